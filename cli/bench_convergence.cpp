// `tessera bench convergence`: sampling strategies compared fairly, at equal time. Each
// configuration renders the same scene several times for the same time budget against a
// converged reference; the table gives the error at equal time (mean ± standard deviation over
// the repetitions, since one MSE is itself noisy), the time to reach a target error, and the
// efficiency 1/(relMSE·time); one SVG plots a curve per configuration.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "engine/io/scene_loader.h"
#include "engine/render/renderer.h"
#include "cli/bench_common.h"
#include "cli/command_line.h"
#include "api/comparison.h"
#include "api/job_runner.h"

namespace tessera::cli {

using server::parse_args;

int bench_convergence(int argc, char** argv) {
    std::string cs184 = default_cs184_dir(), scene_name = "sky/CBspheres_lambertian", out_svg;
    std::pair<int, int> size{160, 120};
    int reps = 3, ref_spp = 2048, depth = 5;
    double budget = 2.0, target = 0.01;
    CLI::App app{"Sampling strategies compared at equal time against a converged reference: error at equal time, "
                 "time to a target error, efficiency, and optionally an SVG of the curves.", "bench convergence"};
    app.option_defaults()->always_capture_default();
    app.add_option("--scene", scene_name, "a CS184 scene, without .dae (e.g. sky/CBbunny); or a .gltf/.glb/.dae file, or builtin:NAME")
        ->type_name("NAME");
    std::string environment;
    app.add_option("--environment", environment, "a lat-long .exr/.hdr map lighting the scene from infinity")->type_name("FILE");
    app.add_option("-r", size, "image width and height (160 120)")->type_name("W H")->check(CLI::Range(8, 2048));
    app.add_option("--seconds", budget, "time budget of each run")->type_name("S")->check(CLI::Range(0.01, 3600.0));
    app.add_option("--reps", reps, "runs of each configuration")->check(CLI::Range(1, 50));
    app.add_option("--ref-spp", ref_spp, "samples per pixel of the reference")->check(CLI::Range(1, 1 << 20));
    app.add_option("--target", target, "relative MSE to reach for the time-to-error column")
        ->type_name("E")
        ->check(CLI::Range(1e-6, 100.0));
    app.add_option("--depth", depth, "maximum bounce depth")->check(CLI::Range(0, 100));
    app.add_option("--svg", out_svg, "also plot the curves to this file")->type_name("FILE");
    bool samplers = false;
    app.add_flag("--samplers", samplers, "compare Sobol points against independent sampling (light sampling with 1 and 4 "
                                         "light rays, MIS with 4), instead of the standard strategies");
    bool defaults = false;
    app.add_flag("--defaults", defaults, "compare the candidates for the default direct lighting (hemisphere, importance and "
                                         "MIS at 1 light ray, glossy lobes by MIS in all), instead of the standard strategies");
    app.add_option("--cs184", cs184, "the CS184 scene folder")->type_name("DIR");
    if (const auto status = parse_args(app, argc, argv)) return *status;
    const int width = size.first, height = size.second;
    const bool file = scene_name.rfind("builtin:", 0) == 0 || std::filesystem::path(scene_name).has_extension();
    const SceneDescription desc = load_scene(file ? scene_name : cs184 + "/" + scene_name + ".dae");
    RenderSettings base;
    base.width = width;
    base.height = height;
    base.max_depth = depth;
    if (!environment.empty()) base.environment = api::load_environment(environment);
    std::vector<api::ComparisonConfig> configs;
    if (defaults) {
        for (DirectLighting d : {DirectLighting::hemisphere, DirectLighting::importance, DirectLighting::mis}) {
            api::ComparisonConfig c{d == DirectLighting::hemisphere ? "hemisphere, 1 light ray"
                                    : d == DirectLighting::importance ? "importance, 1 light ray" : "MIS, 1 light ray", base, {}};
            c.settings.direct = d;
            configs.push_back(c);
        }
    } else if (samplers) {
        for (const auto& [direct, rays, what] : {std::tuple{DirectLighting::importance, 1, "importance, 1 light ray"},
                                                 std::tuple{DirectLighting::importance, 4, "importance, 4 light rays"},
                                                 std::tuple{DirectLighting::mis, 4, "MIS, 4 light rays"}})
            for (SamplerKind k : {SamplerKind::independent, SamplerKind::sobol}) {
                api::ComparisonConfig c{std::string(what) + (k == SamplerKind::sobol ? ", Sobol" : ", independent"), base, {}};
                c.settings.direct = direct;
                c.settings.light_rays = rays;
                c.settings.sampler = k;
                configs.push_back(c);
            }
    } else {
        configs = api::standard_configs(base);
    }
    const api::ComparisonResult r = api::run_comparison(desc, configs, base, ref_spp, budget, reps, target);
    std::printf("Scene %s, %d×%d, depth %d, reference %d spp MIS (%.1f s). Each configuration: %d runs of %.1f s "
                "against the reference (relMSE, ε = 0.01).\n\n%s", scene_name.c_str(), width, height, depth, ref_spp,
                r.reference_seconds, reps, budget, api::comparison_markdown(r, budget, target).c_str());
    if (!out_svg.empty()) {
        std::ofstream(out_svg) << api::comparison_svg(r, scene_name + ": relative MSE against time (first run of each)");
        std::printf("\nPlot: %s\n", out_svg.c_str());
    }
    return 0;
}

}  // namespace tessera::cli
