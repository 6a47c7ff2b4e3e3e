#pragma once
// Random numbers that depend only on (seed, pixel, sample index): every sample owns a PCG32
// stream (O'Neill 2014) seeded by hashing those three, so an image is bitwise identical for
// any thread count and any tile order.
#include <cstdint>

namespace tessera {

// SplitMix64 finaliser (Steele et al. 2014): a bijective avalanche hash.
constexpr uint64_t mix64(uint64_t z) {
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

struct Pcg32 {
    uint64_t state = 0x853c49e6748fea9bull;
    uint64_t inc = 0xda3e39cb94b95bdbull;

    Pcg32() = default;
    Pcg32(uint64_t seed, uint64_t stream) {
        state = 0u;
        inc = (stream << 1u) | 1u;
        next_u32();
        state += seed;
        next_u32();
    }
    uint32_t next_u32() {
        const uint64_t old = state;
        state = old * 6364136223846793005ull + inc;
        const uint32_t xorshifted = uint32_t(((old >> 18u) ^ old) >> 27u);
        const uint32_t rot = uint32_t(old >> 59u);
        return (xorshifted >> rot) | (xorshifted << ((~rot + 1u) & 31));
    }
    // Uniform in [0, 1): the top 24 bits, so the result is exactly representable and never 1.
    float next_float() { return float(next_u32() >> 8) * 0x1p-24f; }
};

inline Pcg32 sample_rng(uint64_t seed, uint64_t pixel, uint64_t sample) {
    return Pcg32(mix64(seed ^ mix64(pixel)), mix64(sample ^ mix64(pixel + 0x632be59bd9b4e019ull)));
}

}  // namespace tessera
