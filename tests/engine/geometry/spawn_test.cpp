#include "engine/geometry/spawn.h"

#include <gtest/gtest.h>

#include "engine/sampling/rng.h"
#include "engine/sampling/warp.h"
#include "engine/scene/procedural.h"
#include "engine/scene/render_scene.h"
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

INSTANTIATE_TEST_SUITE_P(Scales, SpawnAtScale,
                         ::testing::Values(Placement{1e-4f, 0.f}, Placement{1.f, 0.f}, Placement{1e4f, 0.f},
                                           Placement{1.f, 1e4f}, Placement{1.f, 1e5f}, Placement{1e-2f, 1e3f}));

}  // namespace
}  // namespace tessera
