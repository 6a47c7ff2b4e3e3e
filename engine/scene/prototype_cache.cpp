#include "engine/scene/prototype_cache.h"

#include <algorithm>
#include <cstring>

namespace tessera {

namespace {

uint64_t mix(uint64_t h, uint64_t v) {
    // splitmix64's finaliser over the running state and the next word.
    h ^= v + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
    h ^= h >> 30;
    h *= 0xbf58476d1ce4e5b9ull;
    h ^= h >> 27;
    h *= 0x94d049bb133111ebull;
    return h ^ (h >> 31);
}

}  // namespace

PrototypeCache::Key PrototypeCache::key_of(std::span<const TriangleVerts> tris, const BvhBuildOptions& options) {
    Key k;
    k.triangles = tris.size();
    k.type = options.type;
    k.max_leaf = options.max_leaf_size;
    uint64_t h1 = 0x243f6a8885a308d3ull, h2 = 0x13198a2e03707344ull;
    for (const TriangleVerts& t : tris) {
        float f[9] = {t.p0.x, t.p0.y, t.p0.z, t.p1.x, t.p1.y, t.p1.z, t.p2.x, t.p2.y, t.p2.z};
        uint32_t w[9];
        std::memcpy(w, f, sizeof w);
        for (int i = 0; i < 9; ++i) {
            h1 = mix(h1, w[i]);
            h2 = mix(h2 ^ 0xa4093822299f31d0ull, uint64_t(w[i]) * 0x9e3779b97f4a7c15ull + uint64_t(i));
        }
    }
    k.h1 = h1;
    k.h2 = h2;
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
}

}  // namespace tessera
