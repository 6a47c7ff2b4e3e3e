#pragma once
// Prototype trees kept from one build of a scene to the next (a shot's frames): a placement that
// moves changes no prototype, so its BVH is reused rather than built again; a mesh that deforms
// (skinned, morphed) has other triangles and is built anew. Keyed by the triangles themselves
// (two independent 64-bit hashes of their coordinates) and the build options; entries the last
// build did not use are dropped, so the cache holds at most one scene's prototypes. It can keep
// the world-space tree too, for a deforming mesh's refit (`world`).
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "engine/accel/bvh.h"
#include "engine/accel/wide_bvh.h"
#include "engine/geometry/aabb.h"
#include "engine/core/large_vector.h"
#include "engine/geometry/triangle.h"
#include "engine/geometry/triangle4.h"

namespace tessera {

struct PrototypeCache {
    struct Key {
        uint64_t h1 = 0, h2 = 0;
        size_t triangles = 0;
        BvhType type = BvhType::sah;
        int max_leaf = 0;
        bool operator==(const Key&) const = default;
    };
    struct Entry {
        Key key;
        WideBvh wide;                    // leaves name blocks from 0
        LargeVector<Triangle4> blocks;   // lanes name triangles from 0
        Aabb bounds;                     // of the triangles
        bool used = false;
    };
    std::vector<Entry> entries;
    size_t hits = 0, misses = 0;  // over the cache's life

    // The world-space triangles' tree of the last build, for RenderSceneOptions::world_tree
    // refit: keyed by their topology (each triangle's vertex indices and material, in order),
    // so the next frame's deformed mesh finds it; its structure and the blocks' triangles.
    struct World {
        Key key;
        WideBvh wide;
        std::vector<uint32_t> lanes;
        double built_sah = 0.0;  // the tree's SAH cost as built (wide_bvh_stats)
        BvhBuildStats stats;     // its binary tree's, as built
        bool used = false;
    };
    std::optional<World> world;
    size_t world_refits = 0, world_builds = 0;

    static Key key_of(std::span<const TriangleVerts> tris, const BvhBuildOptions& options);
    // The same over any bytes (`count` of whatever they hold).
    static Key key_of_bytes(const void* data, size_t bytes, size_t count, const BvhBuildOptions& options);
    Entry* find(const Key& key);
    // Drops what the build just finished did not use, and clears the marks for the next one.
    void end_build();
};

}  // namespace tessera
