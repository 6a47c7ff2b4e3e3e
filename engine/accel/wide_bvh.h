#pragma once
// A wide BVH collapsed from the binary one (the builders stay binary; this is a layout for
// traversal): each node holds its children's boxes as structure-of-arrays, so one SIMD slab
// test checks all of them, and the tree is a fraction as deep. Eight children with AVX (one
// 8-lane test), four otherwise (SSE or scalar). (Wald et al., "Getting rid of packets", 2008;
// Embree's BVH4 and BVH8.)
#include <cstdint>
#include <span>
#include <vector>

#include "engine/accel/bvh.h"
#include "engine/core/large_vector.h"

namespace tessera {

#if defined(TESSERA_BVH_WIDTH)
inline constexpr int kBvhWidth = TESSERA_BVH_WIDTH;
#elif defined(__AVX__)
inline constexpr int kBvhWidth = 8;
#else
inline constexpr int kBvhWidth = 4;
#endif
static_assert(kBvhWidth == 4 || kBvhWidth == 8);

struct alignas(64) WideNode {
    // Rows: lo.x, lo.y, lo.z, hi.x, hi.y, hi.z; columns: the children. Empty slots have
    // lo = +∞ and hi = −∞, which no ray can enter.
    float bounds[6][kBvhWidth];
    uint32_t child[kBvhWidth];  // inner: node index; leaf: what the leaf names (first entry)
    uint32_t count[kBvhWidth];  // 0: inner child (or empty slot); n > 0: a leaf of n entries
};
static_assert(sizeof(WideNode) == 32 * kBvhWidth, "whole cache lines per node");

struct WideBvh {
    LargeVector<WideNode> nodes;  // nodes[0] is the root
    // A tree that is one leaf (fewer primitives than a split is worth) keeps it here.
    uint32_t root_leaf_count = 0;
    bool empty() const { return nodes.empty() && root_leaf_count == 0; }
    size_t memory_bytes() const { return nodes.size() * sizeof(WideNode); }
};

// The shape of a wide tree, comparable with what Embree prints at verbose=2 for its BVH8.
struct WideBvhStats {
    size_t inner_nodes = 0;
    double fill = 0.0;        // mean occupied child slots per inner node, as a fraction of kBvhWidth
    size_t leaves = 0;
    size_t leaf_entries = 0;  // what the leaves name in total (blocks, once packed)
    // Expected cost of a ray through the tree under the surface-area heuristic, in Embree's
    // model: one per inner node entered, one per leaf entry tested, each weighted by the
    // entered box's area over the root's.
    double sah = 0.0;
};
WideBvhStats wide_bvh_stats(const WideBvh& bvh);

// Where the collapse may merge a binary subtree into one leaf. max_leaf 0: never (the binary
// tree's leaves are kept as they are).
struct WideCollapseOptions {
    int max_leaf = 0;
    float traversal_cost = 1.f;
    float intersection_cost = 1.f;
    int leaf_block = 1;
};

// Collapses a binary BVH (whose prim_index order is kept: a leaf names prim_index[child,
// child + count)). Each wide node absorbs the largest-area inner children of its binary node
// until it has kBvhWidth children; then each child that is a binary subtree of at most
// max_leaf primitives becomes one leaf where the SAH says so.
WideBvh collapse_to_wide(const Bvh& bvh, const WideCollapseOptions& options = {});

// Refits a packed tree (leaves name blocks) to its blocks' vertices as they are now: every box
// recomputed from the leaves up, the structure kept (Kopta et al. 2012, "Fast, effective BVH
// updates for animated scenes": cheap, but the tree was chosen for the old positions). With
// `close` (the same blocks at a shutter's closing), boxes hold both.
struct Triangle4;
void refit_wide(WideBvh& bvh, std::span<const Triangle4> blocks, std::span<const Triangle4> close = {});

}  // namespace tessera
