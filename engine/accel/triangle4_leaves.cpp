#include "engine/accel/triangle4_leaves.h"

#include <algorithm>

#include "engine/core/parallel.h"

namespace tessera {
namespace {

// Writes the blocks holding entries [first, first + count) at out[at...], padding the last
// block with copies of the last triangle (a copy hits where the original does, so no lane
// mask is needed). `triangle_of(entry)` names an entry's triangle.
template <class TriangleOf>
void write_blocks(Triangle4* out, std::span<const TriangleVerts> tris, uint32_t first, uint32_t count, TriangleOf triangle_of) {
    for (uint32_t b = 0; b * 4 < count; ++b) {
        Triangle4& block = out[b];
        for (int l = 0; l < 4; ++l) {
            const uint32_t i = triangle_of(first + std::min(b * 4 + uint32_t(l), count - 1));
            const glm::vec3* v[3] = {&tris[i].p0, &tris[i].p1, &tris[i].p2};
            for (int k = 0; k < 3; ++k)
                for (int a = 0; a < 3; ++a) block.p[k][a][l] = (*v[k])[a];
            block.prim[l] = i;
        }
    }
}

uint32_t blocks_for(uint32_t count) { return (count + 3) / 4; }

}  // namespace

LargeVector<Triangle4> pack_triangle4_leaves(WideBvh& bvh, std::span<const TriangleVerts> tris,
                                             std::span<const uint32_t> prim_index, int threads) {
    auto entry = [prim_index](uint32_t e) { return prim_index[e]; };
    if (bvh.root_leaf_count) {
        LargeVector<Triangle4> out(blocks_for(bvh.root_leaf_count));
        write_blocks(out.data(), tris, 0, bvh.root_leaf_count, entry);
        bvh.root_leaf_count = uint32_t(out.size());
        return out;
    }
    // Blocks go depth-first, in node order, so that a subtree's blocks are near each other in
    // memory: a first pass over the nodes gives every leaf its place, the second fills them.
    std::vector<uint32_t> first_block(bvh.nodes.size() + 1);
    uint32_t total = 0;
    for (size_t n = 0; n < bvh.nodes.size(); ++n) {
        first_block[n] = total;
        for (int c = 0; c < kBvhWidth; ++c) total += blocks_for(bvh.nodes[n].count[c]);
    }
    first_block[bvh.nodes.size()] = total;
    LargeVector<Triangle4> out(total);
    parallel_ranges(bvh.nodes.size(), pass_threads(bvh.nodes.size(), threads, 4096), [&](size_t begin, size_t end, int) {
        for (size_t n = begin; n < end; ++n) {
            WideNode& node = bvh.nodes[n];
            uint32_t at = first_block[n];
            for (int c = 0; c < kBvhWidth; ++c) {
                if (node.count[c] == 0) continue;
                const uint32_t count = node.count[c];
                write_blocks(out.data() + at, tris, node.child[c], count, entry);
                node.child[c] = at;
                node.count[c] = blocks_for(count);
                at += node.count[c];
            }
        }
    });
    return out;
}

LargeVector<Triangle4> repack_triangle4(std::span<const uint32_t> lanes, std::span<const TriangleVerts> tris, int threads) {
    LargeVector<Triangle4> out(lanes.size() / 4);
    parallel_ranges(out.size(), pass_threads(out.size(), threads, 4096), [&](size_t begin, size_t end, int) {
        for (size_t b = begin; b < end; ++b)
            for (int l = 0; l < 4; ++l) {
                const uint32_t i = lanes[4 * b + size_t(l)];
                const glm::vec3* v[3] = {&tris[i].p0, &tris[i].p1, &tris[i].p2};
                for (int k = 0; k < 3; ++k)
                    for (int a = 0; a < 3; ++a) out[b].p[k][a][l] = (*v[k])[a];
                out[b].prim[l] = i;
            }
    });
    return out;
}

LargeVector<Triangle4> pack_triangle4_in_order(std::span<const TriangleVerts> tris, int threads) {
    const uint32_t n = uint32_t(tris.size());
    LargeVector<Triangle4> out(blocks_for(n));
    parallel_ranges(out.size(), pass_threads(out.size(), threads, 4096), [&](size_t begin, size_t end, int) {
        for (size_t b = begin; b < end; ++b)
            write_blocks(out.data() + b, tris, uint32_t(b * 4), std::min<uint32_t>(4, n - uint32_t(b * 4)), [](uint32_t e) { return e; });
    });
    return out;
}

}  // namespace tessera
