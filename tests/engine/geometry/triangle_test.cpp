#include "engine/geometry/triangle.h"

#include <gtest/gtest.h>

#include "engine/sampling/rng.h"
#include "engine/scene/procedural.h"
#include "engine/scene/intersect.h"
#include "tests/test_scale.h"

namespace tessera {
namespace {

bool watertight(const Ray& r, glm::vec3 a, glm::vec3 b, glm::vec3 c, TriangleHit& h) {
    return intersect_triangle_watertight(r, make_watertight_ray(r.d), a, b, c, h);
}

TEST(Triangle, HitsInteriorWithBarycentrics) {
    const glm::vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
    Ray r{{0.25f, 0.5f, 1.f}, 0.f, {0, 0, -1}, INFINITY};
    TriangleHit h;
    ASSERT_TRUE(watertight(r, a, b, c, h));
    EXPECT_FLOAT_EQ(h.t, 1.f);
    EXPECT_NEAR(h.b1, 0.25f, 1e-6f);
    EXPECT_NEAR(h.b2, 0.5f, 1e-6f);
    ASSERT_TRUE(intersect_triangle_moller_trumbore(r, a, b, c, h));
    EXPECT_NEAR(h.b1, 0.25f, 1e-6f);
}

TEST(Triangle, RespectsRayInterval) {
    const glm::vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
    TriangleHit h;
    EXPECT_FALSE(watertight(Ray{{0.2f, 0.2f, 1.f}, 0.f, {0, 0, -1}, 0.5f}, a, b, c, h));
    EXPECT_FALSE(watertight(Ray{{0.2f, 0.2f, 1.f}, 1.5f, {0, 0, -1}, INFINITY}, a, b, c, h));
    EXPECT_FALSE(watertight(Ray{{0.2f, 0.2f, 1.f}, 0.f, {0, 0, 1}, INFINITY}, a, b, c, h));  // behind
}

TEST(Triangle, ParallelAndDegenerateNeverHitNorProduceNaN) {
    const glm::vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
    TriangleHit h;
    EXPECT_FALSE(watertight(Ray{{0.2f, 0.2f, 0.f}, 0.f, {1, 0, 0}, INFINITY}, a, b, c, h));  // in the plane
    EXPECT_FALSE(watertight(Ray{{0.2f, 0.2f, 1.f}, 0.f, {1, 0, 0}, INFINITY}, a, b, c, h));  // parallel above
    // Zero-area triangles: a point and a segment.
    EXPECT_FALSE(watertight(Ray{{0.f, 0.f, 1.f}, 0.f, {0, 0, -1}, INFINITY}, a, a, a, h));
    EXPECT_FALSE(watertight(Ray{{0.5f, 0.f, 1.f}, 0.f, {0, 0, -1}, INFINITY}, a, b, b * 2.f, h));
    EXPECT_FALSE(intersect_triangle_moller_trumbore(Ray{{0.5f, 0.f, 1.f}, 0.f, {0, 0, -1}, INFINITY}, a, b, b * 2.f, h));
}

TEST(Triangle, SliverTriangleHitsAreFinite) {
    const glm::vec3 a(0, 0, 0), b(1000.f, 0, 0), c(500.f, 1e-4f, 0);
    Pcg32 rng(3, 4);
    for (int i = 0; i < 10000; ++i) {
        const glm::vec3 o(1000.f * rng.next_float(), 1e-4f * rng.next_float(), 1.f);
        TriangleHit h;
        if (watertight(Ray{o, 0.f, {0, 0, -1}, INFINITY}, a, b, c, h)) {
            ASSERT_TRUE(std::isfinite(h.t) && std::isfinite(h.b1) && std::isfinite(h.b2));
            ASSERT_NEAR(h.t, 1.f, 1e-5f);
        }
    }
}

// Rays through the shared edges and vertices of a closed mesh must hit it: with the
// watertight test no ray from inside escapes, whatever its direction.
TEST(Triangle, RaysFromInsideAClosedMeshNeverLeak) {
    SceneDescription d = displaced_sphere(20000 / test::kWorkScale);
    RenderSceneOptions opt;
    const RenderScene s = build_render_scene(d, opt);
    const MeshDesc& m = d.meshes[0];
    TraversalCounters tc;
    int escaped = 0, total = 0;
    // Aim exactly at every vertex and at every edge midpoint (where rounding decides).
    for (size_t i = 0; i < m.indices.size(); i += 3) {
        for (int k = 0; k < 3; ++k) {
            const glm::vec3 v = m.positions[m.indices[i + k]];
            const glm::vec3 w = 0.5f * (v + m.positions[m.indices[i + (k + 1) % 3]]);
            for (const glm::vec3& target : {v, w}) {
                Ray r{glm::vec3(0.f), 0.f, glm::normalize(target), INFINITY};
                Hit h;
                ++total;
                if (!intersect(s, r, h, tc)) ++escaped;
            }
        }
    }
    Pcg32 rng(11, 5);
    for (int i = 0; i < 200000 / test::kWorkScale; ++i) {
        const glm::vec3 dir = glm::normalize(glm::vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f));
        Ray r{glm::vec3(0.01f, -0.02f, 0.03f), 0.f, dir, INFINITY};
        Hit h;
        ++total;
        if (!intersect(s, r, h, tc)) ++escaped;
    }
    EXPECT_EQ(escaped, 0) << "of " << total << " rays";
}

}  // namespace
}  // namespace tessera
