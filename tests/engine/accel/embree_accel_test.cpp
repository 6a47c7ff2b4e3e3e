#include "engine/accel/embree_accel.h"
#include "engine/scene/intersect.h"

#include <gtest/gtest.h>

#include "engine/render/renderer.h"
#include "engine/sampling/rng.h"
#include "engine/scene/procedural.h"

namespace tessera {
namespace {

// Embree and our BVH answer the same queries on the same scene: hit or miss agree except for
// rays within rounding of an edge (two different triangle tests), and the distances agree to
// float precision.
TEST(Embree, AgreesWithOurBvh) {
    if (!embree_available()) GTEST_SKIP() << "this build has no Embree (libembree-dev)";
    const SceneDescription d = displaced_sphere(20000);
    const RenderScene ours = build_render_scene(d, {});
    RenderSceneOptions eo;
    eo.bvh.type = BvhType::embree;
    const RenderScene emb = build_render_scene(d, eo);
    ASSERT_TRUE(emb.embree);
    Pcg32 rng(3, 9);
    TraversalCounters tc;
    int disagree = 0, hits = 0;
    const int n = 100000;
    for (int i = 0; i < n; ++i) {
        const glm::vec3 o(2 * rng.next_float() - 1, 2 * rng.next_float() - 1, 2 * rng.next_float() - 1);
        const glm::vec3 dir = glm::normalize(glm::vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f));
        Ray a{1.5f * o, 0.f, dir, INFINITY}, b = a;
        Hit ha, hb;
        const bool ea = intersect(ours, a, ha, tc), eb = intersect(emb, b, hb, tc);
        if (ea != eb) { ++disagree; continue; }
        if (!ea) continue;
        ++hits;
        ASSERT_NEAR(ha.t, hb.t, 1e-4f * std::max(1.f, ha.t)) << i;
        EXPECT_EQ(occluded(ours, Ray{a.o, 0.f, dir, ha.t * 0.999f}, tc), occluded(emb, Ray{a.o, 0.f, dir, ha.t * 0.999f}, tc));
    }
    EXPECT_GT(hits, n / 10);
    EXPECT_LE(disagree, n / 10000) << disagree << " rays disagree";
    // The same image through the whole integrator (same mean within noise: compare exactly
    // equal sample counts and close means).
    RenderSettings st;
    st.width = 32;
    st.height = 24;
    st.spp = 8;
    st.max_depth = 2;
    double ma = 0, mb = 0;
    for (float v : render(ours, st).image.rgb) ma += v;
    for (float v : render(emb, st).image.rgb) mb += v;
    EXPECT_NEAR(ma, mb, 1e-3 * ma);
}

}  // namespace
}  // namespace tessera
