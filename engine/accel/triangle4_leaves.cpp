#include "engine/accel/triangle4_leaves.h"

namespace tessera {
namespace {

// Appends the blocks holding tris[first, first + count), padding the last block with
// copies of the last triangle (a copy hits where the original does, so no lane mask is needed).
uint32_t append_blocks(std::vector<Triangle4>& out, const std::vector<TriangleVerts>& tris, uint32_t first, uint32_t count) {
    const uint32_t start = uint32_t(out.size());
    for (uint32_t b = 0; b * 4 < count; ++b) {
        Triangle4 block;
        for (int l = 0; l < 4; ++l) {
            const uint32_t i = first + std::min(b * 4 + uint32_t(l), count - 1);
            const glm::vec3* v[3] = {&tris[i].p0, &tris[i].p1, &tris[i].p2};
            for (int k = 0; k < 3; ++k)
                for (int a = 0; a < 3; ++a) block.p[k][a][l] = (*v[k])[a];
            block.prim[l] = i;
        }
        out.push_back(block);
    }
    return start;
}

}  // namespace

std::vector<Triangle4> pack_triangle4_leaves(WideBvh& bvh, const std::vector<TriangleVerts>& tris) {
    std::vector<Triangle4> out;
    out.reserve(tris.size() / 3 + 1);
    if (bvh.root_leaf_count) {
        append_blocks(out, tris, 0, bvh.root_leaf_count);
        bvh.root_leaf_count = uint32_t(out.size());
        return out;
    }
    // Depth-first, in node order, so that a subtree's blocks are near each other in memory.
    for (WideNode& n : bvh.nodes)
        for (int c = 0; c < kBvhWidth; ++c) {
            if (n.count[c] == 0) continue;
            const uint32_t count = n.count[c];
            n.child[c] = append_blocks(out, tris, n.child[c], count);
            n.count[c] = (count + 3) / 4;
        }
    out.shrink_to_fit();
    return out;
}

std::vector<Triangle4> pack_triangle4_in_order(const std::vector<TriangleVerts>& tris) {
    std::vector<Triangle4> out;
    out.reserve(tris.size() / 4 + 1);
    for (uint32_t i = 0; i < tris.size(); i += 4)
        append_blocks(out, tris, i, std::min<uint32_t>(4, uint32_t(tris.size()) - i));
    return out;
}

}  // namespace tessera
