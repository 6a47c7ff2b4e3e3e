// `tessera bench leave-out`: what leaving out unneeded work saves, measured side by side.
#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>

#include "engine/render/film.h"
#include "engine/render/renderer.h"
#include "engine/scene/procedural.h"
#include "cli/bench_common.h"
#include "cli/command_line.h"

namespace tessera::cli {

using server::parse_args;

int bench_leave_out(int argc, char** argv) {
    // No options, but a parser all the same: --help works and a stray argument is an error.
    CLI::App app{"What leaving out unneeded work saves: a BVH over a handful of primitives, the error estimate and "
                 "adaptive statistics, each on and off.", "bench leave-out"};
    if (const auto status = parse_args(app, argc, argv)) return *status;
    // 1. A BVH over a handful of primitives against testing them all (camera + shadow rays).
    std::printf("Small scenes: triangle BVH (SAH, wide) against one leaf tested directly; CBspheres-like box, "
                "320×240, 16 spp, depth 2, 1 thread\n\n| triangles | BVH (s) | one leaf (s) | one leaf / BVH |\n|---:|---:|---:|---:|\n");
    for (size_t keep : {1, 2, 4, 6}) {
        SceneDescription d = cornell_spheres();
        if (keep < d.meshes.size()) d.meshes.erase(d.meshes.begin() + long(keep), d.meshes.end() - 1);  // keep the lamp
        double t[2];
        for (int leaf = 0; leaf < 2; ++leaf) {
            RenderSceneOptions o;
            o.min_prims_for_bvh = leaf ? 1'000'000 : 0;
            const RenderScene s = build_render_scene(d, o);
            RenderSettings st;
            st.width = 320;
            st.height = 240;
            st.spp = 16;
            st.max_depth = 2;
            st.threads = 1;
            t[leaf] = render(s, st).stats.render_seconds;
        }
        std::printf("| %zu | %.3f | %.3f | %.2f |\n", d.triangle_count(), t[0], t[1], t[1] / t[0]);
    }
    // 2. Error estimation (passes and the half buffer) and adaptive statistics, on and off.
    std::printf("\nFilm buffers and passes: CBspheres box, 320×240, 64 spp, depth 2, all threads\n\n"
                "| render | time (s) | passes | extra bytes per pixel |\n|---|---:|---:|---:|\n");
    const RenderScene s = build_render_scene(cornell_spheres(), {});
    RenderSettings st;
    st.width = 320;
    st.height = 240;
    st.spp = 64;
    st.max_depth = 2;
    const RenderResult plain = render(s, st);
    std::printf("| plain (one pass, sum and count only) | %.3f | %zu | 0 |\n", plain.stats.render_seconds, plain.curve.points.size());
    st.estimate_error = true;
    const RenderResult est = render(s, st);
    std::printf("| with the error estimate (doubling passes, half buffer) | %.3f | %zu | %zu |\n", est.stats.render_seconds,
                est.curve.points.size(), sizeof(glm::dvec3));
    st.estimate_error = false;
    st.adaptive = AdaptiveSettings{64, 0.0f};  // tolerance 0: runs every sample, only the bookkeeping differs
    const RenderResult ad = render(s, st);
    std::printf("| with adaptive statistics (tolerance 0, so the same samples) | %.3f | %zu | %zu |\n", ad.stats.render_seconds,
                ad.curve.points.size(), sizeof(RunningStats) + 1);
    return 0;
}

}  // namespace tessera::cli
