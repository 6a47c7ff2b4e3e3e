#include "engine/scene/render_scene.h"

#include <gtest/gtest.h>

#include "engine/render/renderer.h"
#include "engine/scene/procedural.h"

namespace tessera {
namespace {

bool mentions(const std::vector<std::string>& v, const char* what) {
    for (const auto& s : v) if (s.find(what) != std::string::npos) return true;
    return false;
}

// A scene without spheres builds no sphere structure and never runs the sphere test; a scene
// without triangles builds no triangle BVH.
TEST(RenderScene, LeavesOutPrimitiveKindsTheSceneLacks) {
    const RenderScene box = build_render_scene(cornell_box(), {});
    EXPECT_TRUE(box.spheres.empty());
    EXPECT_TRUE(box.sphere_bvh.empty());
    EXPECT_TRUE(mentions(box.report.left_out, "spheres: none"));
    SceneDescription only_spheres;
    only_spheres.spheres.push_back({glm::vec3(0.f), 1.f, -1, {}});
    const RenderScene s = build_render_scene(only_spheres, {});
    EXPECT_EQ(s.tri_bvh_stats.node_count, 0u);
    EXPECT_TRUE(s.tri_wide.empty());
    EXPECT_TRUE(s.tri_blocks.empty());
    EXPECT_TRUE(mentions(s.report.left_out, "triangles: none"));
}

// A lone primitive needs no BVH: it is tested directly (above that, a BVH; docs/benchmarks.md,
// "leaving out", has the measurement behind the rule).
TEST(RenderScene, NoBvhOverALonePrimitive) {
    SceneDescription d;
    MeshDesc m;
    m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    m.indices = {0, 1, 2};
    d.meshes.push_back(m);
    const RenderScene s = build_render_scene(d, {});
    EXPECT_EQ(s.tri_bvh_stats.node_count, 1u);
    EXPECT_TRUE(s.tri_wide.nodes.empty());
    EXPECT_EQ(s.tri_wide.root_leaf_count, 1u);
    EXPECT_TRUE(mentions(s.report.left_out, "tested directly"));
    const RenderScene box = build_render_scene(cornell_box(), {});
    EXPECT_GT(box.tri_bvh_stats.node_count, 1u);
}

// No emitters: no light structures, no shadow rays, and a warning.
TEST(RenderScene, NoEmittersMeansNoLightSamplingAndAWarning) {
    SceneDescription d = cornell_box();
    d.materials[3].emission = glm::vec3(0.f);
    const RenderScene s = build_render_scene(d, {});
    EXPECT_TRUE(s.area_lights.empty());
    EXPECT_TRUE(s.light_triangles.empty());
    EXPECT_TRUE(mentions(s.report.warnings, "no lights or emitters"));
    RenderSettings st;
    st.width = 16;
    st.height = 12;
    st.max_depth = 4;
    const RenderResult r = render(s, st);
    EXPECT_EQ(r.stats.shadow_rays, 0u);
    EXPECT_TRUE(mentions(r.left_out, "no shadow rays"));
}

// max_depth ≤ 1 traces no bounce rays.
TEST(RenderScene, NoIndirectBouncesAtDepthOne) {
    const RenderScene s = build_render_scene(cornell_spheres(), {});
    RenderSettings st;
    st.width = 16;
    st.height = 12;
    st.max_depth = 1;
    const RenderResult r = render(s, st);
    EXPECT_EQ(r.stats.bounce_rays, 0u);
    EXPECT_TRUE(mentions(r.left_out, "indirect bounces"));
    st.max_depth = 3;
    EXPECT_GT(render(s, st).stats.bounce_rays, 0u);
}

}  // namespace
}  // namespace tessera
