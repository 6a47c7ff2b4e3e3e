#include "engine/sampling/rng.h"

#include <gtest/gtest.h>

namespace tessera {
namespace {

TEST(Rng, StreamsDependOnlyOnTheirKey) {
    Pcg32 a = sample_rng(1, 100, 7), b = sample_rng(1, 100, 7), c = sample_rng(1, 100, 8), d = sample_rng(2, 100, 7);
    const uint32_t x = a.next_u32();
    EXPECT_EQ(x, b.next_u32());
    EXPECT_NE(x, c.next_u32());
    EXPECT_NE(x, d.next_u32());
}

TEST(Rng, FloatsInUnitIntervalWithUniformMoments) {
    Pcg32 r(9, 9);
    const int n = 1000000;
    double m = 0, m2 = 0;
    for (int i = 0; i < n; ++i) {
        const float u = r.next_float();
        ASSERT_GE(u, 0.f);
        ASSERT_LT(u, 1.f);
        m += u; m2 += double(u) * u;
    }
    // se of the mean = √(1/12)/√n ≈ 2.9e-4; 5 se.
    EXPECT_NEAR(m / n, 0.5, 0.0015);
    EXPECT_NEAR(m2 / n, 1.0 / 3, 0.0015);
}

}  // namespace
}  // namespace tessera
