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
#include "server/bench_common.h"

namespace tessera::cli {
namespace {

struct Config {
    std::string label;
    RenderSettings settings;
    BvhType bvh = BvhType::sah;
};

// Time at which the curve first reaches `target` (log-log interpolation), or -1.
double time_to(const ConvergenceCurve& c, double target) {
    for (size_t i = 0; i < c.points.size(); ++i) {
        const auto& p = c.points[i];
        if (p.rel_mse >= 0 && p.rel_mse <= target) {
            if (i == 0) return p.seconds;
            const auto& q = c.points[i - 1];
            const double t = (std::log(target) - std::log(q.rel_mse)) / (std::log(p.rel_mse) - std::log(q.rel_mse));
            return std::exp(std::log(q.seconds) + t * (std::log(p.seconds) - std::log(q.seconds)));
        }
    }
    return -1;
}

}  // namespace

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
    const std::string path = cs184 + "/" + scene_name + ".dae";
    const SceneDescription desc = load_scene(path);
    const RenderScene scene = build_render_scene(desc, RenderSceneOptions{});

    RenderSettings base;
    base.width = width;
    base.height = height;
    base.max_depth = depth;
    base.light_rays = 4;
    base.spp = 1 << 20;  // the time budget ends each run
    // The reference: MIS, many samples, its own seed.
    RenderSettings rs = base;
    rs.spp = ref_spp;
    rs.direct = DirectLighting::mis;
    rs.seed = 987654321;
    const RenderResult ref = render(scene, rs);
    std::fprintf(stderr, "reference: %d spp in %.1f s\n", ref_spp, ref.stats.render_seconds);

    std::vector<Config> configs;
    for (DirectLighting d : {DirectLighting::hemisphere, DirectLighting::importance, DirectLighting::mis}) {
        Config c{d == DirectLighting::hemisphere ? "hemisphere, 4 light rays" : d == DirectLighting::importance ? "importance, 4 light rays" : "MIS, 4 light rays", base};
        c.settings.direct = d;
        configs.push_back(c);
    }
    for (int l : {1, 16, 64}) {
        Config c{"importance, " + std::to_string(l) + " light ray" + (l > 1 ? "s" : ""), base};
        c.settings.light_rays = l;
        configs.push_back(c);
    }
    {
        Config c{"importance, adaptive (batch 16, tol 0.05)", base};
        c.settings.adaptive = AdaptiveSettings{16, 0.05f};
        c.settings.spp = 1 << 14;
        configs.push_back(c);
    }
    for (BvhType t : {BvhType::midpoint, BvhType::median}) {
        Config c{std::string("importance, BVH ") + to_string(t), base};
        c.bvh = t;
        configs.push_back(c);
    }

    std::printf("Scene %s, %d×%d, depth %d, reference %d spp MIS (%.1f s). Each configuration: %d runs of %.1f s "
                "against the reference (relMSE, ε = 0.01).\n\n", scene_name.c_str(), width, height, depth, ref_spp,
                ref.stats.render_seconds, reps, budget);
    std::printf("| configuration | relMSE at %.1f s (mean ± sd) | spp reached | time to relMSE %.3g (s) | efficiency 1/(relMSE·s) |\n"
                "|---|---:|---:|---:|---:|\n", budget, target);
    std::vector<ConvergenceCurve> curves;
    std::vector<std::string> labels;
    for (const Config& c : configs) {
        RenderSceneOptions so;
        so.bvh.type = c.bvh;
        const RenderScene own = c.bvh == BvhType::sah ? RenderScene{} : build_render_scene(desc, so);
        const RenderScene& sc = c.bvh == BvhType::sah ? scene : own;
        std::vector<double> errs, ttt;
        double spp = 0;
        for (int r = 0; r < reps; ++r) {
            RenderSettings st = c.settings;
            st.seed = uint64_t(1000 + r);
            st.time_limit_s = budget;
            RenderCallbacks cb;
            cb.reference = &ref.image;
            const RenderResult res = render(sc, st, cb);
            errs.push_back(res.curve.points.back().rel_mse);
            spp += res.curve.points.back().spp_mean / reps;
            ttt.push_back(time_to(res.curve, target));
            if (r == 0) { curves.push_back(res.curve); labels.push_back(c.label); }
        }
        double m = 0, sd = 0;
        for (double e : errs) m += e / reps;
        for (double e : errs) sd += (e - m) * (e - m) / std::max(1, reps - 1);
        sd = std::sqrt(sd);
        double t_mean = 0;
        int t_n = 0;
        for (double t : ttt) if (t > 0) { t_mean += t; ++t_n; }
        char tt[64];
        if (t_n == reps) std::snprintf(tt, sizeof tt, "%.3f", t_mean / t_n);
        else std::snprintf(tt, sizeof tt, "not reached (%d of %d runs)", t_n, reps);
        std::printf("| %s | %.4g ± %.2g | %.0f | %s | %.3g |\n", c.label.c_str(), m, sd, spp, tt, 1.0 / (m * budget));
        std::fflush(stdout);
    }
    if (!out_svg.empty()) {
        std::ofstream(out_svg) << convergence_svg(curves, labels, scene_name + ": relative MSE against time (first run of each)");
        std::printf("\nPlot: %s\n", out_svg.c_str());
    }
    return 0;
}

}  // namespace tessera::cli
