// The denoiser's exponential against the library's, over its whole domain.
#include "engine/core/exp_nonpositive.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace tessera {
namespace {

TEST(ExpNonpositive, MatchesTheLibraryToAFewUlpsWhereItMatters) {
    EXPECT_EQ(exp_nonpositive(0.f), 1.f);
    EXPECT_EQ(exp_nonpositive(-0.f), 1.f);
    double worst = 0;
    // Every float step of 2^-12 from -86 to 0, and the points where the power of two changes.
    for (int i = 0; i <= 86 * 4096; ++i) {
        const float x = -float(i) / 4096.f;
        const double want = std::exp(double(x));
        worst = std::max(worst, std::abs(double(exp_nonpositive(x)) - want) / want);
    }
    for (int k = 0; k <= 124; ++k)
        for (const float d : {-1e-6f, 0.f, 1e-6f}) {
            const float x = std::min(0.f, -float(k) / 1.44269504f + d);
            const double want = std::exp(double(x));
            worst = std::max(worst, std::abs(double(exp_nonpositive(x)) - want) / want);
        }
    EXPECT_LT(worst, 6e-7);  // a few float ulps (1.2e-7 relative each); 4e-6 without the two-part ln 2
    // Far below, and NaN (a distance that overflowed): tiny and positive, never a NaN, an
    // infinity or a negative; above the domain, 1.
    for (const float x : {-87.f, -100.f, -1e6f, -std::numeric_limits<float>::infinity(), std::numeric_limits<float>::quiet_NaN()}) {
        const float e = exp_nonpositive(x);
        EXPECT_GE(e, 0.f) << x;
        EXPECT_LT(e, 1e-37f) << x;
    }
    EXPECT_EQ(exp_nonpositive(3.f), 1.f);
    EXPECT_EQ(exp_nonpositive(std::numeric_limits<float>::infinity()), 1.f);
}

}  // namespace
}  // namespace tessera
