#pragma once
// Triangles packed four to a block for the 4-wide test, in the order of a BVH4's leaves.
#include <cstdint>
#include <span>

#include "engine/accel/wide_bvh.h"
#include "engine/core/large_vector.h"
#include "engine/geometry/triangle4.h"

namespace tessera {

// A leaf names entries [child, child + count) of `prim_index`, which gives each entry's
// triangle in `tris`. Each leaf becomes ceil(count / 4) consecutive blocks, and its entry in
// the tree is rewritten to name those blocks (child: first block, count: number of blocks).
// Lane ids are indices into `tris` (the triangles' input order, which shading data keeps).
// Packed on up to `threads` threads (0: one per core); the blocks are the same whatever the count.
LargeVector<Triangle4> pack_triangle4_leaves(WideBvh& bvh, std::span<const TriangleVerts> tris,
                                             std::span<const uint32_t> prim_index, int threads = 0);

// `lanes`' triangles (four per block, as the prim ids of blocks packed before) from `tris`:
// the blocks an earlier packing made, with the triangles' vertices as they are now (a
// deformed mesh whose tree is refitted, refit_wide).
LargeVector<Triangle4> repack_triangle4(std::span<const uint32_t> lanes, std::span<const TriangleVerts> tris, int threads = 0);

// Blocks in plain order, triangle i in block i / 4, lane i % 4 (for Embree's scenes, whose
// hits name triangles by input index).
LargeVector<Triangle4> pack_triangle4_in_order(std::span<const TriangleVerts> tris, int threads = 0);

}  // namespace tessera
