#pragma once
// Sixteen floats as one value (GCC's and clang's vector extensions): for loops that keep many
// running sums per pixel, where the compiler's own vectorizer would keep them in memory. On a
// machine with AVX-512 a Lanes is one register; elsewhere the compiler splits it.
#include <cstdint>
#include <cstring>

// Lanes pass between inline functions only, never across a library's interface: the note that
// their ABI differs with and without AVX-512 concerns nothing, so it is silenced here for every
// file that includes this one.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace tessera {

constexpr int kLanes = 16;
using Lanes = float __attribute__((vector_size(kLanes * sizeof(float))));
using LaneMask = int32_t __attribute__((vector_size(kLanes * sizeof(int32_t))));  // all ones or none, per lane

inline Lanes load_lanes(const float* p) {
    Lanes v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
inline void store_lanes(float* p, Lanes v) { std::memcpy(p, &v, sizeof v); }
inline Lanes splat(float f) { return Lanes{} + f; }
// m ? a : b, lane by lane (a bit select: neither compiler takes ?: on these types alike).
inline Lanes select(LaneMask m, Lanes a, Lanes b) { return Lanes((LaneMask(a) & m) | (LaneMask(b) & ~m)); }
inline Lanes min_lanes(Lanes a, Lanes b) { return select(b < a, b, a); }  // std::min's order: a where b < a fails
inline Lanes max_lanes(Lanes a, Lanes b) { return select(a < b, b, a); }

// exp_nonpositive (engine/core/exp_nonpositive.h) lane by lane, the same reduction and series;
// the rounding to the nearest integer by adding and taking off 1.5·2²³ (round to nearest even,
// as nearbyint in the default rounding mode, exact for |x·log2 e| < 2²²): the scalar's bits,
// where multiply-adds are not fused (with them, the same to a few ulps).
inline Lanes exp_nonpositive(Lanes x) {
    x = select(x > -86.6f, min_lanes(x, splat(0.f)), splat(-86.6f));  // NaN weighs nothing
    const Lanes i = (x * 1.44269504f + 12582912.f) - 12582912.f;
    const Lanes r = (x - i * 0.693145751953125f) - i * 1.428606765330187e-06f;
    const Lanes p =
        1.f + r * (1.f + r * (0.5f + r * (0.166666672f + r * (0.0416666679f + r * (0.00833333377f + r * 0.00138888892f)))));
    return p * Lanes((__builtin_convertvector(i, LaneMask) + 127) << 23);
}

}  // namespace tessera
