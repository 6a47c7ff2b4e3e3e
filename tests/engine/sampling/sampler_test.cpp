#include "engine/sampling/sampler.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <vector>

namespace tessera {
namespace {

// The points samples first..first+n−1 of one pixel give for one dimension (a 2-D request after
// `skip` draws).
std::vector<glm::vec2> points(uint64_t seed, uint64_t pixel, int first, int n, int skip) {
    std::vector<glm::vec2> p;
    for (int i = 0; i < n; ++i) {
        Sampler s(SamplerKind::sobol, seed, pixel, uint64_t(first + i));
        for (int k = 0; k < skip; ++k) s.next_float();
        p.push_back(s.next_2d());
    }
    return p;
}

TEST(SobolBits, SecondDimensionIsPascalsMatrix) {
    // The first points of Sobol's second dimension in index order (Joe & Kuo list them in Gray-code
    // order: 0, 1/2, 3/4, 1/4, 3/8, 7/8, 5/8, 1/8): the direction numbers 1/2, 3/4, 5/8 XORed by
    // the index's bits.
    const double want[] = {0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875};
    for (uint32_t i = 0; i < 8; ++i) EXPECT_EQ(double(sobol::dim1(i)) * 0x1p-32, want[i]) << i;
    for (uint32_t i = 0; i < 8; ++i) EXPECT_EQ(sobol::dim0(i), sobol::reverse_bits(i));
}

// The reversals the hot path uses (GFNI's byte reversal where the compiler targets it, shifts
// and masks elsewhere) against the definition, one bit at a time.
TEST(SobolBits, ReversalsAreTheBitByBitDefinition) {
    auto naive = [](uint32_t x) {
        uint32_t r = 0;
        for (int j = 0; j < 32; ++j) r |= ((x >> j) & 1u) << (31 - j);
        return r;
    };
    Pcg32 rng(7, 11);
    for (int i = 0; i < 10000; ++i) {
        const uint32_t a = rng.next_u32(), b = rng.next_u32();
        ASSERT_EQ(sobol::reverse_bits(a), naive(a)) << a;
        ASSERT_EQ(sobol::reverse_bits_pair(uint64_t(a) << 32 | b), uint64_t(naive(a)) << 32 | naive(b)) << a << " " << b;
    }
    for (uint32_t x : {0u, 1u, 0x80000000u, 0xffffffffu}) EXPECT_EQ(sobol::reverse_bits(x), naive(x));
}

// The sampler's fast path draws exactly the points the reference composition defines: the
// shuffled index, then the scrambled first and second dimensions at it.
TEST(Sampler, FastPathIsTheReferenceComposition) {
    for (uint64_t pixel : {0ull, 77ull, 123456789ull})
        for (uint32_t sample : {0u, 1u, 2u, 3u, 17u, 1000u, 65535u}) {
            Sampler s(SamplerKind::sobol, 42, pixel, sample);
            const uint64_t base = mix64(mix64(42 ^ 0x5851f42d4c957f2dull) ^ mix64(pixel));
            for (uint32_t dim = 0; dim < 12; ++dim) {
                const uint32_t seed = sobol::dimension_seed(base, dim);
                const uint32_t i = sobol::shuffled_index(sample, seed);
                const float x = sobol::to_float(sobol::scrambled_dim0(i, seed ^ 0xa511e9b3u));
                if (dim % 3 == 2) {
                    ASSERT_EQ(s.next_float(), x) << pixel << " " << sample << " " << dim;
                } else {
                    const float y = sobol::to_float(sobol::nested_uniform_scramble(sobol::dim1(i), seed ^ 0x63d83595u));
                    const glm::vec2 p = s.next_2d();
                    ASSERT_EQ(p.x, x) << pixel << " " << sample << " " << dim;
                    ASSERT_EQ(p.y, y) << pixel << " " << sample << " " << dim;
                }
            }
        }
}

TEST(SobolBits, ScrambleIsAPermutationOfEachAlignedBlock) {
    // An Owen scramble maps each dyadic interval onto one of the same size: the first 2^k values
    // (as 32-bit fractions) land in 2^k distinct intervals of length 2^-k.
    for (uint32_t seed : {0u, 1u, 0xdeadbeefu}) {
        std::set<uint32_t> cells;
        for (uint32_t i = 0; i < 256; ++i) cells.insert(sobol::nested_uniform_scramble(sobol::dim0(i), seed) >> 24);
        EXPECT_EQ(cells.size(), 256u) << seed;
    }
}

// A pixel's first 2^k points of every dimension are a (0,k,2)-net: each elementary interval of
// area 2^-k (2^a × 2^(k−a) cells, for every a) holds exactly one point. So is every aligned
// block of 2^k samples after them (the error estimate's halves: convergence.h).
TEST(Sampler, EachDimensionIsStratifiedAsANet) {
    for (int k : {2, 4, 6, 8}) {
        const int n = 1 << k;
        for (int skip : {0, 1, 3, 7}) {
            for (int block : {0, 1, 3}) {
                const auto p = points(5, 1234 + uint64_t(k), block * n, n, skip);
                for (int a = 0; a <= k; ++a) {
                    std::vector<int> cell(size_t(n), 0);
                    for (const glm::vec2& q : p) {
                        const int x = int(q.x * float(1 << a)), y = int(q.y * float(1 << (k - a)));
                        ++cell[size_t(x) * size_t(1 << (k - a)) + size_t(y)];
                    }
                    for (int c : cell) ASSERT_EQ(c, 1) << "k " << k << " a " << a << " skip " << skip << " block " << block;
                }
            }
        }
    }
}

TEST(Sampler, OneDimensionalDrawsAreStratified) {
    const int n = 64;
    for (int skip : {0, 2, 5}) {
        std::vector<int> cell(n, 0);
        for (int i = 0; i < n; ++i) {
            Sampler s(SamplerKind::sobol, 9, 77, uint64_t(i));
            for (int k = 0; k < skip; ++k) s.next_2d();
            ++cell[size_t(s.next_float() * n)];
        }
        for (int c : cell) ASSERT_EQ(c, 1) << "skip " << skip;
    }
}

// Unbiased: over pixels (independent scrambles) each draw is uniform on [0, 1): its mean and
// second moment, and no correlation between the two coordinates, between dimensions, or
// between neighbouring pixels.
TEST(Sampler, DrawsAreUniformAndUncorrelatedAcrossScrambles) {
    const int pixels = 200000;
    double m[4] = {0, 0, 0, 0}, m2[4] = {0, 0, 0, 0}, xy = 0, dims = 0, neighbours = 0;
    for (int px = 0; px < pixels; ++px) {
        Sampler a(SamplerKind::sobol, 3, uint64_t(px), 6), b(SamplerKind::sobol, 3, uint64_t(px) + 1, 6);
        const glm::vec2 p = a.next_2d(), q = a.next_2d();
        const glm::vec2 r = b.next_2d();
        const double v[4] = {p.x, p.y, q.x, q.y};
        for (int i = 0; i < 4; ++i) {
            ASSERT_GE(v[i], 0.0);
            ASSERT_LT(v[i], 1.0);
            m[i] += v[i];
            m2[i] += v[i] * v[i];
        }
        xy += (p.x - 0.5) * (p.y - 0.5);
        dims += (p.x - 0.5) * (q.x - 0.5);
        neighbours += (p.x - 0.5) * (r.x - 0.5);
    }
    // se of a mean: √(1/12/n) ≈ 6.5e-4; of a second moment √(4/45/n) ≈ 6.7e-4; of a covariance
    // of independent uniforms 1/12/√n ≈ 1.9e-4. Five of each.
    for (int i = 0; i < 4; ++i) {
        EXPECT_NEAR(m[i] / pixels, 0.5, 5 * 6.5e-4) << i;
        EXPECT_NEAR(m2[i] / pixels, 1.0 / 3.0, 5 * 6.7e-4) << i;
    }
    EXPECT_NEAR(xy / pixels, 0.0, 5 * 1.9e-4);
    EXPECT_NEAR(dims / pixels, 0.0, 5 * 1.9e-4);
    EXPECT_NEAR(neighbours / pixels, 0.0, 5 * 1.9e-4);
}

TEST(Sampler, DependsOnlyOnSeedPixelAndSample) {
    Sampler a(SamplerKind::sobol, 1, 10, 5), b(SamplerKind::sobol, 1, 10, 5), c(SamplerKind::sobol, 1, 11, 5),
        d(SamplerKind::sobol, 2, 10, 5);
    const glm::vec2 x = a.next_2d();
    EXPECT_EQ(x, b.next_2d());
    EXPECT_NE(x, c.next_2d());
    EXPECT_NE(x, d.next_2d());
}

// Independent sampling draws exactly the numbers of its PCG32 stream, in the order this renderer
// always drew them: images made with it do not change.
TEST(Sampler, IndependentIsThePcgStream) {
    Sampler s(SamplerKind::independent, 4, 99, 3);
    Pcg32 r = sample_rng(4, 99, 3);
    EXPECT_EQ(s.next_float(), r.next_float());
    const float first = r.next_float(), second = r.next_float();
    EXPECT_EQ(s.next_2d(), glm::vec2(second, first));
}

}  // namespace
}  // namespace tessera
