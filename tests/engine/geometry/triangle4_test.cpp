#include "engine/geometry/triangle4.h"

#include <gtest/gtest.h>

#include <bit>

#include "engine/sampling/rng.h"
#include "tests/test_scale.h"

namespace tessera {
namespace {

glm::vec3 random_point(Pcg32& rng, float scale, glm::vec3 offset) {
    return offset + scale * glm::vec3(2 * rng.next_float() - 1, 2 * rng.next_float() - 1, 2 * rng.next_float() - 1);
}

// Each lane of the 4-wide test answers exactly as the scalar watertight test (same hit, same
// t and barycentrics to the bit), across scales and offsets, for rays through the interior,
// through vertices and along edges (where edge functions are zero and the double-precision
// path runs), and with the interval bounds cutting hits off.
TEST(Triangle4, EveryLaneMatchesTheScalarTestBitForBit) {
    Pcg32 rng(7, 11);
    const int n = 400000 / test::kWorkScale;
    int hits = 0, zero_edge_cases = 0;
    for (int i = 0; i < n; ++i) {
        const float scale = std::pow(10.f, float(int(rng.next_u32() % 9)) - 4.f);
        const glm::vec3 offset = (rng.next_u32() % 3 == 0) ? glm::vec3(1e4f, -3e3f, 5e2f) : glm::vec3(0.f);
        Triangle4 block;
        TriangleVerts tv[4];
        for (int l = 0; l < 4; ++l) {
            tv[l] = {random_point(rng, scale, offset), random_point(rng, scale, offset), random_point(rng, scale, offset)};
            if (l > 0 && rng.next_u32() % 2) tv[l].p0 = tv[l - 1].p1, tv[l].p1 = tv[l - 1].p0;  // a shared edge
            if (rng.next_u32() % 16 == 0) tv[l].p2 = tv[l].p1;                                  // degenerate
            const glm::vec3* v[3] = {&tv[l].p0, &tv[l].p1, &tv[l].p2};
            for (int k = 0; k < 3; ++k)
                for (int a = 0; a < 3; ++a) block.p[k][a][l] = (*v[k])[a];
            block.prim[l] = uint32_t(l);
        }
        Ray ray;
        ray.o = random_point(rng, 3.f * scale, offset);
        const int aim = int(rng.next_u32() % 4);
        const TriangleVerts& target = tv[rng.next_u32() % 4];
        glm::vec3 to = aim == 0 ? target.p0                                     // through a vertex
                       : aim == 1 ? 0.5f * (target.p0 + target.p1)              // onto an edge
                       : (target.p0 + target.p1 + target.p2) * (1.f / 3.f) + random_point(rng, 0.3f * scale, glm::vec3(0.f));
        if (rng.next_u32() % 8 == 0) { ray.o.z = to.z; }  // rays in a coordinate plane
        ray.d = to - ray.o;
        if (glm::dot(ray.d, ray.d) == 0.f) continue;
        if (rng.next_u32() % 4 == 0) ray.tmax = rng.next_float() * 1.5f;
        if (rng.next_u32() % 8 == 0) ray.tmin = rng.next_float() * 0.5f;
        const Triangle4Ray r4 = make_triangle4_ray(ray);
        Triangle4Hits h4;
        intersect_triangle4(ray, r4, block, h4);
        for (int l = 0; l < 4; ++l) {
            TriangleHit h;
            const bool hit = intersect_triangle_watertight(ray, r4.w, tv[l].p0, tv[l].p1, tv[l].p2, h);
            ASSERT_EQ(hit, bool(h4.mask & (1 << l))) << "case " << i << " lane " << l;
            if (!hit) continue;
            ++hits;
            EXPECT_EQ(std::bit_cast<uint32_t>(h.t), std::bit_cast<uint32_t>(h4.t[l]));
            EXPECT_EQ(std::bit_cast<uint32_t>(h.b1), std::bit_cast<uint32_t>(h4.b1[l]));
            EXPECT_EQ(std::bit_cast<uint32_t>(h.b2), std::bit_cast<uint32_t>(h4.b2[l]));
        }
        zero_edge_cases += aim < 2;
    }
    EXPECT_GT(hits, n / 4) << "the cases must mostly hit, or they test little";
    EXPECT_GT(zero_edge_cases, n / 3);
}

// A ray that leaves a triangle skips the lanes holding it (a leaf's last block repeats its last
// triangle, so that can be two lanes); the other lanes answer as before, to the bit.
TEST(Triangle4, LanesHoldingTheOriginTriangleNeverHit) {
    Pcg32 rng(3, 5);
    const int n = 100000 / test::kWorkScale;
    int skipped_hits = 0;
    for (int i = 0; i < n; ++i) {
        Triangle4 block;
        for (int l = 0; l < 4; ++l) {
            for (int k = 0; k < 3; ++k) {
                const glm::vec3 p = random_point(rng, 1.f, glm::vec3(0.f, 0.f, -2.f));
                for (int a = 0; a < 3; ++a) block.p[k][a][l] = p[a];
            }
            block.prim[l] = 10 + uint32_t(l);
        }
        if (rng.next_u32() % 4 == 0) {  // a repeated last triangle
            for (int k = 0; k < 3; ++k)
                for (int a = 0; a < 3; ++a) block.p[k][a][3] = block.p[k][a][2];
            block.prim[3] = block.prim[2];
        }
        Ray ray;
        ray.o = random_point(rng, 0.2f, glm::vec3(0.f));
        ray.d = triangle4_vertex(block, 0, int(rng.next_u32() % 4)) * 0.3f + random_point(rng, 0.3f, glm::vec3(0.f, 0.f, -1.f)) - ray.o;
        Triangle4Hits all, skipping;
        intersect_triangle4(ray, make_triangle4_ray(ray), block, all);
        ray.origin_tri = block.prim[rng.next_u32() % 4];
        intersect_triangle4(ray, make_triangle4_ray(ray), block, skipping);
        for (int l = 0; l < 4; ++l) {
            const bool hit = all.mask & (1 << l);
            if (block.prim[l] == ray.origin_tri) {
                EXPECT_FALSE(skipping.mask & (1 << l)) << "case " << i << " lane " << l;
                skipped_hits += hit;
                continue;
            }
            ASSERT_EQ(hit, bool(skipping.mask & (1 << l))) << "case " << i << " lane " << l;
            if (hit) { EXPECT_EQ(std::bit_cast<uint32_t>(all.t[l]), std::bit_cast<uint32_t>(skipping.t[l])); }
        }
    }
    EXPECT_GT(skipped_hits, n / 20) << "the skipped lanes must often be hit, or the test shows nothing";
}

TEST(Triangle4, NearestLaneIsTheFirstOfEquals) {
    Triangle4Hits h;
    h.mask = 0b1110;
    h.t[0] = 0.f; h.t[1] = 2.f; h.t[2] = 1.f; h.t[3] = 1.f;
    EXPECT_EQ(nearest_lane(h), 2);
}

}  // namespace
}  // namespace tessera
