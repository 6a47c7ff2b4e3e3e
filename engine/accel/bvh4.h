#pragma once
// A 4-wide BVH collapsed from the binary one (the builders stay binary; this is a layout for
// traversal): each node holds its four children's boxes as structure-of-arrays, so one SSE
// slab test checks all four, and the tree is half as deep. (Wald et al., "Getting rid of
// packets", 2008; Embree's BVH4.)
#include <cstdint>
#include <vector>

#include "engine/accel/bvh.h"

namespace tessera {

struct alignas(64) Bvh4Node {
    // Rows: lo.x, lo.y, lo.z, hi.x, hi.y, hi.z; columns: the four children. Empty slots have
    // lo = +∞ and hi = −∞, which no ray can enter.
    float bounds[6][4];
    uint32_t child[4];  // inner: node index; leaf: first entry of Bvh::prim_index
    uint32_t count[4];  // 0: inner child (or empty slot); n > 0: a leaf of n primitives
};
static_assert(sizeof(Bvh4Node) == 128, "two cache lines per node");

struct Bvh4 {
    std::vector<Bvh4Node> nodes;  // nodes[0] is the root
    // A tree that is one leaf (fewer primitives than a split is worth) keeps it here.
    uint32_t root_leaf_count = 0;
    bool empty() const { return nodes.empty() && root_leaf_count == 0; }
    size_t memory_bytes() const { return nodes.size() * sizeof(Bvh4Node); }
};

// Collapses a binary BVH (whose prim_index order is kept). Each 4-wide node absorbs the
// largest-area inner children of its binary node until it has four children.
Bvh4 collapse_to_bvh4(const Bvh& bvh);

}  // namespace tessera
