#include "engine/scene/render_scene.h"

#include <algorithm>
#include <cstring>

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


// The preparation's passes run on several threads over disjoint ranges: the scene they make,
// to the byte, does not depend on how many.
TEST(RenderScene, SameSceneWhateverTheBuildThreadCount) {
    // Large enough that every pass splits: gathering (16k triangles a range), the BVH's
    // subtrees (4k) and packing (4k wide nodes a range).
    const SceneDescription d = displaced_sphere(200'000);
    RenderSceneOptions one;
    one.bvh.build_threads = 1;
    const RenderScene a = build_render_scene(d, one);
    ASSERT_GT(a.tri_wide.nodes.size(), 2u * 4096u);
    for (int threads : {2, 3}) {
        RenderSceneOptions o;
        o.bvh.build_threads = threads;
        const RenderScene b = build_render_scene(d, o);
        ASSERT_EQ(a.tri_blocks.size(), b.tri_blocks.size());
        EXPECT_EQ(0, std::memcmp(a.tri_blocks.data(), b.tri_blocks.data(), a.tri_blocks.size() * sizeof(Triangle4))) << threads;
        ASSERT_EQ(a.tri_wide.nodes.size(), b.tri_wide.nodes.size());
        EXPECT_EQ(0, std::memcmp(a.tri_wide.nodes.data(), b.tri_wide.nodes.data(), a.tri_wide.nodes.size() * sizeof(WideNode)));
        ASSERT_EQ(a.tri_shading.size(), b.tri_shading.size());
        for (size_t i = 0; i < a.tri_shading.size(); ++i) {
            const TriangleShading &x = a.tri_shading[i], &y = b.tri_shading[i];
            ASSERT_TRUE(x.n0 == y.n0 && x.n1 == y.n1 && x.n2 == y.n2 && x.material == y.material && x.light == y.light) << i;
        }
        ASSERT_EQ(a.normals.size(), b.normals.size());
        EXPECT_EQ(0, std::memcmp(a.normals.data(), b.normals.data(), a.normals.size() * sizeof(glm::vec3)));
        EXPECT_EQ(a.bounds.lo, b.bounds.lo);
        EXPECT_EQ(a.bounds.hi, b.bounds.hi);
        EXPECT_EQ(a.tri_bvh_stats.sah_cost, b.tri_bvh_stats.sah_cost);
    }
}

// Shading data stays in the input's order and each block lane names its triangle there: a
// lane holds exactly the vertices of the triangle tri_shading[prim] describes, and every
// triangle is in some lane, with our BVH and with Embree's plain order alike.
TEST(RenderScene, LanesNameTheirTrianglesInInputOrder) {
    const SceneDescription d = displaced_sphere(40'000);
    ASSERT_EQ(d.meshes.size(), 1u);
    const MeshDesc& mesh = d.meshes[0];
    std::vector<RenderSceneOptions> builds(1);
    if (embree_available()) {
        builds.emplace_back();
        builds.back().bvh.type = BvhType::embree;
    }
    for (const RenderSceneOptions& o : builds) {
        const RenderScene s = build_render_scene(d, o);
        ASSERT_EQ(s.triangle_count(), mesh.indices.size() / 3);
        std::vector<char> seen(s.triangle_count(), 0);
        for (const Triangle4& block : s.tri_blocks)
            for (int l = 0; l < 4; ++l) {
                const uint32_t prim = block.prim[l];
                ASSERT_LT(prim, s.triangle_count());
                seen[prim] = 1;
                const TriangleShading& sh = s.tri_shading[prim];
                ASSERT_EQ(sh.n0, mesh.indices[3 * prim]);
                ASSERT_EQ(sh.n1, mesh.indices[3 * prim + 1]);
                ASSERT_EQ(sh.n2, mesh.indices[3 * prim + 2]);
                const TriangleVerts v = triangle4_verts(block, l);
                ASSERT_EQ(v.p0, mesh.positions[sh.n0]);
                ASSERT_EQ(v.p1, mesh.positions[sh.n1]);
                ASSERT_EQ(v.p2, mesh.positions[sh.n2]);
            }
        EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), std::ptrdiff_t(s.triangle_count())) << to_string(o.bvh.type);
    }
}

// The report says where the preparation's time went, stage by stage, in order.
TEST(RenderScene, ReportsEachStageOfThePreparation) {
    const RenderScene s = build_render_scene(displaced_sphere(5'000), {});
    std::vector<std::string> names;
    double sum = 0;
    for (const BuildStage& st : s.report.stages) {
        names.push_back(st.name);
        EXPECT_GE(st.seconds, 0.0);
        sum += st.seconds;
    }
    const std::vector<std::string> want = {"gather", "lights", "bvh build", "collapse", "pack blocks", "spheres", "camera"};
    EXPECT_EQ(names, want);
    EXPECT_LE(sum, s.report.seconds + 1e-6);
}

// A description built in code whose normals do not pair with its positions (validate() refuses
// such files) gets computed normals, not a copy past the end of the array.
TEST(RenderScene, NormalsThatDoNotPairWithPositionsAreComputed) {
    SceneDescription d;
    MeshDesc m;
    m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
    m.indices = {0, 1, 2, 2, 1, 3};
    m.normals.assign(9, glm::vec3(1, 0, 0));  // more normals than vertices
    d.meshes.push_back(m);
    const RenderScene s = build_render_scene(d, {});
    ASSERT_EQ(s.normals.size(), 4u);
    for (const glm::vec3& n : s.normals) EXPECT_NEAR(std::abs(n.z), 1.f, 1e-6f);
}

}  // namespace
}  // namespace tessera
