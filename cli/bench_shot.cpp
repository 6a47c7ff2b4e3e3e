// `tessera bench shot`: what a shot's frame costs beyond rendering it. A turntable of a
// displaced sphere (1M triangles by default) on a ground plane, written as a glTF file with a
// rotation animation, rendered through the one shot runner as a user's job would be; each
// frame's report gives its posing, scene build, render and write times. The per-frame overhead
// is the frame's whole time less its render time, over its render time.
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "api/job.h"
#include "api/job_runner.h"
#include "cli/bench_common.h"
#include "cli/bench_turntable.h"
#include "cli/command_line.h"

namespace tessera::cli {

using server::parse_args;
using nlohmann::json;
namespace fs = std::filesystem;

int bench_shot(int argc, char** argv) {
    CLI::App app{"A shot's per-frame overhead (posing, scene build, scheduling, writing) against its render time, on a "
                 "turntable of a large mesh rendered through the shot runner.", "bench shot"};
    uint64_t triangles = 1'000'000;
    int frames = 6, width = 640, height = 360, spp = 64;
    app.add_option("--triangles", triangles, "triangles of the turning mesh")->check(CLI::Range(8, 20000000));
    app.add_option("--frames", frames, "frames rendered")->check(CLI::Range(2, 1000));
    app.add_option("--width", width)->check(CLI::Range(8, 4096));
    app.add_option("--height", height)->check(CLI::Range(8, 4096));
    app.add_option("--spp", spp)->check(CLI::Range(1, 4096));
    if (const auto status = parse_args(app, argc, argv)) return *status;

    const fs::path dir = fs::temp_directory_path() / ("tessera_bench_shot_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    const std::string scene = write_turntable(dir, triangles, 4.0);
    const json body = {{"scene", scene}, {"width", width}, {"height", height}, {"spp", spp}, {"max_depth", 3},
                       {"frames", {{"start", 0}, {"end", frames - 1}}}};
    api::RunOptions opt;
    opt.scene_source = scene;
    const api::JobOutcome out = api::run_job(api::parse_render_job(body), opt, api::RunOutputs::in_directory((dir / "out").string()));
    std::printf("Turntable of a %llu-triangle mesh, %d×%d, %d spp, depth 3, %d frames, all threads\n\n"
                "| frame | pose (s) | scene build (s) | render (s) | write (s) | whole frame (s) | scene update and scheduling | with writing |\n"
                "|---:|---:|---:|---:|---:|---:|---:|---:|\n", (unsigned long long)triangles, width, height, spp, frames);
    double over_sum = 0, write_sum = 0, render_sum = 0;
    std::string stages;
    int counted = 0;
    for (const json& f : out.report["shot"]["frames"]) {
        const int n = f["frame"];
        const json report = json::parse(std::ifstream(dir / "out" / "frames" / std::to_string(n) / "report.json"));
        const json& t = report["timings"];
        const double whole = f["seconds"], render = t["render_s"], write = t["write_s"];
        std::printf("| %d | %.3f | %.3f | %.3f | %.3f | %.3f | %.2f%% | %.2f%% |\n", n, t["load_s"].get<double>(), t["bvh_s"].get<double>(),
                    render, write, whole, 100.0 * (whole - render - write) / render, 100.0 * (whole - render) / render);
        if (n > 0) {  // the first frame also opens the file
            over_sum += whole - render - write;
            write_sum += write;
            render_sum += render;
            ++counted;
            if (n == 1)
                for (const json& st : report["scene"]["build_stages"])
                    stages += " " + st["stage"].get<std::string>() + " " + std::to_string(st["seconds"].get<double>()).substr(0, 5) + " s;";
        }
    }
    std::printf("\nframes after the first (the first also opens the file), mean of %d: scene update and scheduling %.2f%% of "
                "render time, writing the frame's files %.2f%%\nframe 1's scene build:%s\n",
                counted, 100.0 * over_sum / std::max(1e-9, render_sum), 100.0 * write_sum / std::max(1e-9, render_sum), stages.c_str());
    std::error_code ec;
    fs::remove_all(dir, ec);
    return 0;
}

}  // namespace tessera::cli
