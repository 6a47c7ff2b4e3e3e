// Holds engine/accel/bvh_build.cpp to the tree it promises in bvh.h, read straight off the
// binary nodes rather than through a render scene: prim_index a permutation that the leaves
// tile in depth-first order, every node's box exactly the union of what it holds, leaves no
// larger than max_leaf_size (the SAH included), statistics that describe the tree, the two
// build_bvh forms agreeing, and closest and any hits through bvh_traverse.h equal to brute force
// for every builder. (bvh_test.cpp covers the render scene's path, thread-count determinism and
// depth under degenerate inputs.)
#include "engine/accel/bvh.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <numeric>
#include <span>
#include <string>
#include <vector>

#include "engine/accel/bvh_traverse.h"
#include "engine/geometry/triangle.h"
#include "engine/sampling/rng.h"
#include "tests/test_scale.h"

namespace tessera {
namespace {

constexpr BvhType kAllBuilders[] = {BvhType::none, BvhType::midpoint, BvhType::median, BvhType::sah};

glm::vec3 random_in(Pcg32& rng, float lo, float hi) {
    const float x = rng.next_float(), y = rng.next_float(), z = rng.next_float();
    return glm::vec3(lo) + (hi - lo) * glm::vec3(x, y, z);
}

// Boxes of mixed sizes: mostly small, some long slivers and a few large ones, half of them in
// two tight clusters, so that the builders meet both uneven and crowded nodes.
std::vector<Aabb> random_boxes(int n, uint64_t seed) {
    Pcg32 rng(seed, 5);
    std::vector<Aabb> out;
    for (int i = 0; i < n; ++i) {
        const int kind = int(rng.next_u32() % 8);
        glm::vec3 c = random_in(rng, -1.f, 1.f);
        if (kind < 4) c = (kind < 2 ? glm::vec3(0.3f, -0.2f, 0.1f) : glm::vec3(-0.6f, 0.5f, 0.4f)) + 0.02f * c;
        glm::vec3 half = random_in(rng, 0.f, 0.01f);
        if (kind == 5) half[int(rng.next_u32() % 3)] = 0.5f;  // a sliver along one axis
        if (kind == 6 && rng.next_u32() % 8 == 0) half = glm::vec3(0.4f);
        out.push_back(Aabb{c - half, c + half});
    }
    return out;
}

BvhBuildOptions options(BvhType t, int max_leaf, int threads = 1) {
    BvhBuildOptions o;
    o.type = t;
    o.max_leaf_size = max_leaf;
    o.build_threads = threads;
    return o;
}

bool same_box(const glm::vec3& lo, const glm::vec3& hi, const Aabb& b) { return lo == b.lo && hi == b.hi; }

struct TreeShape {
    std::vector<uint32_t> leaves;  // node indices in depth-first order (left before right)
    int depth = 0;                 // of the deepest node, the root at 0
};

// Walks the flat tree as traversal reads it (left child at i + 1, right child at offset) and
// checks, node by node, what bvh.h promises of the layout and the boxes. Every node must be
// reached exactly once: a node shared or skipped would go unnoticed by ray queries that happen
// not to need it.
TreeShape check_tree(const Bvh& bvh, std::span<const Aabb> boxes, const char* what) {
    TreeShape shape;
    const size_t n = boxes.size();
    EXPECT_EQ(bvh.prim_index.size(), n) << what;
    std::vector<uint32_t> sorted(bvh.prim_index.begin(), bvh.prim_index.end());
    std::sort(sorted.begin(), sorted.end());
    for (size_t i = 0; i < sorted.size(); ++i)
        if (sorted[i] != i) {
            ADD_FAILURE() << what << ": prim_index is not a permutation (entry " << i << " is " << sorted[i] << ")";
            return shape;  // the checks below index boxes through it
        }
    if (bvh.nodes.empty()) {
        EXPECT_EQ(n, 0u) << what;
        return shape;
    }
    std::vector<int> visits(bvh.nodes.size(), 0);
    struct Item { uint32_t node; int depth; };
    std::vector<Item> todo = {{0, 0}};
    uint32_t next_entry = 0;  // leaves must tile prim_index in depth-first order
    while (!todo.empty()) {
        const Item it = todo.back();
        todo.pop_back();
        if (it.node >= bvh.nodes.size()) {
            ADD_FAILURE() << what << ": a child index " << it.node << " past the " << bvh.nodes.size() << " nodes";
            continue;
        }
        if (++visits[it.node] > 1) {
            ADD_FAILURE() << what << ": node " << it.node << " is reached twice";
            continue;
        }
        shape.depth = std::max(shape.depth, it.depth);
        const BvhNode& node = bvh.nodes[it.node];
        if (node.is_leaf()) {
            shape.leaves.push_back(it.node);
            EXPECT_EQ(node.offset, next_entry) << what << ": leaf " << it.node << " out of depth-first order";
            if (size_t(node.offset) + node.count > n) {
                ADD_FAILURE() << what << ": leaf " << it.node << " runs past prim_index";
                continue;
            }
            next_entry = node.offset + node.count;
            Aabb u;
            for (uint32_t e = node.offset; e < node.offset + node.count; ++e) u.expand(boxes[bvh.prim_index[e]]);
            EXPECT_TRUE(same_box(node.lo, node.hi, u)) << what << ": leaf " << it.node << "'s box is not its primitives' union";
            continue;
        }
        const uint32_t left = it.node + 1, right = node.offset;
        if (right <= left || right >= bvh.nodes.size() || left >= bvh.nodes.size()) {
            ADD_FAILURE() << what << ": interior node " << it.node << " has right child " << right;
            continue;
        }
        const Aabb u = merge(Aabb{bvh.nodes[left].lo, bvh.nodes[left].hi}, Aabb{bvh.nodes[right].lo, bvh.nodes[right].hi});
        EXPECT_TRUE(same_box(node.lo, node.hi, u)) << what << ": node " << it.node << "'s box is not its children's union";
        todo.push_back({right, it.depth + 1});
        todo.push_back({left, it.depth + 1});
    }
    EXPECT_EQ(next_entry, n) << what << ": the leaves do not cover prim_index";
    for (size_t i = 0; i < visits.size(); ++i)
        if (visits[i] == 0) {
            ADD_FAILURE() << what << ": node " << i << " is never reached";
            break;
        }
    Aabb all;
    for (const Aabb& b : boxes) all.expand(b);
    EXPECT_TRUE(same_box(bvh.nodes[0].lo, bvh.nodes[0].hi, all)) << what << ": the root is not the scene's box";
    return shape;
}

TEST(BvhBuild, EveryBuilderMakesAValidTreeOverEveryPrimitiveOnce) {
    const std::vector<Aabb> boxes = random_boxes(3000, 1);
    for (BvhType t : kAllBuilders)
        for (int leaf : {1, 3, 8}) {
            const std::string what = std::string(to_string(t)) + ", max leaf " + std::to_string(leaf);
            const Bvh bvh = build_bvh(boxes, options(t, leaf));
            const TreeShape shape = check_tree(bvh, boxes, what.c_str());
            if (t == BvhType::none) {
                ASSERT_EQ(bvh.nodes.size(), 1u) << what;
                EXPECT_EQ(bvh.nodes[0].count, boxes.size()) << what;
            }
            EXPECT_EQ(shape.leaves.size() * 2 - 1, bvh.nodes.size()) << what << ": a binary tree";
        }
}

// The parallel build lays its parts out as the sequential one does; the layout checks must hold
// for the spliced tree too (child offsets moved by each part's base).
TEST(BvhBuild, ParallelBuildKeepsTheLayout) {
    const std::vector<Aabb> boxes = random_boxes(20000 / test::kWorkScale, 2);
    for (BvhType t : {BvhType::midpoint, BvhType::median, BvhType::sah}) {
        const Bvh bvh = build_bvh(boxes, options(t, 4, 4));
        check_tree(bvh, boxes, to_string(t));
    }
}

// The leaf-size bound holds for the SAH too (it keeps a leaf only when n <= max_leaf_size,
// bvh.h), and for boxes whose centroids coincide, which no plane can separate.
TEST(BvhBuild, LeavesRespectTheMaximumSize) {
    const std::vector<Aabb> boxes = random_boxes(4000, 3);
    std::vector<Aabb> same(300, Aabb{glm::vec3(-1.f, 0.f, 2.f), glm::vec3(1.f, 0.5f, 2.5f)});
    // Coinciding centroids, different boxes: the split must still be by count.
    for (size_t i = 0; i < same.size(); i += 2) same[i] = Aabb{glm::vec3(-2.f, -0.25f, 1.5f), glm::vec3(2.f, 0.75f, 3.f)};
    const std::vector<Aabb>* inputs[] = {&boxes, &same};
    for (const std::vector<Aabb>* input : inputs)
        for (BvhType t : {BvhType::midpoint, BvhType::median, BvhType::sah})
            for (int leaf : {1, 2, 4, 5, 8, 16}) {
                const Bvh bvh = build_bvh(*input, options(t, leaf));
                const std::string what = std::string(to_string(t)) + ", max leaf " + std::to_string(leaf) +
                                         (input == &same ? ", coinciding centroids" : "");
                const TreeShape shape = check_tree(bvh, *input, what.c_str());
                uint32_t largest = 0;
                for (uint32_t l : shape.leaves) {
                    EXPECT_GT(bvh.nodes[l].count, 0u) << what;
                    largest = std::max(largest, bvh.nodes[l].count);
                }
                EXPECT_LE(largest, uint32_t(leaf)) << what;
                EXPECT_LT(shape.depth, kMaxBvhDepth) << what;
            }
}

// The statistics describe the tree as built: depth, counts, the leaf-size histogram, the memory
// and the SAH cost (the same figure as sah_cost(), which is checked against the model itself).
TEST(BvhBuild, StatsDescribeTheTree) {
    const std::vector<Aabb> boxes = random_boxes(5000, 4);
    for (BvhType t : kAllBuilders) {
        BvhBuildOptions o = options(t, 6);
        o.traversal_cost = 0.7f;
        o.intersection_cost = 1.3f;
        o.leaf_block = 4;
        const Bvh bvh = build_bvh(boxes, o);
        const TreeShape shape = check_tree(bvh, boxes, to_string(t));
        const BvhBuildStats& s = bvh.stats;
        EXPECT_EQ(s.node_count, bvh.nodes.size()) << to_string(t);
        EXPECT_EQ(s.leaf_count, shape.leaves.size()) << to_string(t);
        EXPECT_EQ(s.depth, shape.depth) << to_string(t);
        EXPECT_EQ(s.memory_bytes, bvh.nodes.size() * sizeof(BvhNode) + bvh.prim_index.size() * sizeof(uint32_t));
        EXPECT_GE(s.build_seconds, 0.0);
        std::vector<size_t> histogram(size_t(o.max_leaf_size) + 2, 0);
        for (uint32_t l : shape.leaves) ++histogram[std::min<size_t>(bvh.nodes[l].count, histogram.size() - 1)];
        EXPECT_EQ(s.leaf_size_histogram, histogram) << to_string(t);

        const double root = Aabb{bvh.nodes[0].lo, bvh.nodes[0].hi}.surface_area();
        double cost = 0;
        for (const BvhNode& n : bvh.nodes) {
            const double area = Aabb{n.lo, n.hi}.surface_area();
            cost += (n.is_leaf() ? 1.3 * double((n.count + 3) / 4) : 0.7) * area / root;
        }
        EXPECT_NEAR(s.sah_cost, cost, 1e-6 * cost) << to_string(t);
        EXPECT_EQ(s.sah_cost, sah_cost(bvh, o.traversal_cost, o.intersection_cost, o.leaf_block)) << to_string(t);
    }
}

TEST(BvhBuild, EmptyAndSingleInputs) {
    const Bvh empty = build_bvh(std::span<const Aabb>{}, BvhBuildOptions{});
    EXPECT_TRUE(empty.empty());
    EXPECT_TRUE(empty.prim_index.empty());
    EXPECT_EQ(sah_cost(empty, 1.f, 1.f), 0.0);
    const std::vector<Aabb> one = {Aabb{glm::vec3(1.f, 2.f, 3.f), glm::vec3(2.f, 3.f, 5.f)}};
    for (BvhType t : kAllBuilders) {
        const Bvh b = build_bvh(one, options(t, 8));
        ASSERT_EQ(b.nodes.size(), 1u) << to_string(t);
        EXPECT_EQ(b.nodes[0].count, 1u);
        EXPECT_EQ(b.prim_index[0], 0u);
        check_tree(b, one, to_string(t));
    }
    // Every primitive at one point: the root has no area, and the cost is the leaves' tests alone.
    const std::vector<Aabb> points(10, Aabb{glm::vec3(4.f), glm::vec3(4.f)});
    const Bvh p = build_bvh(points, options(BvhType::sah, 8));
    check_tree(p, points, "points");
    EXPECT_EQ(sah_cost(p, 1.f, 2.f, 4), 2.0 * 3);
}

// The callback form reads each primitive's bounds exactly once (from several threads) and
// builds the tree the span form builds.
TEST(BvhBuild, CallbackFormReadsEachBoundOnceAndBuildsTheSameTree) {
    const std::vector<Aabb> boxes = random_boxes(40000 / test::kWorkScale, 5);
    for (BvhType t : {BvhType::median, BvhType::sah}) {
        const BvhBuildOptions o = options(t, 8, 2);
        std::vector<std::atomic<int>> calls(boxes.size());
        const Bvh from_calls = build_bvh(boxes.size(), [&](size_t i) {
            calls[i].fetch_add(1, std::memory_order_relaxed);
            return boxes[i];
        }, o);
        for (size_t i = 0; i < calls.size(); ++i) ASSERT_EQ(calls[i].load(), 1) << to_string(t) << ", primitive " << i;
        const Bvh from_span = build_bvh(boxes, o);
        ASSERT_EQ(from_calls.nodes.size(), from_span.nodes.size()) << to_string(t);
        for (size_t i = 0; i < from_span.nodes.size(); ++i) {
            const BvhNode &a = from_calls.nodes[i], &b = from_span.nodes[i];
            ASSERT_TRUE(a.lo == b.lo && a.hi == b.hi && a.offset == b.offset && a.count == b.count) << to_string(t) << ", node " << i;
        }
        EXPECT_EQ(from_calls.prim_index, from_span.prim_index) << to_string(t);
    }
}

TEST(BvhBuild, TypeNamesRoundTrip) {
    for (BvhType t : {BvhType::none, BvhType::midpoint, BvhType::median, BvhType::sah, BvhType::embree}) {
        BvhType parsed = BvhType::none;
        ASSERT_TRUE(parse_bvh_type(to_string(t), parsed)) << to_string(t);
        EXPECT_EQ(parsed, t);
    }
    BvhType kept = BvhType::median;
    EXPECT_FALSE(parse_bvh_type("SAH", kept));
    EXPECT_FALSE(parse_bvh_type("", kept));
    EXPECT_FALSE(parse_bvh_type("kd", kept));
    EXPECT_EQ(kept, BvhType::median) << "a failed parse leaves the value alone";
}

// ---- rays -------------------------------------------------------------------------------------

struct Soup {
    std::vector<TriangleVerts> tris;
    std::vector<Aabb> bounds;
};

// Random triangles of very different sizes in [-1, 1]³, some of them in a dense cluster.
Soup random_soup(int n, uint64_t seed) {
    Pcg32 rng(seed, 9);
    Soup s;
    for (int i = 0; i < n; ++i) {
        const float size = i % 50 == 0 ? 0.8f : (i % 3 == 0 ? 0.02f : 0.12f);
        glm::vec3 c = random_in(rng, -1.f, 1.f);
        if (i % 4 == 0) c = glm::vec3(0.2f, 0.1f, -0.3f) + 0.1f * c;
        const TriangleVerts t{c + size * random_in(rng, -1.f, 1.f), c + size * random_in(rng, -1.f, 1.f),
                              c + size * random_in(rng, -1.f, 1.f)};
        Aabb b;
        b.expand(t.p0); b.expand(t.p1); b.expand(t.p2);
        s.tris.push_back(t);
        s.bounds.push_back(b);
    }
    return s;
}

// Rays from around and inside the soup in all directions; a third with a segment cut short at
// either end, so the traversal's use of tmin and tmax is exercised too.
std::vector<Ray> random_rays(int n, uint64_t seed) {
    Pcg32 rng(seed, 13);
    std::vector<Ray> rays;
    while (int(rays.size()) < n) {
        Ray r;
        r.o = random_in(rng, -1.5f, 1.5f);
        const glm::vec3 d = random_in(rng, -1.f, 1.f);
        const float len2 = glm::dot(d, d);
        if (len2 > 1.f || len2 < 1e-4f) continue;
        r.d = d / std::sqrt(len2);
        const int cut = int(rng.next_u32() % 6);
        if (cut == 0) r.tmax = 0.2f + 2.f * rng.next_float();
        if (cut == 1) r.tmin = 0.5f * rng.next_float();
        rays.push_back(r);
    }
    return rays;
}

struct Answer {
    bool hit = false;
    float t = 0.f;
};

Answer brute_closest(const Soup& s, Ray r) {
    const WatertightRay w = make_watertight_ray(r.d);
    Answer a;
    for (const TriangleVerts& t : s.tris) {
        TriangleHit h;
        if (intersect_triangle_watertight(r, w, t.p0, t.p1, t.p2, h)) {
            r.tmax = h.t;
            a = {true, h.t};
        }
    }
    return a;
}

// Every builder, at several leaf sizes, gives each ray the brute-force answer: the same closest
// distance (the same triangle test on the same triangle, whatever the tree: exact equality),
// and an any-hit answer that agrees with it. A box that excludes a primitive it should hold, or
// a leaf that loses one, shows up as a miss or a farther hit.
TEST(BvhBuild, ClosestAndAnyHitsMatchBruteForceForEveryBuilder) {
    const Soup soup = random_soup(2000, 6);
    const std::vector<Ray> rays = random_rays(3000 / test::kWorkScale, 7);
    std::vector<Answer> expected;
    int hits = 0;
    for (const Ray& r : rays) {
        expected.push_back(brute_closest(soup, r));
        hits += expected.back().hit;
    }
    ASSERT_GT(hits, int(rays.size()) / 5) << "the rays should meet the soup often enough to test something";
    ASSERT_LT(hits, int(rays.size())) << "and miss it sometimes";
    for (BvhType t : kAllBuilders)
        for (int leaf : {1, 4, 8}) {
            if (t == BvhType::none && leaf != 8) continue;
            const Bvh bvh = build_bvh(soup.bounds, options(t, leaf));
            TraversalCounters tc;
            for (size_t i = 0; i < rays.size(); ++i) {
                Ray r = rays[i];
                const WatertightRay w = make_watertight_ray(r.d);
                float found_t = 0.f;
                const bool hit = bvh_closest_hit(bvh, r, [&](uint32_t id, Ray& ray) {
                    TriangleHit h;
                    const TriangleVerts& tv = soup.tris[id];
                    if (!intersect_triangle_watertight(ray, w, tv.p0, tv.p1, tv.p2, h)) return false;
                    ray.tmax = h.t;
                    found_t = h.t;
                    return true;
                }, tc);
                ASSERT_EQ(hit, expected[i].hit) << to_string(t) << ", max leaf " << leaf << ", ray " << i;
                if (hit) {
                    ASSERT_EQ(found_t, expected[i].t) << to_string(t) << ", max leaf " << leaf << ", ray " << i;
                    EXPECT_EQ(r.tmax, expected[i].t);
                }
                const bool any = bvh_any_hit(bvh, rays[i], [&](uint32_t id, const Ray& ray) {
                    TriangleHit h;
                    const TriangleVerts& tv = soup.tris[id];
                    return intersect_triangle_watertight(ray, w, tv.p0, tv.p1, tv.p2, h);
                }, tc);
                ASSERT_EQ(any, expected[i].hit) << to_string(t) << ", max leaf " << leaf << ", ray " << i << " (any hit)";
            }
            EXPECT_GT(tc.nodes_visited, 0u);
        }
}

// ---- hostile extents --------------------------------------------------------------------------

// Centroids closer together than about 1e-37 along any one axis (a mesh uploaded at that scale,
// or a floor with one vertex a hair off its plane: validate() accepts any finite coordinate).
// The SAH bins all three axes, and an axis's bin scale nbins / extent then overflows to +∞; a
// centroid's (c − lo) · scale is 0 · ∞ = NaN or d · ∞ = ∞, and either converts to INT_MIN, which
// must not become a bin index. Midpoint and median splits never bin: they are the control.
TEST(BvhBuild, SahSurvivesCentroidsTooCloseForTheBinScale) {
    std::vector<Aabb> pair_of_clusters;
    for (int i = 0; i < 32; ++i) {
        const float x = (i % 2) ? 5e-38f : 0.f;
        pair_of_clusters.push_back(Aabb{glm::vec3(x, 0.f, 0.f), glm::vec3(x, 1.f, 1.f)});
    }
    std::vector<Aabb> tiny_mesh = random_boxes(2000, 8);
    for (Aabb& b : tiny_mesh) {
        b.lo *= 1e-37f;
        b.hi *= 1e-37f;
    }
    std::vector<Aabb> flat;
    for (int i = 0; i < 64; ++i) {
        const float x = float(i % 8), z = float(i / 8), y = i == 27 ? 5e-38f : 0.f;
        flat.push_back(Aabb{glm::vec3(x, y, z), glm::vec3(x + 1.f, y, z + 1.f)});
    }
    const std::vector<Aabb>* inputs[] = {&pair_of_clusters, &tiny_mesh, &flat};
    for (const std::vector<Aabb>* input : inputs)
        for (BvhType t : {BvhType::midpoint, BvhType::median, BvhType::sah}) {
            const Bvh bvh = build_bvh(*input, options(t, 4));
            const TreeShape shape = check_tree(bvh, *input, to_string(t));
            EXPECT_LT(shape.depth, kMaxBvhDepth) << to_string(t);
        }
}

// Boxes near the end of the float range: 0.5 · (lo + hi) overflows to +∞, the centroid bounds'
// extent is then ∞ and the bin scale 0, and (∞ − lo) · 0 is NaN again. (bvh_build.cpp's choose()
// already expects infinite areas from such bounds and leaves them to the SAH to decide.)
TEST(BvhBuild, SahSurvivesCentroidsThatOverflow) {
    std::vector<Aabb> boxes;
    for (int i = 0; i < 32; ++i) {
        const float x = (i % 2) ? 3e38f : 0.f;
        boxes.push_back(Aabb{glm::vec3(x, 0.f, 0.f), glm::vec3(x, 1.f, 1.f)});
    }
    for (BvhType t : {BvhType::midpoint, BvhType::median, BvhType::sah}) {
        const Bvh bvh = build_bvh(boxes, options(t, 4));
        const TreeShape shape = check_tree(bvh, boxes, to_string(t));
        EXPECT_LT(shape.depth, kMaxBvhDepth) << to_string(t);
    }
}

}  // namespace
}  // namespace tessera
