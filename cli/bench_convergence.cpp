// `tessera bench convergence`: sampling strategies compared fairly, at equal time. Each
// configuration renders the same scene several times for the same time budget against a
// converged reference; the table gives the error at equal time (mean ± standard deviation over
// the repetitions, since one MSE is itself noisy), the time to reach a target error, and the
// efficiency 1/(relMSE·time); one SVG plots a curve per configuration.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "engine/io/scene_loader.h"
#include "engine/render/renderer.h"
#include "cli/bench_common.h"
#include "api/comparison.h"

namespace tessera::cli {

int bench_convergence(int argc, char** argv) {
    std::string cs184 = default_cs184_dir(), scene_name = "sky/CBspheres_lambertian", out_svg;
    int width = 160, height = 120, reps = 3, ref_spp = 2048, depth = 5;
    double budget = 2.0, target = 0.01;
    for (int i = 0; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--cs184" && i + 1 < argc) cs184 = argv[++i];
        else if (a == "--scene" && i + 1 < argc) scene_name = argv[++i];
        else if (a == "-r" && i + 2 < argc) { width = std::atoi(argv[++i]); height = std::atoi(argv[++i]); }
        else if (a == "--seconds" && i + 1 < argc) budget = std::atof(argv[++i]);
        else if (a == "--reps" && i + 1 < argc) reps = std::atoi(argv[++i]);
        else if (a == "--ref-spp" && i + 1 < argc) ref_spp = std::atoi(argv[++i]);
        else if (a == "--target" && i + 1 < argc) target = std::atof(argv[++i]);
        else if (a == "--depth" && i + 1 < argc) depth = std::atoi(argv[++i]);
        else if (a == "--svg" && i + 1 < argc) out_svg = argv[++i];
        else {
            std::fprintf(stderr, "usage: tessera bench convergence [--scene sky/CBbunny] [-r W H] [--seconds S] [--reps N] "
                                 "[--ref-spp N] [--target E] [--depth N] [--svg FILE] [--cs184 DIR]\n");
            return 2;
        }
    }
    if (width < 8 || height < 8 || width > 2048 || height > 2048 || reps < 1 || reps > 50 || !(budget > 0) || ref_spp < 1 ||
        !(target > 0) || depth < 0 || depth > 100) {
        std::fprintf(stderr, "tessera bench convergence: an option is out of range\n");
        return 2;
    }
    const SceneDescription desc = load_scene(cs184 + "/" + scene_name + ".dae");
    RenderSettings base;
    base.width = width;
    base.height = height;
    base.max_depth = depth;
    const api::ComparisonResult r =
        api::run_comparison(desc, api::standard_configs(base), base, ref_spp, budget, reps, target);
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
