// `tessera bench instances`: what instancing costs and saves, measured side by side in one run.
// Memory: N placements of one mesh against one placement (the target: at most 1.2 times one
// copy's BVH plus 100 bytes per placement). Time: the same field instanced and flattened into
// world-space meshes, rendered alike (what entering a placement costs a ray).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "engine/render/renderer.h"
#include "engine/scene/instancing.h"
#include "engine/scene/prototype_cache.h"
#include "engine/scene/procedural.h"
#include "cli/bench_common.h"
#include "cli/command_line.h"

namespace tessera::cli {

using server::parse_args;

namespace {

struct Prepared {
    RenderScene scene;
    double seconds = 0;
};

Prepared prepare(const SceneDescription& d) {
    const auto t0 = std::chrono::steady_clock::now();
    Prepared p{build_render_scene(d, {}), 0};
    p.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return p;
}

}  // namespace

int bench_instances(int argc, char** argv) {
    CLI::App app{"Instancing: memory of many placements of one mesh against one placement, and render time of an "
                 "instanced field against the same field flattened.", "bench instances"};
    uint32_t count = 10000, flat_count = 100;
    uint64_t triangles = 100000, flat_triangles = 10000;
    int spp = 8;
    app.add_option("--count", count, "placements for the memory measurement")->check(CLI::Range(2, 1000000));
    app.add_option("--triangles", triangles, "triangles of the placed mesh for the memory measurement")->check(CLI::Range(8, 20000000));
    app.add_option("--flat-count", flat_count, "placements for the time measurement (flattened too)")->check(CLI::Range(1, 10000));
    app.add_option("--flat-triangles", flat_triangles, "triangles of the placed mesh for the time measurement")->check(CLI::Range(8, 1000000));
    app.add_option("--spp", spp, "samples per pixel of the renders")->check(CLI::Range(1, 1024));
    if (const auto status = parse_args(app, argc, argv)) return *status;

    const Prepared one = prepare(instanced_field(1, triangles));
    const Prepared many = prepare(instanced_field(count, triangles));
    const double bvh1 = double(one.scene.triangle_accel_bytes());
    const double bvhn = double(many.scene.triangle_accel_bytes());
    const double budget = 1.2 * bvh1 + 100.0 * count;
    std::printf("Memory: %u placements of a %zu-triangle mesh against one (BVH, blocks of triangles, placements and "
                "the tree over them)\n\n| placements | triangles placed | BVH bytes | bytes per placement beyond one | "
                "target (1.2 × one + 100 B each) | within | prepare (s) |\n|---:|---:|---:|---:|---:|---|---:|\n",
                count, size_t(one.scene.prototypes.empty() ? 0 : one.scene.prototypes[0].triangles));
    std::printf("| 1 | %zu | %.0f | - | - | - | %.3f |\n", size_t(one.scene.prototypes[0].triangles), bvh1, one.seconds);
    std::printf("| %u | %zu | %.0f | %.1f | %.0f | %s | %.3f |\n", count, size_t(one.scene.prototypes[0].triangles) * count, bvhn,
                (bvhn - bvh1) / double(count - 1), budget, bvhn <= budget ? "yes" : "NO", many.seconds);

    // Time: the same scene both ways, rendered alike.
    const SceneDescription field = instanced_field(flat_count, flat_triangles);
    SceneDescription flat = field;
    flatten_instances(flat);
    const Prepared inst = prepare(field);
    const Prepared world = prepare(flat);
    RenderSettings st;
    st.width = 640;
    st.height = 360;
    st.spp = spp;
    st.max_depth = 3;
    const RenderResult ri = render(inst.scene, st);
    const RenderResult rf = render(world.scene, st);
    auto mean = [](const RenderResult& r) {
        double s = 0;
        for (float v : r.image.rgb) s += v;
        return s / double(std::max<size_t>(1, r.image.rgb.size()));
    };
    std::printf("\nTime: %u placements of a %zu-triangle mesh, instanced and flattened, 640×360, %d spp, depth 3, all threads\n\n"
                "| scene | triangles stored | BVH bytes | prepare (s) | render (s) | mean radiance |\n|---|---:|---:|---:|---:|---:|\n",
                flat_count, size_t(inst.scene.prototypes.empty() ? 0 : inst.scene.prototypes[0].triangles), spp);
    std::printf("| instanced | %zu | %zu | %.3f | %.3f | %.5f |\n", inst.scene.triangle_count(), inst.scene.triangle_accel_bytes(),
                inst.seconds, ri.stats.render_seconds, mean(ri));
    std::printf("| flattened | %zu | %zu | %.3f | %.3f | %.5f |\n", world.scene.triangle_count(), world.scene.triangle_accel_bytes(),
                world.seconds, rf.stats.render_seconds, mean(rf));
    std::printf("\ninstanced / flattened: render time %.2f, preparation %.3f, BVH bytes %.4f\n",
                ri.stats.render_seconds / rf.stats.render_seconds, inst.seconds / world.seconds,
                double(inst.scene.triangle_accel_bytes()) / double(world.scene.triangle_accel_bytes()));

    // A shot's next frame with the placements moved: the prototype's tree kept from the last
    // frame (PrototypeCache) against built again. Medians of 5.
    SceneDescription moving = instanced_field(flat_count, triangles);
    PrototypeCache cache;
    build_render_scene(moving, {}, &cache);
    std::vector<double> kept, rebuilt;
    for (int k = 0; k < 5; ++k) {
        for (InstanceDesc& in : moving.instances) in.to_world[3].x += 0.01f;
        auto t0 = std::chrono::steady_clock::now();
        build_render_scene(moving, {}, &cache);
        kept.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        t0 = std::chrono::steady_clock::now();
        build_render_scene(moving, {});
        rebuilt.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    std::sort(kept.begin(), kept.end());
    std::sort(rebuilt.begin(), rebuilt.end());
    std::printf("\nA frame's scene build, %u placements of a %zu-triangle mesh moved: prototype tree kept %.4f s, "
                "built again %.4f s (kept / built %.2f; medians of 5)\n",
                flat_count, size_t(one.scene.prototypes[0].triangles), kept[2], rebuilt[2], kept[2] / rebuilt[2]);
    return bvhn <= budget ? 0 : 1;
}

}  // namespace tessera::cli
