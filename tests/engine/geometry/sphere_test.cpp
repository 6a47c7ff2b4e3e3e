#include "engine/geometry/sphere.h"

#include <gtest/gtest.h>

namespace tessera {
namespace {

TEST(Sphere, HitsFrontThenBackFromInside) {
    float t;
    ASSERT_TRUE(intersect_sphere(Ray{{0, 0, 5}, 0.f, {0, 0, -1}, INFINITY}, {0, 0, 0}, 1.f, t));
    EXPECT_FLOAT_EQ(t, 4.f);
    ASSERT_TRUE(intersect_sphere(Ray{{0, 0, 0}, 0.f, {0, 0, -1}, INFINITY}, {0, 0, 0}, 1.f, t));
    EXPECT_FLOAT_EQ(t, 1.f);
    EXPECT_FALSE(intersect_sphere(Ray{{0, 2, 5}, 0.f, {0, 0, -1}, INFINITY}, {0, 0, 0}, 1.f, t));
}

// A small sphere far away: the textbook b² − 4ac loses every digit here (b² ≈ 4ac ≈ 1e16);
// the stable form finds the hit to float precision.
TEST(Sphere, SmallDistantSphereKeepsPrecision) {
    const glm::vec3 c(0, 0, -1e4f);
    const float r = 1e-2f;
    float t;
    ASSERT_TRUE(intersect_sphere(Ray{{0, 0, 0}, 0.f, {0, 0, -1}, INFINITY}, c, r, t));
    EXPECT_NEAR(t, 1e4f - r, 1e4f * 1e-6f);
    // Grazing: a ray offset by 0.999 r still hits, one at 1.001 r misses.
    EXPECT_TRUE(intersect_sphere(Ray{{0.999f * r, 0, 0}, 0.f, {0, 0, -1}, INFINITY}, c, r, t));
    EXPECT_FALSE(intersect_sphere(Ray{{1.001f * r, 0, 0}, 0.f, {0, 0, -1}, INFINITY}, c, r, t));
}

TEST(Sphere, UnnormalisedDirection) {
    float t;
    ASSERT_TRUE(intersect_sphere(Ray{{0, 0, 5}, 0.f, {0, 0, -2}, INFINITY}, {0, 0, 0}, 1.f, t));
    EXPECT_FLOAT_EQ(t, 2.f);
}

}  // namespace
}  // namespace tessera
