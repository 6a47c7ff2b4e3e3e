#include "engine/scene/prototype_cache.h"

#include <algorithm>
#include <cstring>

namespace tessera {

namespace {

// One multiply and two shifts per 8 bytes (a wyhash-like mix): hashing a million triangles
// costs a few milliseconds, a small part of what building their tree again would.
inline uint64_t step(uint64_t h, uint64_t w, uint64_t k) {
    h = (h ^ w) * k;
    return h ^ (h >> 29) ^ (h >> 47);
}

uint64_t finish(uint64_t h) {
    h ^= h >> 30;
    h *= 0xbf58476d1ce4e5b9ull;
    h ^= h >> 27;
    h *= 0x94d049bb133111ebull;
    return h ^ (h >> 31);
}

}  // namespace

PrototypeCache::Key PrototypeCache::key_of(std::span<const TriangleVerts> tris, const BvhBuildOptions& options) {
    static_assert(sizeof(TriangleVerts) == 36);
    return key_of_bytes(tris.data(), tris.size() * sizeof(TriangleVerts), tris.size(), options);
}

PrototypeCache::Key PrototypeCache::key_of_bytes(const void* data, size_t n, size_t count, const BvhBuildOptions& options) {
    Key k;
    k.triangles = count;
    k.type = options.type;
    k.max_leaf = options.max_leaf_size;
    // Two independent streams over the bits, eight bytes at a time.
    const auto* bytes = static_cast<const unsigned char*>(data);
    uint64_t h1 = 0x243f6a8885a308d3ull ^ n, h2 = 0x13198a2e03707344ull ^ (n * 0x9e3779b97f4a7c15ull);
    size_t i = 0;
    for (; i + 8 <= n; i += 8) {
        uint64_t w;
        std::memcpy(&w, bytes + i, 8);
        h1 = step(h1, w, 0x9e3779b97f4a7c15ull);
        h2 = step(h2, w + i, 0xd6e8feb86659fd93ull);
    }
    if (i < n) {
        uint64_t w = 0;
        std::memcpy(&w, bytes + i, n - i);
        h1 = step(h1, w, 0x9e3779b97f4a7c15ull);
        h2 = step(h2, w + i, 0xd6e8feb86659fd93ull);
    }
    k.h1 = finish(h1);
    k.h2 = finish(h2);
    return k;
}

PrototypeCache::Entry* PrototypeCache::find(const Key& key) {
    for (Entry& e : entries)
        if (e.key == key) return &e;
    return nullptr;
}

void PrototypeCache::end_build() {
    entries.erase(std::remove_if(entries.begin(), entries.end(), [](const Entry& e) { return !e.used; }), entries.end());
    for (Entry& e : entries) e.used = false;
    if (world && !world->used) world.reset();
    if (world) world->used = false;
}

}  // namespace tessera
