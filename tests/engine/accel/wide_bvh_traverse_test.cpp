#include "engine/accel/wide_bvh_traverse.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace tessera {
namespace {

struct Box { glm::vec3 lo, hi; };

// The exact answer (in double, whose rounding is far below float's): does the segment
// [tmin, tmax] of the ray meet the closed box? A zero direction component meets the slab
// when the origin is inside it, as the traversal's NaN rule has it.
bool truly_enters(const Box& b, const Ray& r) {
    double enter = r.tmin, leave = r.tmax;
    for (int a = 0; a < 3; ++a) {
        const double o = r.o[a], d = r.d[a], lo = b.lo[a], hi = b.hi[a];
        if (d == 0.0) {
            if (o < lo || o > hi) return false;
            continue;
        }
        double t0 = (lo - o) / d, t1 = (hi - o) / d;
        if (t0 > t1) std::swap(t0, t1);
        enter = std::max(enter, t0);
        leave = std::min(leave, t1);
    }
    return enter <= leave;
}

// Which of a node's children the traversal visits (every child is a one-entry leaf, and
// the leaf test never reports a hit, so nothing is culled).
unsigned visited_children(const WideNode& node, const Ray& ray) {
    WideBvh bvh;
    bvh.nodes = {node};
    unsigned seen = 0;
    Ray r = ray;
    TraversalCounters tc;
    wide_closest_hit(bvh, r, [&](uint32_t first, uint32_t, Ray&) { seen |= 1u << first; return false; }, tc);
    return seen;
}

// The slab test may widen a box by a few ulps but never misses one the ray truly meets:
// scales 1e-4 to 1e4, origins up to 1e5 from the world's, rays starting on a box's face,
// axis-parallel rays, tiny direction components, segments cut short. (This covers the
// fused multiply-add form where the build has FMA, the subtract-multiply form elsewhere.)
TEST(WideTraverse, NeverMissesABoxTheRayTrulyMeets) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-1.f, 1.f), u01(0.f, 1.f);
    // Draws in sequence (the order of a constructor's arguments is unspecified).
    auto rand3 = [&](std::uniform_real_distribution<float>& d) {
        const float x = d(rng), y = d(rng), z = d(rng);
        return glm::vec3(x, y, z);
    };
    int met = 0, extra = 0, extra_near_origin = 0, near_origin_met = 0;
    for (float scale : {1e-4f, 1.f, 1e4f})
        for (float offset : {0.f, 1e4f, 1e5f})
            for (int trial = 0; trial < 20000; ++trial) {
                const float sx = u(rng) < 0 ? -1.f : 1.f, sz = u(rng) < 0 ? -1.f : 1.f;
                const glm::vec3 base = offset * glm::vec3(sx, 1.f, sz);
                WideNode node;
                Box boxes[kBvhWidth];
                for (int c = 0; c < kBvhWidth; ++c) {
                    const glm::vec3 center = base + scale * rand3(u);
                    glm::vec3 half = scale * rand3(u01);
                    if (c == 1) half.y = 0.f;  // a flat box
                    boxes[c] = {center - half, center + half};
                    for (int a = 0; a < 3; ++a) { node.bounds[a][c] = boxes[c].lo[a]; node.bounds[a + 3][c] = boxes[c].hi[a]; }
                    node.child[c] = uint32_t(c);
                    node.count[c] = 1;
                }
                Ray ray;
                ray.o = base + 3.f * scale * rand3(u);
                if (trial % 5 == 0) ray.o.x = boxes[trial % kBvhWidth].lo.x;  // on a face
                ray.d = glm::normalize(rand3(u));
                if (trial % 7 == 0) ray.d[trial % 3] = 0.f;                   // parallel to a slab
                if (trial % 11 == 0) ray.d[(trial + 1) % 3] = 1e-20f;         // nearly so
                if (trial % 13 == 0) ray.d = glm::vec3(0.f, 0.f, 0.f), ray.d[trial % 3] = -1.f;
                ray.tmin = trial % 3 == 0 ? 0.f : 1e-3f * scale;
                ray.tmax = trial % 4 == 0 ? INFINITY : 4.f * scale * u01(rng);
                const unsigned seen = visited_children(node, ray);
                for (int c = 0; c < kBvhWidth; ++c) {
                    const bool truth = truly_enters(boxes[c], ray), got = seen & (1u << c);
                    if (truth) {
                        ++met;
                        ASSERT_TRUE(got) << "scale " << scale << " offset " << offset << " trial " << trial << " child " << c;
                    } else if (got) {
                        ++extra;
                        if (offset == 0.f) ++extra_near_origin;
                    }
                    if (offset == 0.f && truth) ++near_origin_met;
                }
            }
    EXPECT_GT(met, 40000) << "the cases must often meet boxes, or they test little";
    // Near the world's origin the widening is a few ulps: almost no box is entered falsely.
    EXPECT_LT(extra_near_origin, near_origin_met / 1000 + 10) << "extra visits: " << extra;
}

}  // namespace
}  // namespace tessera
