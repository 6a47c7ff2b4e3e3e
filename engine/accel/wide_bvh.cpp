#include "engine/accel/wide_bvh.h"

#include <algorithm>
#include <cmath>

namespace tessera {
namespace {

float area(const BvhNode& n) { return Aabb{n.lo, n.hi}.surface_area(); }

uint32_t collapse(const Bvh& bvh, uint32_t binary, WideBvh& out) {
    const uint32_t index = uint32_t(out.nodes.size());
    out.nodes.emplace_back();
    // Gather up to kBvhWidth binary subtrees under this node.
    uint32_t kids[kBvhWidth] = {binary + 1, bvh.nodes[binary].offset};
    int n = 2;
    while (n < kBvhWidth) {
        int best = -1;
        float best_area = -1.f;
        for (int i = 0; i < n; ++i) {
            const BvhNode& k = bvh.nodes[kids[i]];
            if (!k.is_leaf() && area(k) > best_area) { best = i; best_area = area(k); }
        }
        if (best < 0) break;
        const uint32_t open = kids[best];
        kids[best] = open + 1;
        kids[n++] = bvh.nodes[open].offset;
    }
    WideNode node;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < kBvhWidth; ++c) { node.bounds[r][c] = INFINITY; node.bounds[r + 3][c] = -INFINITY; }
    for (int c = 0; c < kBvhWidth; ++c) { node.child[c] = 0; node.count[c] = 0; }
    for (int c = 0; c < n; ++c) {
        const BvhNode& k = bvh.nodes[kids[c]];
        for (int a = 0; a < 3; ++a) { node.bounds[a][c] = k.lo[a]; node.bounds[a + 3][c] = k.hi[a]; }
        if (k.is_leaf()) { node.child[c] = k.offset; node.count[c] = k.count; }
    }
    for (int c = 0; c < n; ++c) {
        const BvhNode& k = bvh.nodes[kids[c]];
        if (!k.is_leaf()) node.child[c] = collapse(bvh, kids[c], out);
    }
    out.nodes[index] = node;
    return index;
}

}  // namespace

WideBvh collapse_to_wide(const Bvh& bvh) {
    WideBvh out;
    if (bvh.nodes.empty()) return out;
    if (bvh.nodes[0].is_leaf()) {
        out.root_leaf_count = bvh.nodes[0].count;
        return out;
    }
    out.nodes.reserve(bvh.nodes.size() / (kBvhWidth - 1) + 1);
    collapse(bvh, 0, out);
    return out;
}

}  // namespace tessera
