#include "engine/accel/bvh.h"

#include <gtest/gtest.h>

#include "engine/io/scene_loader.h"
#include "engine/sampling/rng.h"
#include "engine/scene/procedural.h"
#include "engine/scene/intersect.h"
#include "tests/test_paths.h"
#include "tests/test_scale.h"

namespace tessera {
namespace {

constexpr BvhType kBuilders[] = {BvhType::midpoint, BvhType::median, BvhType::sah};

RenderScene build(const SceneDescription& d, BvhType t, int leaf = BvhBuildOptions{}.max_leaf_size) {
    RenderSceneOptions o;
    o.bvh.type = t;
    o.bvh.max_leaf_size = leaf;
    return build_render_scene(d, o);
}

// Random rays: origins in a box 1.5 × the scene's, directions uniform on the sphere.
std::vector<Ray> random_rays(const Aabb& b, int n, uint64_t seed) {
    Pcg32 rng(seed, 3);
    std::vector<Ray> rays(static_cast<size_t>(n));
    const glm::vec3 c = b.centroid(), e = 0.75f * b.extent();
    for (Ray& r : rays) {
        r.o = c + e * glm::vec3(2 * rng.next_float() - 1, 2 * rng.next_float() - 1, 2 * rng.next_float() - 1);
        glm::vec3 d;
        do d = glm::vec3(2 * rng.next_float() - 1, 2 * rng.next_float() - 1, 2 * rng.next_float() - 1);
        while (glm::dot(d, d) > 1.f || glm::dot(d, d) < 1e-4f);
        r.d = glm::normalize(d);
    }
    return rays;
}

struct Closest { bool hit; float t; glm::vec3 p; };

Closest trace(const RenderScene& s, Ray r) {
    Hit h;
    TraversalCounters tc;
    if (!intersect(s, r, h, tc)) return {false, 0.f, {}};
    return {true, h.t, surface_at(s, r, h).p};
}

// Each builder against brute force (`none`: every primitive tested), and all builders against
// each other on many more rays. The hit distance must be identical: the same triangle test
// runs on the same triangle whatever the tree. (Two triangles at exactly the same distance
// can swap, so the triangle id itself is not compared.)
void check_mesh(const SceneDescription& d, int brute_rays, int builder_rays) {
    const RenderScene brute = build(d, BvhType::none);
    std::vector<RenderScene> scenes;
    for (BvhType t : kBuilders) scenes.push_back(build(d, t));
    const auto rays = random_rays(brute.bounds, builder_rays, 42);
    int hits = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        const Closest ref = i < size_t(brute_rays) ? trace(brute, rays[i]) : trace(scenes[2], rays[i]);
        hits += ref.hit;
        for (size_t k = 0; k < scenes.size(); ++k) {
            const Closest c = trace(scenes[k], rays[i]);
            ASSERT_EQ(c.hit, ref.hit) << to_string(kBuilders[k]) << " ray " << i;
            if (ref.hit) {
                ASSERT_EQ(c.t, ref.t) << to_string(kBuilders[k]) << " ray " << i;
            }
        }
    }
    EXPECT_GT(hits, builder_rays / 20) << "the rays should hit the mesh often enough to test something";
}

TEST(Bvh, BuildersMatchBruteForceOnProceduralMesh) {
    check_mesh(displaced_sphere(20000), 100000 / test::kWorkScale, 1000000 / test::kWorkScale);
}

TEST(Bvh, BuildersMatchBruteForceOnCow) {
    TESSERA_REQUIRE_CS184(dir);
    check_mesh(load_scene(dir + "/meshedit/cow.dae"), 100000 / test::kWorkScale, 1000000 / test::kWorkScale);
}

TEST(Bvh, BuildersMatchBruteForceOnCBbunny) {
    TESSERA_REQUIRE_CS184(dir);
    check_mesh(load_scene(dir + "/sky/CBbunny.dae"), 20000 / test::kWorkScale, 1000000 / test::kWorkScale);
}

std::vector<Aabb> triangle_bounds(const SceneDescription& d) {
    std::vector<Aabb> out;
    for (const MeshDesc& m : d.meshes)
        for (size_t i = 0; i + 2 < m.indices.size(); i += 3) {
            Aabb b;
            for (int k = 0; k < 3; ++k) b.expand(m.positions[m.indices[i + size_t(k)]]);
            out.push_back(b);
        }
    return out;
}

TEST(Bvh, NodesAreFlatAndStatsConsistent) {
    const std::vector<Aabb> bounds = triangle_bounds(displaced_sphere(50000));
    for (BvhType t : kBuilders) {
        BvhBuildOptions o;
        o.type = t;
        const Bvh bvh = build_bvh(bounds, o);
        const BvhBuildStats& st = bvh.stats;
        EXPECT_EQ(st.node_count, bvh.nodes.size());
        EXPECT_EQ(st.leaf_count * 2 - 1, st.node_count) << "a binary tree";
        size_t prims = 0;
        for (const BvhNode& n : bvh.nodes) {
            if (n.is_leaf()) {
                prims += n.count;
                if (t != BvhType::sah) {
                    EXPECT_LE(n.count, uint32_t(o.max_leaf_size));
                }
            }
        }
        EXPECT_EQ(prims, bounds.size()) << "every triangle in exactly one leaf";
        EXPECT_LT(st.depth, kMaxBvhDepth);
        EXPECT_GT(st.sah_cost, 0.0);
    }
}

// The parallel build splices the halves in the sequential order: the same tree, node for
// node, whatever the thread count (the image must not depend on it).
TEST(Bvh, ParallelBuildIsTheSequentialTree) {
    const std::vector<Aabb> bounds = triangle_bounds(displaced_sphere(60000));
    for (BvhType t : kBuilders) {
        BvhBuildOptions o;
        o.type = t;
        o.build_threads = 1;
        const Bvh one = build_bvh(bounds, o);
        for (int threads : {2, 3, 8}) {
            o.build_threads = threads;
            const Bvh many = build_bvh(bounds, o);
            ASSERT_EQ(many.nodes.size(), one.nodes.size()) << to_string(t) << ", " << threads << " threads";
            for (size_t i = 0; i < one.nodes.size(); ++i) {
                const BvhNode &a = one.nodes[i], &b = many.nodes[i];
                ASSERT_TRUE(a.lo == b.lo && a.hi == b.hi && a.offset == b.offset && a.count == b.count)
                    << to_string(t) << ", " << threads << " threads, node " << i;
            }
            EXPECT_EQ(many.prim_index, one.prim_index);
            EXPECT_EQ(many.stats.depth, one.stats.depth);
        }
    }
}

TEST(Bvh, SahIsCheaperThanMidpointAndMedian) {
    const SceneDescription d = displaced_sphere(50000);
    const double sah = build(d, BvhType::sah).tri_bvh_stats.sah_cost;
    EXPECT_LT(sah, build(d, BvhType::midpoint).tri_bvh_stats.sah_cost);
    EXPECT_LT(sah, build(d, BvhType::median).tri_bvh_stats.sah_cost);
}

// Identical centroids cannot be separated by any plane; the builders must still terminate,
// respect the leaf size and keep the depth bounded.
TEST(Bvh, DegenerateInputsTerminate) {
    for (BvhType t : kBuilders) {
        std::vector<Aabb> same(10000, Aabb{glm::vec3(1.f), glm::vec3(2.f)});
        BvhBuildOptions o;
        o.type = t;
        const Bvh b = build_bvh(same, o);
        EXPECT_LT(b.stats.depth, kMaxBvhDepth);
        // Geometric progression of positions: midpoint splits peel one primitive per level.
        std::vector<Aabb> geo;
        for (int i = 0; i < 2000; ++i) {
            const float x = std::ldexp(1.f, -i % 120);
            geo.push_back(Aabb{glm::vec3(x), glm::vec3(x)});
        }
        const Bvh g = build_bvh(geo, o);
        EXPECT_LT(g.stats.depth, kMaxBvhDepth);
    }
}

}  // namespace
}  // namespace tessera
