// Sixteen floats as one value: each lane as the scalar code computes it.
#include "engine/core/float_lanes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "engine/core/exp_nonpositive.h"

namespace tessera {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity(), kNaN = std::numeric_limits<float>::quiet_NaN();

TEST(FloatLanes, ExponentialIsTheScalarOnesLaneByLane) {
    // Every step of 2^-10 over the domain, sixteen at a time: the lanes round to the nearest
    // integer by another route than nearbyint (the same where multiply-adds are not fused, as in
    // this file), so they are held to the scalar's few ulps, not to its bits.
    double worst = 0;
    for (int i = 0; i <= 87 * 1024; i += kLanes) {
        float x[kLanes], e[kLanes];
        for (int l = 0; l < kLanes; ++l) x[l] = -float(i + l) / 1024.f;
        store_lanes(e, exp_nonpositive(load_lanes(x)));
        for (int l = 0; l < kLanes; ++l) {
            const double s = exp_nonpositive(x[l]);
            worst = std::max(worst, std::abs(double(e[l]) - s) / s);
        }
    }
    EXPECT_LT(worst, 3e-7);
    // Outside the domain as the scalar: 1 above it, tiny and positive below, and NaN weighs nothing.
    // (−0.34657…: either side of −ln2/2, where the nearest integer turns.)
    const float odd[kLanes] = {0.f, -0.f, 3.f, kInf, -87.f, -100.f, -1e6f, -kInf, kNaN, -kNaN, -0.346573f, -0.346574f,
                               -1e-30f, -43.3f, -86.5f, -86.7f};
    float e[kLanes];
    store_lanes(e, exp_nonpositive(load_lanes(odd)));
    for (int l = 0; l < kLanes; ++l) {
        const float s = exp_nonpositive(odd[l]);
        EXPECT_TRUE(std::isfinite(e[l])) << odd[l];
        EXPECT_GE(e[l], 0.f) << odd[l];
        EXPECT_NEAR(e[l], s, 3e-7 * s) << odd[l];
    }
    EXPECT_EQ(e[0], 1.f);
    EXPECT_EQ(e[2], 1.f);
    EXPECT_EQ(e[3], 1.f);
    EXPECT_LT(e[8], 1e-37f);
}

TEST(FloatLanes, SelectMinAndMaxTakeEachLaneAsStdDoes) {
    float a[kLanes], b[kLanes], s[kLanes], lo[kLanes], hi[kLanes];
    const float values[] = {-2.f, -0.f, 0.f, 1.f, kInf, -kInf, kNaN, 5.5f};
    for (int l = 0; l < kLanes; ++l) {
        a[l] = values[l % 8];
        b[l] = values[(l * 3 + 1) % 8];
    }
    const Lanes la = load_lanes(a), lb = load_lanes(b);
    store_lanes(s, select(la < lb, splat(1.f), splat(2.f)));
    store_lanes(lo, min_lanes(la, lb));
    store_lanes(hi, max_lanes(la, lb));
    for (int l = 0; l < kLanes; ++l) {
        EXPECT_EQ(s[l], a[l] < b[l] ? 1.f : 2.f) << l;
        // std::min(a, b) is b < a ? b : a, std::max(a, b) a < b ? b : a, NaN and signed zeros included.
        const float want_lo = std::min(a[l], b[l]), want_hi = std::max(a[l], b[l]);
        EXPECT_TRUE(std::memcmp(&lo[l], &want_lo, sizeof(float)) == 0) << a[l] << " " << b[l];
        EXPECT_TRUE(std::memcmp(&hi[l], &want_hi, sizeof(float)) == 0) << a[l] << " " << b[l];
    }
    // A row in and out unchanged, unaligned.
    float row[kLanes + 1], back[kLanes + 1] = {};
    for (int l = 0; l <= kLanes; ++l) row[l] = float(l) * 0.25f - 1.f;
    store_lanes(back + 1, load_lanes(row + 1));
    for (int l = 1; l <= kLanes; ++l) EXPECT_EQ(back[l], row[l]);
}

}  // namespace
}  // namespace tessera
