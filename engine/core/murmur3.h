#pragma once
// MurmurHash3_x86_32 (Austin Appleby, public domain): the hash Cryptomatte names its ids by
// (engine/render/cryptomatte.h), so every decoder finds the same id for a name.
#include <cstdint>
#include <string_view>

namespace tessera {

constexpr uint32_t murmur3_32(std::string_view key, uint32_t seed = 0) {
    auto rotl = [](uint32_t x, int r) { return (x << r) | (x >> (32 - r)); };
    auto byte = [&](size_t i) { return uint32_t(static_cast<unsigned char>(key[i])); };
    constexpr uint32_t c1 = 0xcc9e2d51u, c2 = 0x1b873593u;
    const size_t len = key.size(), blocks = len / 4;
    uint32_t h = seed;
    for (size_t i = 0; i < blocks; ++i) {
        // Little-endian blocks whatever the machine (the reference reads them natively on x86).
        uint32_t k = byte(4 * i) | byte(4 * i + 1) << 8 | byte(4 * i + 2) << 16 | byte(4 * i + 3) << 24;
        k *= c1;
        k = rotl(k, 15);
        k *= c2;
        h ^= k;
        h = rotl(h, 13);
        h = h * 5 + 0xe6546b64u;
    }
    uint32_t k = 0;
    const size_t t = blocks * 4;
    switch (len & 3) {
        case 3: k ^= byte(t + 2) << 16; [[fallthrough]];
        case 2: k ^= byte(t + 1) << 8; [[fallthrough]];
        case 1:
            k ^= byte(t);
            k *= c1;
            k = rotl(k, 15);
            k *= c2;
            h ^= k;
    }
    h ^= uint32_t(len);
    h ^= h >> 16;
    h *= 0x85ebca6bu;
    h ^= h >> 13;
    h *= 0xc2b2ae35u;
    h ^= h >> 16;
    return h;
}

}  // namespace tessera
