#pragma once
// e^x for x ≤ 0 in float, without a branch or a library call, so that a loop of them
// vectorizes (the denoiser's NL-means weights: two per neighbour per pixel).
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>

namespace tessera {

// 2^i · e^r with i = round(x / ln 2) and r = x − i·ln 2 in [−ln2/2, ln2/2] (Cody and Waite's
// reduction: ln 2 in two parts, so that r carries no rounding of i·ln 2), e^r by its Taylor
// series to the sixth power: a relative error of a few float ulps. Below e^-86 it is held at
// about 2^-125 (the weights compared with it are at least 10⁻⁴), and so is NaN; positive x
// gives 1.
inline float exp_nonpositive(float x) {
    x = x > -86.6f ? std::min(x, 0.f) : -86.6f;  // NaN (an overflowed distance) weighs nothing
    const float i = std::nearbyint(x * 1.44269504f);
    const float r = (x - i * 0.693145751953125f) - i * 1.428606765330187e-06f;
    const float p =
        1.f + r * (1.f + r * (0.5f + r * (0.166666672f + r * (0.0416666679f + r * (0.00833333377f + r * 0.00138888892f)))));
    return p * std::bit_cast<float>((int32_t(i) + 127) << 23);
}

}  // namespace tessera
