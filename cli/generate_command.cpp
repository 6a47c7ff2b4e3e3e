// `tessera generate`: writes our procedural scenes as glTF files (scenes/ is made with it).
#include <cstdio>
#include <cstdlib>
#include <string>

#include "engine/io/gltf_writer.h"
#include "engine/scene/procedural.h"
#include "cli/commands.h"

namespace tessera::cli {

int generate_command(int argc, char** argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: tessera generate cornell_box|cornell_spheres|displaced_sphere FILE.gltf [--triangles N]\n");
        return 2;
    }
    const std::string name = argv[0], path = argv[1];
    uint64_t triangles = 1'000'000;
    for (int i = 2; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--triangles" && i + 1 < argc) triangles = std::strtoull(argv[++i], nullptr, 10);
        else { std::fprintf(stderr, "tessera generate: unknown option %s\n", a.c_str()); return 2; }
    }
    SceneDescription scene;
    if (name == "cornell_box") scene = cornell_box();
    else if (name == "cornell_spheres") scene = cornell_spheres();
    else if (name == "displaced_sphere") {
        if (triangles < 8 || triangles > 20'000'000) { std::fprintf(stderr, "tessera generate: --triangles must lie in [8, 2e7]\n"); return 2; }
        scene = displaced_sphere(triangles);
    } else {
        std::fprintf(stderr, "tessera generate: unknown scene '%s'\n", name.c_str());
        return 2;
    }
    write_gltf(path, scene);
    std::printf("wrote %s\n", path.c_str());
    return 0;
}

}  // namespace tessera::cli
