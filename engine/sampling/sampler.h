#pragma once
// The numbers one pixel sample draws, dimension by dimension along its path: independent PCG32
// numbers, or Owen-scrambled Sobol points (Burley 2020, "Practical Hash-based Owen Scrambling").
//
// Sobol: each request (a 1-D number, or a 2-D point for a pair that belongs together: a lens or
// pixel position, a direction, a point on a light) takes the next dimension of the path. A 2-D
// request reads the first two Sobol dimensions, a (0,2)-sequence, so a pixel's points for that
// decision are stratified in both axes at once; every dimension has its own hash-seeded nested
// uniform scramble of the values and its own shuffle of the sample order ("padding"), so
// dimensions are decorrelated without the higher Sobol dimensions' poorer 2-D projections.
//
// One sequence per pixel: sample s is point s. The first 2^k samples of every dimension are then
// one (0,k,2)-net, not two independent nets of half the size (measured on the Cornell box at
// depth 5: 1.32x less error at 16 spp, 1.11x at 64, than the two replicates this sampler
// used to split a pixel's samples into). The error estimate copes with the correlation this
// brings (engine/render/convergence.h): it compares the pixel's first 2^k samples with the rest,
// both nets, and corrects for how fast the error falls.
//
// Everything depends only on (seed, pixel, sample index): the same image for any thread count,
// tile size, pass split or render node.
#include <array>
#include <cstdint>
#ifdef __GFNI__
#include <immintrin.h>
#endif

#include <glm/glm.hpp>

#include "engine/sampling/rng.h"

namespace tessera {

enum class SamplerKind { independent, sobol };

namespace sobol {

inline uint32_t reverse_bits(uint32_t x) {
#ifdef __GFNI__
    const __m128i v = _mm_gf2p8affine_epi64_epi8(_mm_cvtsi32_si128(int(x)), _mm_set1_epi64x(0x8040201008040201ll), 0);
    return __builtin_bswap32(uint32_t(_mm_cvtsi128_si32(v)));
#else
    x = __builtin_bswap32(x);  // bytes in one instruction, then the bits within each byte
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    return ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
#endif
}

// A fast approximation of an Owen scramble of reversed bits (Laine & Karras 2011's idea):
// every output bit depends only on the input bits at or below it. Vegdahl's 2021 constants,
// which mix better than Burley's 2020 ones (his "Building a Better LK Hash").
inline uint32_t laine_karras_permutation(uint32_t x, uint32_t seed) {
    x ^= x * 0x3d20adeau;
    x += seed;
    x *= (seed >> 16) | 1u;
    x ^= x * 0x05526c56u;
    x ^= x * 0x53a22864u;
    return x;
}

// A nested uniform (Owen) scramble of a 32-bit fixed-point value: each bit flipped by a hash of
// the bits above it.
inline uint32_t nested_uniform_scramble(uint32_t x, uint32_t seed) {
    return reverse_bits(laine_karras_permutation(reverse_bits(x), seed));
}

// The first Sobol dimension (van der Corput) and the second (Pascal's matrix mod 2:
// v₀ = 2³¹, vᵢ = vᵢ₋₁ ⊕ vᵢ₋₁ ≫ 1), as 32-bit fractions.
inline uint32_t dim0(uint32_t i) { return reverse_bits(i); }

// A map that is linear over GF(2) in its argument's bits, as the XOR of one table entry per byte
// of the argument: column k is the image of bit k. (Shuffled indices have random high bits, so
// a loop over set bits would branch on noise: measured, that made Sobol sampling 45% slower per
// sample than independent.)
struct ByteTables {
    uint32_t t[4][256];
    constexpr explicit ByteTables(const std::array<uint32_t, 32>& column) : t{} {
        for (int b = 0; b < 4; ++b)
            for (int x = 0; x < 256; ++x) {
                uint32_t r = 0;
                for (int k = 0; k < 8; ++k)
                    if (x >> k & 1) r ^= column[size_t(8 * b + k)];
                t[b][x] = r;
            }
    }
    constexpr uint32_t operator()(uint32_t x) const { return t[0][x & 255] ^ t[1][(x >> 8) & 255] ^ t[2][(x >> 16) & 255] ^ t[3][x >> 24]; }
};

// The second dimension's columns: vₖ, the image of index bit k; or, for the sampler's reversed
// form, reverse(v₃₁₋ₖ), the reversed value's image of the reversed index's bit k. The
// sampler keeps its shuffled index reversed (the form the scramble works on) and reads the
// value already in the form the scramble takes.
constexpr std::array<uint32_t, 32> dim1_columns(bool reversed) {
    std::array<uint32_t, 32> v{};
    v[0] = 0x80000000u;
    for (size_t k = 1; k < 32; ++k) v[k] = v[k - 1] ^ (v[k - 1] >> 1);
    if (!reversed) return v;
    std::array<uint32_t, 32> r{};
    for (size_t k = 0; k < 32; ++k)
        for (int j = 0; j < 32; ++j) r[k] |= ((v[31 - k] >> j) & 1u) << (31 - j);
    return r;
}
inline constexpr ByteTables kDim1{dim1_columns(false)}, kDim1Reversed{dim1_columns(true)};

inline uint32_t dim1(uint32_t i) { return kDim1(i); }
// dim1(reverse(r)), reversed.
inline uint32_t dim1_reversed(uint32_t r) { return kDim1Reversed(r); }

// Two 32-bit values reversed at once (each in its own half): one 64-bit reversal where a 2-D
// point needs two.
inline uint64_t reverse_bits_pair(uint64_t x) {
#ifdef __GFNI__
    const __m128i v = _mm_gf2p8affine_epi64_epi8(_mm_cvtsi64_si128((long long)x), _mm_set1_epi64x(0x8040201008040201ll), 0);
    const uint64_t y = uint64_t(_mm_cvtsi128_si64(v));  // each byte's bits reversed; now each half's bytes
    return uint64_t(__builtin_bswap32(uint32_t(y >> 32))) << 32 | __builtin_bswap32(uint32_t(y));
#else
    x = __builtin_bswap64(x);
    x = ((x >> 4) & 0x0f0f0f0f0f0f0f0full) | ((x & 0x0f0f0f0f0f0f0f0full) << 4);
    x = ((x >> 2) & 0x3333333333333333ull) | ((x & 0x3333333333333333ull) << 2);
    x = ((x >> 1) & 0x5555555555555555ull) | ((x & 0x5555555555555555ull) << 1);
    return (x >> 32) | (x << 32);  // the bswap also swapped the halves: swap them back
#endif
}

// One scramble seed per dimension of a pixel (`base` is already a mixed key).
inline uint32_t dimension_seed(uint64_t base, uint32_t dim) { return uint32_t(mix64(base + dim) >> 32); }

// The shuffled Sobol index of a dimension (Burley's "padding": each dimension sees the
// pixel's points in its own order).
inline uint32_t shuffled_index(uint32_t index, uint32_t seed) { return nested_uniform_scramble(index, seed); }

// Scrambled first dimension of point i: scramble(reverse(i)) needs no reversal in between.
inline uint32_t scrambled_dim0(uint32_t i, uint32_t seed) { return reverse_bits(laine_karras_permutation(i, seed)); }

// A 32-bit fraction to a float in [0, 1): its top 24 bits, exactly representable, never 1.
inline float to_float(uint32_t x) { return float(x >> 8) * 0x1p-24f; }

}  // namespace sobol

// A pair of independent numbers, in the order this renderer always drew them (images made with
// independent sampling stay the same bit for bit).
inline glm::vec2 independent_2d(Pcg32& rng) {
    const float b = rng.next_float();
    const float a = rng.next_float();
    return {a, b};
}

class Sampler {
public:
    Sampler(SamplerKind kind, uint64_t seed, uint64_t pixel, uint64_t sample)
        : kind_(kind) {
        // Only the kind in use is seeded: this runs once per pixel sample.
        if (kind_ == SamplerKind::independent) {
            rng_ = sample_rng(seed, pixel, sample);
        } else {
            reversed_index_ = sobol::reverse_bits(uint32_t(sample));
            base_ = mix64(mix64(seed ^ 0x5851f42d4c957f2dull) ^ mix64(pixel));
            next_ = sobol_point(0);
        }
    }

    SamplerKind kind() const { return kind_; }

    // Each draw hands out a point computed ahead and computes the next one: a point is a chain
    // of about 75 cycles of dependent multiplies and bit reversals, which a draw waited for
    // (Sobol points cost 14% more time per sample than independent numbers on the Cornell box);
    // computed one draw ahead it runs beside the ray tracing in between. A 1-D draw is the
    // first coordinate of its dimension's point, as the reference composition defines it.
    float next_float() {
        if (kind_ == SamplerKind::independent) return rng_.next_float();
        const float x = next_.x;
        next_ = sobol_point(++dim_);
        return x;
    }

    glm::vec2 next_2d() {
        if (kind_ == SamplerKind::independent) return independent_2d(rng_);
        const glm::vec2 p = next_;
        next_ = sobol_point(++dim_);
        return p;
    }

private:
    // Dimension `dim`'s point: the same points as sobol::shuffled_index, scrambled_dim0 and
    // nested_uniform_scramble(dim1) compose to (Sampler.FastPathIsTheReferenceComposition), with
    // three bit reversals instead of five, two of them in one 64-bit reversal.
    glm::vec2 sobol_point(uint32_t dim) const {
        const uint32_t s = sobol::dimension_seed(base_, dim);
        const uint32_t r = sobol::laine_karras_permutation(reversed_index_, s);  // the shuffled index, reversed
        const uint32_t a = sobol::laine_karras_permutation(sobol::reverse_bits(r), s ^ 0xa511e9b3u);
        const uint32_t b = sobol::laine_karras_permutation(sobol::dim1_reversed(r), s ^ 0x63d83595u);
        const uint64_t both = sobol::reverse_bits_pair(uint64_t(a) << 32 | b);
        return {sobol::to_float(uint32_t(both >> 32)), sobol::to_float(uint32_t(both))};
    }

    SamplerKind kind_;
    Pcg32 rng_;
    uint64_t base_ = 0;
    uint32_t reversed_index_ = 0;
    glm::vec2 next_{0.f};  // dimension dim_'s point
    uint32_t dim_ = 0;
};

}  // namespace tessera
