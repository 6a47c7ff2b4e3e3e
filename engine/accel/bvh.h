#pragma once
// A bounding volume hierarchy over abstract primitives (given by their bounds), stored as
// flat depth-first nodes: an interior node's left child follows it, the right child is at
// `offset`. The BVH knows nothing of triangles or spheres; traversal takes the primitive test
// as a template argument, so the hot path has no virtual or indirect call.
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "engine/core/large_vector.h"
#include "engine/geometry/aabb.h"

namespace tessera {

enum class BvhType { none, midpoint, median, sah, embree };

const char* to_string(BvhType t);
bool parse_bvh_type(const std::string& s, BvhType& out);

struct BvhNode {
    glm::vec3 lo;
    uint32_t offset;  // leaf: first entry of Bvh::prim_index; interior: index of the right child
    glm::vec3 hi;
    uint32_t count;   // leaf: number of primitives (> 0); interior: 0
    bool is_leaf() const { return count != 0; }
};
static_assert(sizeof(BvhNode) == 32, "two nodes per cache line");

struct BvhBuildOptions {
    BvhType type = BvhType::sah;
    // Largest leaf: two blocks of four (below). For the SAH the render scene builds the binary
    // tree down to one block and lets the collapse to the wide tree merge subtrees up to this
    // size where the SAH prefers a leaf (render_scene.cpp, wide_bvh.h).
    int max_leaf_size = 8;
    // 32 rather than 16: 4–6% faster incoherent and shadow rays on building and maxplanck
    // (`tessera bench rays`), at the same build time (a node gets min(bins, primitives) bins).
    int sah_bins = 32;
    // Relative costs of one node visit and one leaf test. pbrt's 1/8 : 1 (the write-ups')
    // prices a scalar triangle test against a binary node; here a leaf test covers four
    // triangles and a visited wide node eight boxes, which cost about the same, so 1 : 1
    // (Embree's ratio). Measured: throughput within noise of 1/8, and 15–25% less memory.
    float traversal_cost = 1.0f;
    float intersection_cost = 1.0f;
    // Primitives a leaf tests at once: the triangle test takes four (triangle4.h), so a leaf
    // costs one test per started block of four, and the SAH fills blocks rather than
    // splitting below them.
    int leaf_block = 4;
    // Threads for the build (0: one per core). The tree is the same whatever the count.
    int build_threads = 0;
};

struct BvhBuildStats {
    size_t node_count = 0;
    size_t leaf_count = 0;
    int depth = 0;
    std::vector<size_t> leaf_size_histogram;  // [k] = leaves holding k primitives (last bin: k and more)
    double sah_cost = 0.0;                    // expected cost per ray under the SAH model
    double build_seconds = 0.0;
    size_t memory_bytes = 0;
};

struct Bvh {
    LargeVector<BvhNode> nodes;
    LargeVector<uint32_t> prim_index;  // primitive ids in leaf order
    BvhBuildStats stats;
    bool empty() const { return nodes.empty(); }
};

// Deepest tree that traversal's fixed stack supports; builders fall back to median splits
// (depth log2 n) past kMaxBvhDepth / 2, so hostile inputs cannot overflow it.
inline constexpr int kMaxBvhDepth = 128;

Bvh build_bvh(std::span<const Aabb> prim_bounds, const BvhBuildOptions& options);
// The same, with each primitive's bounds computed as the build reads them (called once per
// primitive, from several threads), so a large mesh needs no array of bounds.
Bvh build_bvh(size_t count, const std::function<Aabb(size_t)>& bounds_of, const BvhBuildOptions& options);

// Expected traversal cost of a built tree under the SAH model (the same figure as stats.sah_cost).
double sah_cost(const Bvh& bvh, float traversal_cost, float intersection_cost, int leaf_block = 1);

}  // namespace tessera
