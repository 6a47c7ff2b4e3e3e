#include "engine/accel/wide_bvh.h"

#include <algorithm>
#include <cmath>

#include "engine/geometry/triangle4.h"

namespace tessera {
namespace {

float area(const BvhNode& n) { return Aabb{n.lo, n.hi}.surface_area(); }

struct Collapser {
    const Bvh& bvh;
    const WideCollapseOptions& opt;
    std::vector<uint32_t> first, count;  // each binary subtree's range of leaf entries

    // Fills first/count bottom-up; a subtree's entries are contiguous (the builders partition
    // in place and lay leaves out depth-first).
    void measure(uint32_t i) {
        const BvhNode& n = bvh.nodes[i];
        if (n.is_leaf()) { first[i] = n.offset; count[i] = n.count; return; }
        measure(i + 1);
        measure(n.offset);
        first[i] = first[i + 1];
        count[i] = count[i + 1] + count[n.offset];
    }

    double blocks(uint32_t n) const { return double((n + uint32_t(opt.leaf_block) - 1) / uint32_t(opt.leaf_block)); }

    // Embree's rule for a subtree that would become a wide node: one leaf instead when it is
    // small enough and the SAH prices the leaf at most at the split (a node visit plus its two
    // halves as leaves).
    bool as_leaf(uint32_t i) const {
        const BvhNode& n = bvh.nodes[i];
        if (n.is_leaf()) return true;
        if (count[i] > uint32_t(opt.max_leaf)) return false;
        const uint32_t l = i + 1, r = n.offset;
        const double leaf = opt.intersection_cost * blocks(count[i]) * area(n);
        const double split = opt.traversal_cost * area(n) +
                             opt.intersection_cost * (blocks(count[l]) * area(bvh.nodes[l]) + blocks(count[r]) * area(bvh.nodes[r]));
        return leaf <= split;
    }

    uint32_t collapse(uint32_t binary, WideBvh& out) {
        const uint32_t index = uint32_t(out.nodes.size());
        out.nodes.emplace_back();
        // Gather up to kBvhWidth binary subtrees under this node, opening the largest first.
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
        bool leaf[kBvhWidth];
        for (int c = 0; c < n; ++c) {
            const BvhNode& k = bvh.nodes[kids[c]];
            for (int a = 0; a < 3; ++a) { node.bounds[a][c] = k.lo[a]; node.bounds[a + 3][c] = k.hi[a]; }
            leaf[c] = as_leaf(kids[c]);
            if (leaf[c]) { node.child[c] = first[kids[c]]; node.count[c] = count[kids[c]]; }
        }
        for (int c = 0; c < n; ++c)
            if (!leaf[c]) node.child[c] = collapse(kids[c], out);
        out.nodes[index] = node;
        return index;
    }
};

}  // namespace

WideBvh collapse_to_wide(const Bvh& bvh, const WideCollapseOptions& options) {
    WideBvh out;
    if (bvh.nodes.empty()) return out;
    Collapser c{bvh, options, std::vector<uint32_t>(bvh.nodes.size()), std::vector<uint32_t>(bvh.nodes.size())};
    c.measure(0);
    if (c.as_leaf(0)) {
        out.root_leaf_count = c.count[0];
        return out;
    }
    out.nodes.reserve(bvh.nodes.size() / (kBvhWidth - 1) + 1);
    c.collapse(0, out);
    return out;
}

WideBvhStats wide_bvh_stats(const WideBvh& bvh) {
    WideBvhStats st;
    if (bvh.nodes.empty()) {
        if (bvh.root_leaf_count) { st.leaves = 1; st.leaf_entries = bvh.root_leaf_count; st.sah = bvh.root_leaf_count; }
        return st;
    }
    auto child_area = [](const WideNode& n, int c) {
        const glm::vec3 d{n.bounds[3][c] - n.bounds[0][c], n.bounds[4][c] - n.bounds[1][c], n.bounds[5][c] - n.bounds[2][c]};
        return 2.0 * (double(d.x) * d.y + double(d.y) * d.z + double(d.z) * d.x);
    };
    Aabb root;
    const WideNode& r = bvh.nodes[0];
    for (int c = 0; c < kBvhWidth; ++c)
        if (r.bounds[0][c] <= r.bounds[3][c]) root.expand(Aabb{{r.bounds[0][c], r.bounds[1][c], r.bounds[2][c]}, {r.bounds[3][c], r.bounds[4][c], r.bounds[5][c]}});
    const double root_area = std::max(double(root.surface_area()), 1e-30);
    st.inner_nodes = bvh.nodes.size();
    st.sah = 1.0;  // the root is always entered
    size_t slots = 0;
    for (const WideNode& n : bvh.nodes)
        for (int c = 0; c < kBvhWidth; ++c) {
            if (!(n.bounds[0][c] <= n.bounds[3][c])) continue;  // empty slot
            ++slots;
            const double w = child_area(n, c) / root_area;
            if (n.count[c]) { ++st.leaves; st.leaf_entries += n.count[c]; st.sah += w * n.count[c]; }
            else st.sah += w;
        }
    st.fill = double(slots) / double(st.inner_nodes * kBvhWidth);
    return st;
}

namespace {

void expand_blocks(Aabb& box, std::span<const Triangle4> blocks, uint32_t first, uint32_t count) {
    for (uint32_t b = first; b < first + count; ++b)
        for (int v = 0; v < 3; ++v)
            for (int l = 0; l < 4; ++l) box.expand(triangle4_vertex(blocks[b], v, l));
}

// Node n's slots from its children, returning their union.
Aabb refit_node(WideBvh& bvh, uint32_t n, std::span<const Triangle4> blocks, std::span<const Triangle4> close) {
    Aabb all;
    for (int c = 0; c < kBvhWidth; ++c) {
        WideNode& node = bvh.nodes[n];
        if (!(node.bounds[0][c] <= node.bounds[3][c])) continue;  // an empty slot stays empty
        Aabb box;
        if (node.count[c]) {
            expand_blocks(box, blocks, node.child[c], node.count[c]);
            if (!close.empty()) expand_blocks(box, close, node.child[c], node.count[c]);
        } else {
            box = refit_node(bvh, node.child[c], blocks, close);
        }
        WideNode& again = bvh.nodes[n];
        for (int a = 0; a < 3; ++a) {
            again.bounds[a][c] = box.lo[a];
            again.bounds[3 + a][c] = box.hi[a];
        }
        all.expand(box);
    }
    return all;
}

}  // namespace

void refit_wide(WideBvh& bvh, std::span<const Triangle4> blocks, std::span<const Triangle4> close) {
    if (!bvh.nodes.empty()) refit_node(bvh, 0, blocks, close);
}

}  // namespace tessera
