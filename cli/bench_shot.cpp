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
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "api/job.h"
#include "api/job_runner.h"
#include "engine/io/image_io.h"
#include "engine/render/image.h"
#include "engine/scene/render_scene.h"
#include "cli/bench_common.h"
#include "cli/bench_turntable.h"
#include "cli/command_line.h"

namespace tessera::cli {

using server::parse_args;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

// A deforming shot rendered twice through the shot runner, its world-space tree rebuilt every
// frame, and as shots do by default (built at the first frame of each group of 8, refitted
// for the others): per frame the build and render times side by side, at the same samples (so
// equal quality; the images are compared too). The deformation spans the shot.
int bench_deform(const fs::path& dir, uint64_t triangles, int frames, int width, int height, int spp, double growth) {
    const std::string scene = write_turntable(dir, triangles, double(frames - 1) / 24.0, true);
    const json body = {{"scene", scene}, {"width", width}, {"height", height}, {"spp", spp}, {"max_depth", 3},
                       {"frames", {{"start", 0}, {"end", frames - 1}}}};
    struct Frame { double build, render; std::string built; double sah = 0, built_sah = 0; };
    auto run = [&](RenderSceneOptions::WorldTree how, const char* name) {
        api::RenderJob job = api::parse_render_job(body);
        job.scene_options.world_tree = how;
        job.scene_options.refit_max_sah_growth = growth;
        api::RunOptions opt;
        opt.scene_source = scene;
        api::run_job(job, opt, api::RunOutputs::in_directory((dir / name).string()));
        std::vector<Frame> out;
        for (int n = 0; n < frames; ++n) {
            const json r = json::parse(std::ifstream(dir / name / "frames" / std::to_string(n) / "report.json"));
            std::string built;
            for (const json& line : r["scene"]["built"])
                if (line.get<std::string>().rfind("triangle BVH", 0) == 0) built = line;
            Frame f{r["timings"]["bvh_s"].get<double>(), r["timings"]["render_s"].get<double>(), built};
            const size_t at = built.find("SAH cost ");
            if (at != std::string::npos) std::sscanf(built.c_str() + at, "SAH cost %lf, %lf", &f.sah, &f.built_sah);
            out.push_back(f);
        }
        return out;
    };
    const std::vector<Frame> rebuilt = run(RenderSceneOptions::WorldTree::rebuild, "rebuild");
    const std::vector<Frame> refitted = run(RenderSceneOptions::WorldTree::automatic, "refit");
    std::printf("A %llu-triangle mesh deforming (a morph target, twist and ripple, weight 0 → 1 → 0 over the shot), %d×%d, %d spp, "
                "depth 3, %d frames, all threads: its tree rebuilt each frame against built every 8th frame and refitted between\n\n"
                "| frame | rebuild: build (s) | render (s) | refit: build (s) | render (s) | refit / rebuild, build + render | refit's SAH / as built | same pixels |\n"
                "|---:|---:|---:|---:|---:|---:|---:|---|\n", (unsigned long long)triangles, width, height, spp, frames);
    double a_build = 0, a_render = 0, b_build = 0, b_render = 0;
    int same = 0;
    for (int n = 0; n < frames; ++n) {
        const Frame &a = rebuilt[size_t(n)], &b = refitted[size_t(n)];
        const std::string f = "frames/" + std::to_string(n) + "/image.exr";
        const Image x = read_image((dir / "rebuild" / f).string()), y = read_image((dir / "refit" / f).string());
        const bool eq = x.rgb == y.rgb;
        same += eq;
        std::printf("| %d | %.3f | %.3f | %.3f | %.3f | %.3f | %s | %s |\n", n, a.build, a.render, b.build, b.render,
                    (b.build + b.render) / (a.build + a.render),
                    b.built_sah > 0 ? (std::to_string(b.sah / b.built_sah).substr(0, 5) + (b.built.find("refused") != std::string::npos ? " (refused)" : "")).c_str() : "-",
                    eq ? "yes" : "no");
        if (n > 0) a_build += a.build, a_render += a.render, b_build += b.build, b_render += b.render;
    }
    std::printf("\nframes after the first (mean of %d): rebuild %.3f s build + %.3f s render; refit %.3f s + %.3f s; refit / rebuild "
                "%.3f (build alone %.3f, render alone %.3f); %d of %d frames the same pixels\nlast frame's tree: %s\n",
                frames - 1, a_build / (frames - 1), a_render / (frames - 1), b_build / (frames - 1), b_render / (frames - 1),
                (b_build + b_render) / (a_build + a_render), b_build / a_build, b_render / a_render, same, frames,
                refitted.back().built.c_str());
    return 0;
}

}  // namespace

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
    bool deform = false;
    double growth = RenderSceneOptions{}.refit_max_sah_growth;
    app.add_flag("--deform", deform, "a deforming mesh instead: its tree rebuilt each frame against refitted, side by side");
    app.add_option("--refit-max-sah-growth", growth, "with --deform: the refit's bound")->check(CLI::Range(0.0, 100.0));
    if (const auto status = parse_args(app, argc, argv)) return *status;

    const fs::path dir = fs::temp_directory_path() / ("tessera_bench_shot_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    if (deform) {
        const int rc = bench_deform(dir, triangles, frames, width, height, spp, growth);
        std::error_code ec;
        fs::remove_all(dir, ec);
        return rc;
    }
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
