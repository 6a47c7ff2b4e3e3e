#include "engine/geometry/spawn.h"

#include <gtest/gtest.h>

#include <bit>

#include "engine/sampling/rng.h"
#include "engine/sampling/warp.h"
#include "engine/scene/procedural.h"
#include "engine/scene/intersect.h"
#include "tests/test_scale.h"

namespace tessera {
namespace {

struct Placement { float scale; float offset; };

class SpawnAtScale : public ::testing::TestWithParam<Placement> {};

// Inside a closed cube, a ray spawned from a wall into the room must hit another wall (never
// its own), and one spawned out through the wall must escape: no self-intersection, no leak,
// at 1e-4 and 1e4 and far from the origin alike.
TEST_P(SpawnAtScale, NoSelfIntersectionNoLeak) {
    const Placement pl = GetParam();
    const glm::vec3 center(pl.offset, -0.5f * pl.offset, 0.25f * pl.offset);
    const RenderScene s = build_render_scene(furnace_box(0.5f, 1.f, pl.scale, center), RenderSceneOptions{});
    Pcg32 rng(7, 1);
    TraversalCounters tc;
    int self_hits = 0, leaks = 0, misses = 0;
    const int n = 20000 / test::kWorkScale;
    for (int i = 0; i < n; ++i) {
        const glm::vec3 dir = glm::normalize(glm::vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f));
        Ray r{center, 0.f, dir, INFINITY};
        Hit h;
        if (!intersect(s, r, h, tc)) { ++misses; continue; }
        SurfaceInteraction si = surface_at(s, r, h);
        if (glm::dot(si.ng, dir) > 0.f) si.ng = -si.ng;  // inward
        const glm::vec3 wi = Frame(si.ng).to_world(sample_cosine_hemisphere(rng.next_float(), rng.next_float()));
        Ray in = spawn_ray(si.p, si.p_err, si.ng, wi);
        Hit h2;
        if (!intersect(s, in, h2, tc)) ++leaks;
        else if (glm::dot(surface_at(s, in, h2).ng, si.ng) > 0.999f || glm::dot(surface_at(s, in, h2).ng, si.ng) < -0.999f) {
            // Same plane as the origin's face (the opposite face has the opposite normal but lies
            // a whole box away).
            if (h2.t < 0.5f * pl.scale) ++self_hits;
        }
        Ray out = spawn_ray(si.p, si.p_err, si.ng, -wi);
        Hit h3;
        if (intersect(s, out, h3, tc)) ++self_hits;
    }
    EXPECT_EQ(misses, 0);
    EXPECT_EQ(self_hits, 0);
    EXPECT_EQ(leaks, 0);
}

// A spawned ray names the triangle it leaves, and the triangle test skips it. That must save
// work only: on a curved mesh (neighbours at every angle) and at every scale, closest hits and
// shadow-ray answers are the same, to the bit, with and without the skip.
TEST_P(SpawnAtScale, SkippingTheOriginTriangleChangesNoAnswer) {
    const Placement pl = GetParam();
    SceneDescription d = displaced_sphere(20000, 3);
    for (MeshDesc& m : d.meshes)
        for (glm::vec3& p : m.positions) p = p * pl.scale + glm::vec3(pl.offset, -0.5f * pl.offset, 0.25f * pl.offset);
    d.camera.reset();
    const RenderScene s = build_render_scene(d, RenderSceneOptions{});
    const glm::vec3 c = s.bounds.centroid();
    const float r = 0.5f * glm::length(s.bounds.extent());
    Pcg32 rng(11, 2);
    TraversalCounters tc;
    int rays = 0, hits = 0, occluded_count = 0;
    const int n = 20000 / test::kWorkScale;
    for (int i = 0; i < n; ++i) {
        const glm::vec3 dir = glm::normalize(glm::vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f));
        Ray cam{c - 2.f * r * dir, 0.f, dir, INFINITY};
        Hit h;
        if (!intersect(s, cam, h, tc)) continue;
        SurfaceInteraction si = surface_at(s, cam, h);
        ASSERT_EQ(si.tri, h.prim);
        if (glm::dot(si.ng, dir) > 0.f) si.ng = -si.ng;
        const glm::vec3 wi = Frame(si.ng).to_world(sample_cosine_hemisphere(rng.next_float(), rng.next_float()));
        const glm::vec3 target = c + r * glm::vec3(rng.next_float() - 0.5f, 1.5f, rng.next_float() - 0.5f);
        for (Ray with : {spawn_ray(si.p, si.p_err, si.ng, wi, si.tri), spawn_ray(si.p, si.p_err, si.ng, -wi, si.tri),
                         spawn_ray_to(si.p, si.p_err, si.ng, target, si.tri)}) {
            Ray without = with;
            without.origin_tri = kNoTriangle;
            ++rays;
            Hit a, b;
            const bool ha = intersect(s, with, a, tc), hb = intersect(s, without, b, tc);
            ASSERT_EQ(ha, hb) << "ray " << i;
            if (ha) {
                ++hits;
                EXPECT_EQ(a.prim, b.prim);
                EXPECT_NE(a.prim, si.tri);
                EXPECT_EQ(std::bit_cast<uint32_t>(a.t), std::bit_cast<uint32_t>(b.t));
            }
            const bool oa = occluded(s, with, tc), ob = occluded(s, without, tc);
            ASSERT_EQ(oa, ob) << "ray " << i;
            occluded_count += oa;
        }
    }
    EXPECT_GT(rays, n) << "most camera rays must hit the sphere";
    EXPECT_GT(hits, rays / 10) << "the bumps must shadow one another, or the test shows little";
    EXPECT_LT(occluded_count, rays);
}

INSTANTIATE_TEST_SUITE_P(Scales, SpawnAtScale,
                         ::testing::Values(Placement{1e-4f, 0.f}, Placement{1.f, 0.f}, Placement{1e4f, 0.f},
                                           Placement{1.f, 1e4f}, Placement{1.f, 1e5f}, Placement{1e-2f, 1e3f}));

}  // namespace
}  // namespace tessera
