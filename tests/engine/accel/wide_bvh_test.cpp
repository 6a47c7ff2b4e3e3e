#include "engine/accel/wide_bvh.h"

#include <gtest/gtest.h>

#include <vector>

#include "engine/scene/procedural.h"
#include "engine/scene/intersect.h"

namespace tessera {
namespace {

// The collapsed tree covers every triangle exactly once (in the blocks its leaves name; a
// block's padding lanes repeat a triangle of the same block), inside its parent's boxes, and
// is about half as deep. (Hit-for-hit equality with brute force is in bvh_test.cpp, since
// intersect() traverses this tree.)
TEST(WideBvh, CollapseKeepsEveryPrimitiveOnce) {
    for (BvhType t : {BvhType::midpoint, BvhType::median, BvhType::sah}) {
        RenderSceneOptions o;
        o.bvh.type = t;
        const RenderScene s = build_render_scene(displaced_sphere(20000), o);
        const WideBvh& b = s.tri_wide;
        ASSERT_FALSE(b.nodes.empty());
        std::vector<int> seen(s.triangle_count(), 0);
        struct Item { uint32_t node; int depth; };
        std::vector<Item> todo = {{0, 1}};
        int depth = 0;
        while (!todo.empty()) {
            const Item it = todo.back();
            todo.pop_back();
            depth = std::max(depth, it.depth);
            const WideNode& n = b.nodes[it.node];
            for (int c = 0; c < kBvhWidth; ++c) {
                if (n.bounds[0][c] > n.bounds[3][c]) continue;  // empty slot
                if (n.count[c]) {
                    for (uint32_t b = n.child[c]; b < n.child[c] + n.count[c]; ++b) {
                        const Triangle4& block = s.tri_blocks[b];
                        for (int l = 0; l < 4; ++l) {
                            const TriangleVerts tv = triangle4_verts(block, l);
                            for (const glm::vec3& p : {tv.p0, tv.p1, tv.p2})
                                for (int a = 0; a < 3; ++a) {
                                    EXPECT_GE(p[a], n.bounds[a][c]);
                                    EXPECT_LE(p[a], n.bounds[a + 3][c]);
                                }
                            const bool repeat = l > 0 && block.prim[l] == block.prim[l - 1];
                            if (!repeat) ++seen[block.prim[l]];
                        }
                    }
                } else {
                    todo.push_back({n.child[c], it.depth + 1});
                }
            }
        }
        for (int v : seen) ASSERT_EQ(v, 1);
        EXPECT_LE(depth, s.tri_bvh_stats.depth / 2 + 2) << to_string(t);
    }
}

TEST(WideBvh, SingleLeafTreeIsKeptAsOneLeaf) {
    RenderSceneOptions o;
    o.bvh.type = BvhType::none;
    const RenderScene s = build_render_scene(displaced_sphere(200), o);
    EXPECT_TRUE(s.tri_wide.nodes.empty());
    EXPECT_EQ(s.tri_wide.root_leaf_count, s.tri_blocks.size()) << "the one leaf names every block";
    EXPECT_EQ(s.tri_blocks.size(), (s.triangle_count() + 3) / 4);
}

}  // namespace
}  // namespace tessera
