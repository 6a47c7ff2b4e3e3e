// tessera: one executable with subcommands.
#include <cstdio>
#include <cstring>
#include <exception>

#include "cli/commands.h"
#include "cli/serve_command.h"

namespace {

void usage() {
    std::puts(
        "usage: tessera <command> [options]\n"
        "  serve [options]        the HTTP render server ('tessera serve --help'); with --redis an\n"
        "                         API node of a render farm\n"
        "  worker --redis URL     a render node of a farm: renders tiles queued in Redis\n"
        "  render [flags] SCENE   render a scene to PNG/EXR (CS184 flags; 'tessera render --help')\n"
        "  bench bvh [options]    the BVH table (build time, render time, speedup, cost per ray)\n"
        "  bench figures [opts]   the write-ups' comparison images and tables (docs/figures)\n"
        "  generate NAME FILE     write a built-in scene as glTF (cornell_box, cornell_spheres,\n"
        "                         displaced_sphere [--triangles N]); how scenes/ is made\n");
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h")) {
        usage();
        return argc < 2 ? 2 : 0;
    }
    try {
        if (!std::strcmp(argv[1], "render")) return tessera::cli::render_command(argc - 2, argv + 2);
        if (!std::strcmp(argv[1], "serve")) return tessera::server::serve_command(argc - 2, argv + 2);
        if (!std::strcmp(argv[1], "worker")) return tessera::server::worker_command(argc - 2, argv + 2);
        if (!std::strcmp(argv[1], "bench")) return tessera::cli::bench_command(argc - 2, argv + 2);
        if (!std::strcmp(argv[1], "generate")) return tessera::cli::generate_command(argc - 2, argv + 2);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "tessera: %s\n", e.what());
        return 1;
    }
    std::fprintf(stderr, "tessera: unknown command '%s'\n", argv[1]);
    usage();
    return 2;
}
