#pragma once
// Triangles packed four to a block for the 4-wide test, in the order of a BVH4's leaves.
#include <vector>

#include "engine/accel/wide_bvh.h"
#include "engine/geometry/triangle4.h"

namespace tessera {

// `tris` is in leaf order (a leaf's triangles are tris[child, child + count)). Each leaf
// becomes ceil(count / 4) consecutive blocks, and its entry in the tree is rewritten to
// name those blocks (child: first block, count: number of blocks). Lane ids are indices
// into `tris`.
std::vector<Triangle4> pack_triangle4_leaves(WideBvh& bvh, const std::vector<TriangleVerts>& tris);

// Blocks in plain order, triangle i in block i / 4, lane i % 4 (for Embree's scenes, whose
// hits name triangles by input index).
std::vector<Triangle4> pack_triangle4_in_order(const std::vector<TriangleVerts>& tris);

}  // namespace tessera
