// Holds engine/accel/triangle4_leaves.cpp to its packing contract (triangle4_leaves.h): each leaf
// of the wide tree becomes ceil(count / 4) consecutive blocks, laid out depth-first in node
// order, holding exactly the triangles its prim_index entries name, in that order, with exact
// copies of their vertices and their input indices in the lanes; a last block is padded with
// its last triangle; the leaf's entry is rewritten to name its blocks; the single-leaf tree and
// the plain-order packing keep the same promises; and the thread count changes nothing.
// (wide_bvh_test.cpp checks coverage through a whole render scene; this checks the packing
// itself, entry by entry.)
#include "engine/accel/triangle4_leaves.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <numeric>
#include <span>
#include <string>
#include <vector>

#include "engine/sampling/rng.h"

namespace tessera {
namespace {

std::vector<TriangleVerts> random_triangles(size_t n, uint64_t seed) {
    Pcg32 rng(seed, 3);
    auto point = [&rng] {
        const float x = rng.next_float(), y = rng.next_float(), z = rng.next_float();
        return glm::vec3(2.f * x - 1.f, 2.f * y - 1.f, 2.f * z - 1.f);
    };
    std::vector<TriangleVerts> tris(n);
    for (TriangleVerts& t : tris) {
        const glm::vec3 c = point();
        t.p0 = c + 0.05f * point();
        t.p1 = c + 0.05f * point();
        t.p2 = c + 0.05f * point();
    }
    return tris;
}

bool same_triangle(const Triangle4& block, int lane, const TriangleVerts& t) {
    const TriangleVerts v = triangle4_verts(block, lane);
    return v.p0 == t.p0 && v.p1 == t.p1 && v.p2 == t.p2;
}

// Checks one leaf's blocks against the entries it named before packing: lane k of the leaf holds
// entry first + min(k, count - 1), by index and by its exact vertices.
void check_leaf(const LargeVector<Triangle4>& blocks, uint32_t first_block, uint32_t blocks_named, uint32_t first_entry,
                uint32_t count, std::span<const uint32_t> prim_index, std::span<const TriangleVerts> tris,
                std::vector<int>& seen, const std::string& where) {
    ASSERT_EQ(blocks_named, (count + 3) / 4) << where;
    ASSERT_LE(size_t(first_block) + blocks_named, blocks.size()) << where;
    for (uint32_t k = 0; k < 4 * blocks_named; ++k) {
        const Triangle4& block = blocks[first_block + k / 4];
        const int lane = int(k % 4);
        const uint32_t want = prim_index[first_entry + std::min(k, count - 1)];
        ASSERT_EQ(block.prim[lane], want) << where << ", lane " << k;
        ASSERT_TRUE(same_triangle(block, lane, tris[want])) << where << ", lane " << k << ": not the triangle's own vertices";
        if (k < count) ++seen[want];
    }
}

// A binary tree over the triangles' bounds, collapsed, then packed: every leaf names its own
// blocks, the blocks follow the nodes' order, and every triangle is in exactly one leaf's lanes,
// padding aside. The trees cover leaves of one entry to eight (one block or two): SAH leaves
// merged by the collapse as the render scene does, and median and midpoint leaves kept as built.
TEST(Triangle4Leaves, EveryLeafBecomesItsOwnBlocksInNodeOrder) {
    const std::vector<TriangleVerts> tris = random_triangles(3000, 1);
    std::vector<Aabb> bounds;
    for (const TriangleVerts& t : tris) {
        Aabb b;
        b.expand(t.p0); b.expand(t.p1); b.expand(t.p2);
        bounds.push_back(b);
    }
    struct Config {
        BvhType type;
        int max_leaf;
        WideCollapseOptions collapse;
    };
    const Config configs[] = {{BvhType::sah, 1, {8, 1.f, 1.f, 4}},
                              {BvhType::sah, 4, {8, 1.f, 1.f, 4}},
                              {BvhType::midpoint, 3, {}},
                              {BvhType::median, 8, {}}};  // 3000 / 2⁹: leaves of 5 and 6, two blocks each
    for (const Config& cfg : configs) {
        BvhBuildOptions o;
        o.type = cfg.type;
        o.max_leaf_size = cfg.max_leaf;
        o.build_threads = 1;
        const Bvh bvh = build_bvh(bounds, o);
        WideBvh wide = collapse_to_wide(bvh, cfg.collapse);
        ASSERT_FALSE(wide.nodes.empty());
        const WideBvh before = wide;
        const LargeVector<Triangle4> blocks = pack_triangle4_leaves(wide, tris, bvh.prim_index, 1);
        ASSERT_EQ(wide.nodes.size(), before.nodes.size());
        EXPECT_EQ(wide.root_leaf_count, 0u);
        const std::string name = std::string(to_string(cfg.type)) + ", max leaf " + std::to_string(cfg.max_leaf);
        std::vector<int> seen(tris.size(), 0);
        uint32_t next_block = 0;
        int two_block_leaves = 0;
        for (size_t n = 0; n < wide.nodes.size(); ++n)
            for (int c = 0; c < kBvhWidth; ++c) {
                const WideNode &was = before.nodes[n], &is = wide.nodes[n];
                const std::string where = name + ", node " + std::to_string(n) + ", slot " + std::to_string(c);
                for (int r = 0; r < 6; ++r) EXPECT_EQ(is.bounds[r][c], was.bounds[r][c]) << where << ": boxes are not the packing's";
                if (was.count[c] == 0) {
                    // Inner children and empty slots are left as they were.
                    EXPECT_EQ(is.count[c], 0u) << where;
                    EXPECT_EQ(is.child[c], was.child[c]) << where;
                    continue;
                }
                two_block_leaves += was.count[c] > 4;
                EXPECT_EQ(is.child[c], next_block) << where << ": blocks out of node order";
                check_leaf(blocks, is.child[c], is.count[c], was.child[c], was.count[c], bvh.prim_index, tris, seen, where);
                if (HasFatalFailure()) return;
                next_block = is.child[c] + is.count[c];
            }
        EXPECT_EQ(next_block, blocks.size()) << name << ": no block is left unnamed";
        for (size_t i = 0; i < seen.size(); ++i) ASSERT_EQ(seen[i], 1) << name << ", triangle " << i;
        if (cfg.type == BvhType::median) {
            EXPECT_GT(two_block_leaves, 0) << "the median tree's leaves should need two blocks";
        }
    }
}

// A tree that is one leaf: its blocks hold prim_index's order (here not the identity), and the
// leaf's count becomes the number of blocks.
TEST(Triangle4Leaves, SingleLeafTreeFollowsPrimIndex) {
    const std::vector<TriangleVerts> tris = random_triangles(7, 2);
    const std::vector<uint32_t> prim_index = {6, 2, 4, 0, 5, 1, 3};
    WideBvh wide;
    wide.root_leaf_count = 7;
    const LargeVector<Triangle4> blocks = pack_triangle4_leaves(wide, tris, prim_index, 1);
    ASSERT_EQ(blocks.size(), 2u);
    EXPECT_EQ(wide.root_leaf_count, 2u);
    EXPECT_TRUE(wide.nodes.empty());
    std::vector<int> seen(tris.size(), 0);
    check_leaf(blocks, 0, 2, 0, 7, prim_index, tris, seen, "the root leaf");
    for (int s : seen) EXPECT_EQ(s, 1);
    // Exactly one block: no padding at all.
    WideBvh four;
    four.root_leaf_count = 4;
    const LargeVector<Triangle4> one = pack_triangle4_leaves(four, tris, prim_index, 1);
    ASSERT_EQ(one.size(), 1u);
    EXPECT_EQ(four.root_leaf_count, 1u);
    for (int l = 0; l < 4; ++l) EXPECT_EQ(one[0].prim[l], prim_index[size_t(l)]);
}

// Nodes written by hand, enough of them that the packing runs on several threads (it splits the
// nodes at 4096 a thread): the blocks and the rewritten nodes are the same, bit for bit, for any
// thread count.
TEST(Triangle4Leaves, ThreadCountChangesNothing) {
    Pcg32 rng(5, 5);
    const size_t node_count = 3 * 4096 + 17;
    WideBvh wide;
    wide.nodes.resize(node_count);
    uint32_t entries = 0;
    for (WideNode& node : wide.nodes) {
        for (int r = 0; r < 6; ++r)
            for (int c = 0; c < kBvhWidth; ++c) node.bounds[r][c] = r < 3 ? -1.f : 1.f;
        for (int c = 0; c < kBvhWidth; ++c) {
            const uint32_t count = rng.next_u32() % 3 == 0 ? 0u : 1u + rng.next_u32() % 9;
            node.count[c] = count;
            node.child[c] = count ? entries : 7u;  // an inner child's index, left alone
            entries += count;
        }
    }
    const std::vector<TriangleVerts> tris = random_triangles(entries, 6);
    std::vector<uint32_t> prim_index(entries);
    std::iota(prim_index.begin(), prim_index.end(), 0u);
    for (size_t i = prim_index.size(); i > 1; --i) std::swap(prim_index[i - 1], prim_index[rng.next_u32() % i]);

    WideBvh one_thread = wide;
    const LargeVector<Triangle4> a = pack_triangle4_leaves(one_thread, tris, prim_index, 1);
    for (int threads : {2, 3, 4}) {
        WideBvh many = wide;
        const LargeVector<Triangle4> b = pack_triangle4_leaves(many, tris, prim_index, threads);
        ASSERT_EQ(a.size(), b.size()) << threads << " threads";
        EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(Triangle4)), 0) << threads << " threads";
        for (size_t n = 0; n < node_count; ++n)
            for (int c = 0; c < kBvhWidth; ++c) {
                ASSERT_EQ(many.nodes[n].child[c], one_thread.nodes[n].child[c]) << threads << " threads, node " << n;
                ASSERT_EQ(many.nodes[n].count[c], one_thread.nodes[n].count[c]) << threads << " threads, node " << n;
            }
    }
    // And what the one thread wrote is right: every entry once, in its leaf's blocks.
    std::vector<int> seen(entries, 0);
    for (size_t n = 0; n < node_count; ++n)
        for (int c = 0; c < kBvhWidth; ++c) {
            if (wide.nodes[n].count[c] == 0) continue;
            check_leaf(a, one_thread.nodes[n].child[c], one_thread.nodes[n].count[c], wide.nodes[n].child[c],
                       wide.nodes[n].count[c], prim_index, tris, seen, "node " + std::to_string(n));
            if (HasFatalFailure()) return;
        }
    for (int s : seen) ASSERT_EQ(s, 1);
}

// Plain order (Embree's scenes, whose hits name input indices): triangle i in block i / 4,
// lane i % 4, the last block padded with the last triangle; the same for any thread count.
TEST(Triangle4Leaves, InOrderPackingPutsTriangleIAtBlockIOverFour) {
    for (size_t n : {size_t(0), size_t(1), size_t(8), size_t(10), size_t(40001)}) {
        const std::vector<TriangleVerts> tris = random_triangles(n, 7 + n);
        const LargeVector<Triangle4> blocks = pack_triangle4_in_order(tris, 1);
        ASSERT_EQ(blocks.size(), (n + 3) / 4) << n << " triangles";
        for (size_t k = 0; k < 4 * blocks.size(); ++k) {
            const size_t i = std::min(k, n - 1);
            const Triangle4& block = blocks[k / 4];
            ASSERT_EQ(block.prim[k % 4], uint32_t(i)) << n << " triangles, lane " << k;
            ASSERT_TRUE(same_triangle(block, int(k % 4), tris[i])) << n << " triangles, lane " << k;
        }
        const LargeVector<Triangle4> threaded = pack_triangle4_in_order(tris, 4);
        ASSERT_EQ(threaded.size(), blocks.size());
        if (!blocks.empty()) {
            EXPECT_EQ(std::memcmp(threaded.data(), blocks.data(), blocks.size() * sizeof(Triangle4)), 0) << n << " triangles";
        }
    }
}

}  // namespace
}  // namespace tessera
