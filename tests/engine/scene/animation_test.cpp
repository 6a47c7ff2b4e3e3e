// Keyframe sampling against values worked out by hand: STEP holds, LINEAR interpolates (slerp
// for rotations, along the shorter arc), CUBICSPLINE reproduces any cubic exactly, and every
// kind clamps outside its keys.
#include "engine/scene/animation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

namespace tessera {
namespace {

AnimationChannel channel(AnimatedProperty p, Interpolation i, int width, std::vector<float> times, std::vector<float> values) {
    AnimationChannel c;
    c.property = p;
    c.interpolation = i;
    c.width = width;
    c.times = std::move(times);
    c.values = std::move(values);
    return c;
}

std::vector<float> at(const AnimationChannel& c, double t) {
    std::vector<float> v(size_t(c.width), NAN);
    sample(c, t, v.data());
    return v;
}

TEST(Animation, StepHoldsEachKeyUntilTheNext) {
    const auto c = channel(AnimatedProperty::translation, Interpolation::step, 3, {0, 1, 2}, {0, 0, 0, 5, 6, 7, 8, 9, 10});
    EXPECT_EQ(at(c, 0.999), (std::vector<float>{0, 0, 0}));
    EXPECT_EQ(at(c, 1.0), (std::vector<float>{5, 6, 7}));
    EXPECT_EQ(at(c, 1.5), (std::vector<float>{5, 6, 7}));
    EXPECT_EQ(at(c, 2.0), (std::vector<float>{8, 9, 10}));
}

TEST(Animation, LinearInterpolatesAndClampsOutsideTheKeys) {
    const auto c = channel(AnimatedProperty::scale, Interpolation::linear, 3, {1, 3}, {1, 2, 3, 3, 2, 1});
    EXPECT_EQ(at(c, -10), (std::vector<float>{1, 2, 3}));
    EXPECT_EQ(at(c, NAN), (std::vector<float>{1, 2, 3}));
    EXPECT_EQ(at(c, 1e9), (std::vector<float>{3, 2, 1}));
    const auto mid = at(c, 2.5);
    EXPECT_FLOAT_EQ(mid[0], 2.5f);
    EXPECT_FLOAT_EQ(mid[1], 2.0f);
    EXPECT_FLOAT_EQ(mid[2], 1.5f);
}

TEST(Animation, LinearRotationsSlerpAlongTheShorterArc) {
    const float h = float(std::sin(std::numbers::pi / 4));  // 90 degrees about z: (0, 0, sin 45, cos 45)
    const auto c = channel(AnimatedProperty::rotation, Interpolation::linear, 4, {0, 1}, {0, 0, 0, 1, 0, 0, h, h});
    for (double s : {0.1, 0.25, 0.5, 0.9}) {
        const auto q = at(c, s);  // the angle grows linearly: s * 90 degrees
        EXPECT_NEAR(q[2], std::sin(s * std::numbers::pi / 4), 1e-6) << s;
        EXPECT_NEAR(q[3], std::cos(s * std::numbers::pi / 4), 1e-6) << s;
    }
    // The same end given as its negation (the same rotation) must not swing the long way round.
    const auto neg = channel(AnimatedProperty::rotation, Interpolation::linear, 4, {0, 1}, {0, 0, 0, 1, 0, 0, -h, -h});
    const auto q = at(neg, 0.5);
    EXPECT_NEAR(std::abs(q[2]), std::sin(std::numbers::pi / 8), 1e-6);
    EXPECT_NEAR(std::abs(q[3]), std::cos(std::numbers::pi / 8), 1e-6);
    // Nearly equal ends (where slerp would divide by sin of almost 0) stay finite and unit.
    const auto close = channel(AnimatedProperty::rotation, Interpolation::linear, 4, {0, 1}, {0, 0, 0, 1, 0, 0, 1e-7f, 1});
    const auto r = at(close, 0.5);
    EXPECT_NEAR(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3], 1.0, 1e-6);
}

// A Hermite segment with the cubic's own end values and slopes is the cubic itself: glTF's
// CUBICSPLINE (tangents scaled by the key interval) must reproduce p(t) = t³ − 2t² + 0.5t + 1
// over unequal intervals.
TEST(Animation, CubicSplineReproducesACubicExactly) {
    auto p = [](double t) { return t * t * t - 2 * t * t + 0.5 * t + 1; };
    auto dp = [](double t) { return 3 * t * t - 4 * t + 0.5; };
    const std::vector<float> times = {-1.0f, 0.25f, 2.0f};
    std::vector<float> values;
    for (float t : times) values.insert(values.end(), {float(dp(t)), float(p(t)), float(dp(t))});  // in, value, out
    const auto c = channel(AnimatedProperty::weights, Interpolation::cubic_spline, 1, times, values);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 2.0);
    for (int i = 0; i < 200; ++i) {
        const double t = u(rng);
        EXPECT_NEAR(at(c, t)[0], p(t), 2e-5) << t;
    }
    EXPECT_FLOAT_EQ(at(c, -5)[0], float(p(-1)));  // clamped to the first value, not extrapolated
}

TEST(Animation, WeightsInterpolateEachTargetAlone) {
    const auto c = channel(AnimatedProperty::weights, Interpolation::linear, 2, {0, 1}, {0, 1, 1, 0});
    const auto w = at(c, 0.25);
    EXPECT_FLOAT_EQ(w[0], 0.25f);
    EXPECT_FLOAT_EQ(w[1], 0.75f);
}

TEST(Animation, CubicSplineRotationsComeOutUnitLength) {
    const float h = float(std::sin(std::numbers::pi / 4));
    // Zero tangents: a Hermite ease between identity and 90 degrees about x, normalised.
    const auto c = channel(AnimatedProperty::rotation, Interpolation::cubic_spline, 4, {0, 1},
                           {0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, h, 0, 0, h, 0, 0, 0, 0});
    for (double t : {0.1, 0.5, 0.7}) {
        const auto q = at(c, t);
        EXPECT_NEAR(q[0] * q[0] + q[3] * q[3], 1.0, 1e-6);
    }
}

}  // namespace
}  // namespace tessera
