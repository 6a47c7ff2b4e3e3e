// `tessera bench`: benchmarks that reproduce the write-ups' tables, each figure measured in
// this run, side by side, on this machine.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "engine/io/scene_loader.h"
#include "engine/render/renderer.h"
#include "engine/scene/procedural.h"
#include "cli/bench_common.h"
#include "cli/command_line.h"
#include "cli/commands.h"

namespace tessera::cli {

using server::parse_args;
namespace {

struct BenchScene {
    std::string label;
    SceneDescription desc;
};

struct Row {
    std::string scene;
    size_t triangles;
    BvhType type;
    double build_s;
    size_t nodes;
    int depth;
    double sah_cost;
    double render_s;        // at 800×600, 1 spp (scaled from a smaller frame when marked)
    bool scaled;
    double nodes_per_ray, tests_per_ray;
};

Row measure(const BenchScene& s, BvhType type, int threads, double none_budget_tests) {
    RenderSceneOptions o;
    o.bvh.type = type;
    o.min_prims_for_bvh = 0;  // measure the builder even on tiny scenes
    const RenderScene rs = build_render_scene(s.desc, o);
    RenderSettings st;
    st.integrator = Integrator::normals;
    st.spp = 1;
    st.threads = threads;
    st.width = 800;
    st.height = 600;
    bool scaled = false;
    const double full_pixels = 800.0 * 600.0;
    if (type == BvhType::none) {
        // Brute force tests every triangle per ray: render a centred smaller frame with the same
        // focal length when the full frame would take too long, and scale its time.
        const double pixels = std::min(full_pixels, none_budget_tests / double(std::max<size_t>(1, rs.triangle_count())));
        if (pixels < full_pixels) {
            const double f = std::sqrt(pixels / full_pixels);
            st.width = std::max(8, int(800 * f));
            st.height = std::max(6, int(600 * f));
            scaled = true;
        }
    }
    const RenderResult r = render(rs, st);
    const double per_ray = r.stats.rays() ? 1.0 / double(r.stats.rays()) : 0.0;
    const double time = r.stats.render_seconds * full_pixels / (double(st.width) * st.height);
    return Row{s.label, rs.triangle_count(), type, rs.tri_bvh_stats.build_seconds, rs.tri_bvh_stats.node_count,
               rs.tri_bvh_stats.depth, rs.tri_bvh_stats.sah_cost, time, scaled,
               double(r.stats.traversal.nodes_visited) * per_ray, double(r.stats.traversal.prim_tests) * per_ray};
}

int bench_bvh(int argc, char** argv) {
    std::string cs184 = default_cs184_dir();
    int threads = 0;
    uint64_t big = 1'000'000;
    double budget = 2e9;  // triangle tests allowed for the brute-force row of one scene
    CLI::App app{"The BVH table: build time, render time, speedup against brute force and cost per ray, for each "
                 "builder on the CS184 meshes and a displaced sphere.", "bench bvh"};
    app.option_defaults()->always_capture_default();
    app.add_option("--cs184", cs184, "the CS184 scene folder")->type_name("DIR");
    app.add_option("--threads", threads, "render threads (0: all cores)")->check(CLI::Range(0, 1024));
    // The same bounds as `tessera generate displaced_sphere`.
    app.add_option("--big-triangles", big, "triangles in the displaced sphere")
        ->check(CLI::Range(uint64_t{8}, uint64_t{20'000'000}));
    app.add_option("--none-budget", budget, "triangle tests allowed for one scene's brute-force row; beyond it a "
                                            "smaller frame is rendered and its time scaled")
        ->type_name("TESTS")
        ->check(CLI::Range(1.0, 1e13));
    if (const auto status = parse_args(app, argc, argv)) return *status;
    std::vector<BenchScene> scenes;
    for (const char* f : {"meshedit/cow.dae", "sky/CBbunny.dae", "meshedit/maxplanck.dae"}) {
        const std::string path = cs184 + "/" + f;
        if (!std::filesystem::exists(path)) {
            std::fprintf(stderr, "tessera bench: %s not found (pass --cs184 DIR); skipping it\n", path.c_str());
            continue;
        }
        scenes.push_back({std::filesystem::path(f).stem().string(), load_scene(path)});
    }
    scenes.push_back({"displaced_sphere", displaced_sphere(big)});

    std::printf("| scene | triangles | BVH | build (ms) | nodes | depth | SAH cost | render 800×600 1 spp (s) | speedup vs none | nodes/ray | leaf tests/ray | weighted cost/ray |\n");
    std::printf("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    std::vector<std::string> notes;
    // The builders' cost model: one visited node against one leaf test (a block of four triangles).
    const BvhBuildOptions model;
    auto weighted_cost = [&](const Row& r) { return model.traversal_cost * r.nodes_per_ray + model.intersection_cost * r.tests_per_ray; };
    for (const BenchScene& s : scenes) {
        std::vector<Row> rows;
        for (BvhType t : {BvhType::none, BvhType::midpoint, BvhType::median, BvhType::sah}) {
            rows.push_back(measure(s, t, threads, budget));
            std::fflush(stdout);
        }
        const double none_time = rows[0].render_s;
        for (const Row& r : rows) {
            const double weighted = weighted_cost(r);
            std::printf("| %s | %zu | %s | %.1f | %zu | %d | %.2f | %.3f%s | %.0f× | %.1f | %.1f | %.2f |\n", r.scene.c_str(),
                        r.triangles, to_string(r.type), r.build_s * 1e3, r.nodes, r.depth, r.sah_cost, r.render_s,
                        r.scaled ? " (scaled)" : "", none_time / r.render_s, r.nodes_per_ray, r.tests_per_ray, weighted);
        }
        const double mid = weighted_cost(rows[1]);
        const double sah = weighted_cost(rows[3]);
        char buf[256];
        std::snprintf(buf, sizeof buf, "%s: SAH lowers the measured weighted traversal cost per ray by %.1f%% against midpoint "
                                       "(model SAH cost: %.1f%%)", s.label.c_str(), 100.0 * (mid - sah) / mid,
                      100.0 * (rows[1].sah_cost - rows[3].sah_cost) / rows[1].sah_cost);
        notes.push_back(buf);
    }
    std::printf("\n");
    for (const auto& n : notes) std::printf("- %s\n", n.c_str());
    std::printf("- (scaled): brute force rendered a centred crop of the frame with at most %.0e triangle tests; its time is "
                "scaled to 800×600 by the pixel ratio.\n", budget);

    // Camera-ray throughput: CBbunny-like normal shading at 16 spp on 1 thread and on all.
    for (const BenchScene& s : scenes) {
        if (s.label != "CBbunny") continue;
        const RenderScene rs = build_render_scene(s.desc, RenderSceneOptions{});
        std::printf("\nNormal shading, %s, 800×600, 16 spp, SAH:\n", s.label.c_str());
        for (int t : {1, 0}) {
            RenderSettings st;
            st.integrator = Integrator::normals;
            st.width = 800;
            st.height = 600;
            st.spp = 16;
            st.threads = t;
            const RenderResult r = render(rs, st);
            std::printf("- %d thread(s): %.3f s, %.2f M camera rays/s (%.2f per thread)\n", r.stats.threads, r.stats.render_seconds,
                        double(r.stats.camera_rays) / r.stats.render_seconds * 1e-6,
                        double(r.stats.camera_rays) / r.stats.render_seconds * 1e-6 / r.stats.threads);
        }
    }
    return 0;
}

// Light selection: every light sampled (CS184), one light per sample chosen by power, and one
// emitting triangle per sample chosen through the light tree, on scenes lit by many lamps.
// Noise is measured from two renders with different seeds, as the mean per-pixel variance and
// as relative MSE; efficiency = 1 / (noise × time), higher is better.
int bench_lights(int argc, char** argv) {
    int spp = 8, lamps = 32, rays = 4;
    std::pair<int, int> size{320, 240};
    bool scattered = false, field = false, open = false;
    CLI::App app{"Light selection: every light sampled, one light per sample chosen by power, and one emitting triangle "
                 "per sample chosen through the light tree, on a box lit by many lamps; noise, time and efficiency "
                 "1/(variance × time).", "bench lights"};
    app.option_defaults()->always_capture_default();
    app.add_option("--spp", spp, "samples per pixel")->check(CLI::Range(1, 1 << 16));
    app.add_option("--lamps", lamps, "lamps in the box")->check(CLI::Range(1, 4096));
    app.add_option("--rays", rays, "light rays (per light with 'all', in all otherwise)")->check(CLI::Range(1, 64));
    app.add_option("-r", size, "image width and height")->type_name("W H")->check(CLI::Range(8, 4096));
    app.add_flag("--scattered", scattered, "lamps scattered through the box's volume (builtin:scattered_lights), not on its ceiling");
    app.add_flag("--field", field, "equal lamps over a 40 m field among blocks (builtin:lamp_field)");
    app.add_flag("--open", open, "with --field: the same lamps without the blocks (what occlusion costs)");
    if (const auto status = parse_args(app, argc, argv)) return *status;
    const RenderScene scene = build_render_scene(field       ? lamp_field(lamps, !open)
                                                 : scattered ? scattered_lights(lamps)
                                                             : many_lights(lamps),
                                                 RenderSceneOptions{});
    std::printf("builtin:%s (%d lamps), %d×%d, %d spp, %d light rays, direct light only (bounce 1), light sampling, independent samples\n\n",
                field ? (open ? "lamp_field without blocks" : "lamp_field") : scattered ? "scattered_lights" : "many_lights", lamps, size.first, size.second, spp, rays);
    std::printf("| selection | time (s) | shadow rays | mean | per-pixel variance | efficiency 1/(var·s) | relMSE | 1/(relMSE·s) |\n"
                "|---|---:|---:|---:|---:|---:|---:|---:|\n");
    double eff_all = 0, rel_all = 0;
    std::vector<double> reference;  // every light's two renders averaged: the least noisy image here
    for (LightSelection sel : {LightSelection::all, LightSelection::power, LightSelection::tree}) {
        RenderSettings st;
        st.width = size.first;
        st.height = size.second;
        st.spp = spp;
        st.light_rays = rays;
        st.sampler = SamplerKind::independent;  // the two seeds' difference is then pure noise
        // Bounce 1 only: the lamps seen directly add the same pixel-integration noise to every
        // selection and would hide the difference being measured.
        st.max_depth = 1;
        st.bounces = BounceMode::nth;
        st.light_selection = sel;
        st.seed = 1;
        const RenderResult a = render(scene, st);
        st.seed = 2;
        const RenderResult b = render(scene, st);
        if (reference.empty())
            for (size_t i = 0; i < a.image.rgb.size(); ++i) reference.push_back(0.5 * (double(a.image.rgb[i]) + b.image.rgb[i]));
        // Each estimator is unbiased, so (a − b)²/2 estimates one render's variance, which is its
        // MSE; relMSE divides it by a denominator independent of the two renders (the reference,
        // ε = 0.01 as in bench convergence), so a firefly in one render counts in full instead of
        // also inflating the mean it is divided by.
        double var = 0, mean = 0, rel = 0;
        for (size_t i = 0; i < a.image.rgb.size(); ++i) {
            const double d = double(a.image.rgb[i]) - b.image.rgb[i];
            var += d * d / 2;
            mean += 0.5 * (double(a.image.rgb[i]) + b.image.rgb[i]);
            rel += d * d / 2 / (reference[i] * reference[i] + 0.01);
        }
        rel /= double(a.image.rgb.size());
        var /= double(a.image.rgb.size());
        mean /= double(a.image.rgb.size());
        const double time = 0.5 * (a.stats.render_seconds + b.stats.render_seconds);
        const double eff = 1.0 / (var * time);
        if (sel == LightSelection::all) eff_all = eff, rel_all = 1.0 / (rel * time);
        std::printf("| %s | %.3f | %llu | %.4f | %.3g | %.3g (%.2f×) | %.3g | %.3g (%.2f×) |\n",
                    sel == LightSelection::all ? "all" : sel == LightSelection::power ? "power" : "tree", time,
                    (unsigned long long)a.stats.shadow_rays, mean, var, eff, eff / eff_all, rel, 1.0 / (rel * time),
                    1.0 / (rel * time) / rel_all);
    }
    return 0;
}

struct Kind {
    const char* name;
    int (*run)(int argc, char** argv);
    const char* what;
};

const Kind kKinds[] = {
    {"bvh", bench_bvh, "the BVH table: build time, render time, speedup, cost per ray"},
    {"figures", bench_figures, "the write-ups' comparison images and tables (docs/figures)"},
    {"lights", bench_lights, "light selection: every light, by power, and by the light tree"},
    {"server", bench_server, "the HTTP server: request latency, throughput, overhead per job"},
    {"convergence", bench_convergence, "sampling strategies at equal time against a reference"},
    {"leave-out", bench_leave_out, "what leaving out unneeded work saves"},
    {"rays", bench_rays, "our BVH and Embree on the same rays"},
    {"prepare", bench_prepare, "scene preparation: every stage on 1 and 2 threads beside Embree, peak memory, cache hits"},
    {"cluster", bench_cluster, "a render farm: tile hand-offs, overhead per tile, two nodes against one process"},
    {"instances", bench_instances, "instancing: memory of many placements against one, time against the flattened scene"},
    {"shot", bench_shot, "a shot's per-frame overhead (pose, build, write) against its render time"},
    {"materials", bench_materials, "the energy each BSDF keeps, and the CS184 material scenes with their time"},
    {"denoise", bench_denoise, "the denoiser: true and estimated error of noisy and denoised images, its time, the time saved"},
};

}  // namespace

int bench_command(int argc, char** argv) {
    std::vector<std::string> names;
    std::string kinds_help = "Kinds:\n", usage = "usage: tessera bench ";
    for (const Kind& k : kKinds) {
        char line[160];
        std::snprintf(line, sizeof line, "  %-13s %s\n", k.name, k.what);
        kinds_help += line;
        usage += (names.empty() ? "" : "|") + std::string(k.name);
        names.emplace_back(k.name);
    }
    usage += " [options]\n";
    CLI::App app{"Benchmarks that reproduce the write-ups' tables, each figure measured in this run, on this machine. "
                 "'tessera bench KIND --help' lists a kind's options.", "bench"};
    app.footer(kinds_help);
    std::string kind;
    app.add_option("kind", kind, "which benchmark")->type_name("KIND")->check(CLI::IsMember(names));
    // Only the first word is the dispatcher's: the rest belongs to the kind, whose own parser
    // reads it (and answers its --help).
    const auto status = parse_args(app, std::min(argc, 1), argv);
    if (status == 0) return 0;  // --help
    if (status || kind.empty()) {
        std::fputs(usage.c_str(), stderr);
        return 2;
    }
    const Kind* k = std::find_if(std::begin(kKinds), std::end(kKinds), [&](const Kind& c) { return kind == c.name; });
    return k->run(argc - 1, argv + 1);
}

}  // namespace tessera::cli
