// engine/scene/prototype_cache.h through build_render_scene: a second build of a scene whose
// placements moved reuses each prototype's tree and blocks (the same blocks, so the same image
// bit for bit), a prototype whose triangles changed (a deforming mesh) or whose build options
// changed is built anew, and entries the last build did not use are dropped. With world_tree
// refit, the world-space tree of the last build is refitted for the same meshes moved: it
// holds every triangle, rays meet what a fresh build's meet, and at unmoved positions it is the
// fresh build's tree exactly.
#include "engine/scene/prototype_cache.h"

#include <gtest/gtest.h>

#include <cstring>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/render/renderer.h"
#include "engine/sampling/rng.h"
#include "engine/scene/intersect.h"
#include "engine/scene/procedural.h"
#include "engine/scene/render_scene.h"

namespace tessera {
namespace {

bool same_blocks(const RenderScene& a, const RenderScene& b) {
    return a.tri_blocks.size() == b.tri_blocks.size() &&
           std::memcmp(a.tri_blocks.data(), b.tri_blocks.data(), a.tri_blocks.size() * sizeof(Triangle4)) == 0;
}

TEST(PrototypeCache, MovedPlacementsReuseTheirPrototypesTree) {
    SceneDescription d = instanced_field(9, 3000);
    PrototypeCache cache;
    const RenderScene first = build_render_scene(d, {}, &cache);
    EXPECT_EQ(cache.misses, 1u);
    EXPECT_EQ(cache.entries.size(), 1u);
    for (InstanceDesc& in : d.instances) in.to_world = glm::translate(glm::mat4(1.f), glm::vec3(0.3f, 0, 0)) * in.to_world;
    const RenderScene second = build_render_scene(d, {}, &cache);
    EXPECT_EQ(cache.hits, 1u);
    EXPECT_EQ(cache.misses, 1u);
    // What the cache gave is what a build without it makes, bit for bit; so is the image.
    const RenderScene fresh = build_render_scene(d, {});
    EXPECT_TRUE(same_blocks(second, fresh));
    RenderSettings st;
    st.width = 24;
    st.height = 16;
    st.spp = 4;
    st.max_depth = 2;
    EXPECT_EQ(render(second, st).image.rgb, render(fresh, st).image.rgb);
    bool mentioned = false;
    for (const std::string& b : second.report.built) mentioned |= b.find("kept from the previous frame") != std::string::npos;
    EXPECT_TRUE(mentioned);
}

TEST(PrototypeCache, ADeformedPrototypeOrOtherOptionsAreBuiltAnew) {
    SceneDescription d = instanced_field(4, 2000);
    PrototypeCache cache;
    build_render_scene(d, {}, &cache);
    d.prototypes[0].positions[5] += glm::vec3(0.01f, 0, 0);  // one vertex moved: a deforming mesh
    const RenderScene deformed = build_render_scene(d, {}, &cache);
    EXPECT_EQ(cache.hits, 0u);
    EXPECT_EQ(cache.misses, 2u);
    EXPECT_EQ(cache.entries.size(), 1u);  // the old shape's entry is dropped
    EXPECT_TRUE(same_blocks(deformed, build_render_scene(d, {})));
    RenderSceneOptions other;
    other.bvh.max_leaf_size = 4;
    build_render_scene(d, other, &cache);
    EXPECT_EQ(cache.hits, 0u);
    EXPECT_EQ(cache.misses, 3u);
    // A scene without instances leaves the cache empty.
    build_render_scene(cornell_box(), {}, &cache);
    EXPECT_TRUE(cache.entries.empty());
}

// The displaced sphere and a ground, world-space (no instances): `amount` twists the sphere.
SceneDescription twisted(float amount) {
    SceneDescription d = displaced_sphere(20'000);
    for (glm::vec3& p : d.meshes[0].positions) {
        const float a = amount * p.y, c = std::cos(a), s = std::sin(a);
        p = glm::vec3(c * p.x + s * p.z, p.y + 0.2f * amount * std::sin(3.f * p.x), -s * p.x + c * p.z);
    }
    d.meshes[0].normals.clear();
    MeshDesc ground;
    ground.positions = {{-4, -1.3f, -4}, {4, -1.3f, -4}, {4, -1.3f, 4}, {-4, -1.3f, 4}};
    ground.indices = {0, 2, 1, 0, 3, 2};
    d.meshes.push_back(ground);
    return d;
}

TEST(PrototypeCache, ARefittedWorldTreeMeetsWhatAFreshBuildMeets) {
    RenderSceneOptions refit, keep;
    refit.world_tree = RenderSceneOptions::WorldTree::refit;
    refit.refit_max_sah_growth = 1e9;  // however far the mesh moved
    keep.world_tree = RenderSceneOptions::WorldTree::keep;
    PrototypeCache cache;
    build_render_scene(twisted(0.f), refit, &cache);  // nothing kept yet: built, not kept
    EXPECT_FALSE(cache.world.has_value());
    const RenderScene first = build_render_scene(twisted(0.f), keep, &cache);
    EXPECT_EQ(cache.world_builds, 1u);
    // Unmoved: the refit is the build, node for node.
    const RenderScene again = build_render_scene(twisted(0.f), refit, &cache);
    EXPECT_EQ(cache.world_refits, 1u);
    ASSERT_EQ(again.tri_wide.nodes.size(), first.tri_wide.nodes.size());
    EXPECT_EQ(std::memcmp(again.tri_wide.nodes.data(), first.tri_wide.nodes.data(), first.tri_wide.nodes.size() * sizeof(WideNode)), 0);
    EXPECT_TRUE(same_blocks(again, first));
    // Twisted far: the old tree over the new positions.
    const SceneDescription moved = twisted(1.5f);
    const RenderScene refitted = build_render_scene(moved, refit, &cache);
    EXPECT_EQ(cache.world_refits, 2u);
    const RenderScene fresh = build_render_scene(moved, {});
    // Every leaf's box holds its blocks, every inner slot its child's boxes.
    for (const WideNode& n : refitted.tri_wide.nodes)
        for (int c = 0; c < kBvhWidth; ++c) {
            if (!(n.bounds[0][c] <= n.bounds[3][c])) continue;
            auto inside = [&](const glm::vec3& p) {
                for (int a = 0; a < 3; ++a)
                    if (p[a] < n.bounds[a][c] || p[a] > n.bounds[3 + a][c]) return false;
                return true;
            };
            if (n.count[c]) {
                for (uint32_t b = n.child[c]; b < n.child[c] + n.count[c]; ++b)
                    for (int v = 0; v < 3; ++v)
                        for (int l = 0; l < 4; ++l) ASSERT_TRUE(inside(triangle4_vertex(refitted.tri_blocks[b], v, l)));
            } else {
                const WideNode& child = refitted.tri_wide.nodes[n.child[c]];
                for (int k = 0; k < kBvhWidth; ++k)
                    if (child.bounds[0][k] <= child.bounds[3][k]) {
                        ASSERT_TRUE(inside({child.bounds[0][k], child.bounds[1][k], child.bounds[2][k]}));
                        ASSERT_TRUE(inside({child.bounds[3][k], child.bounds[4][k], child.bounds[5][k]}));
                    }
            }
        }
    // Rays from around the scene toward it meet the same triangle at the same distance.
    Pcg32 rng(7, 11);
    TraversalCounters counters;
    int hits = 0;
    for (int i = 0; i < 20'000; ++i) {
        const glm::vec3 o(rng.next_float() * 8 - 4, rng.next_float() * 4 - 1, 4.f);
        const glm::vec3 target(rng.next_float() * 3 - 1.5f, rng.next_float() * 3 - 1.5f, rng.next_float() * 3 - 1.5f);
        Ray a{o, 0.f, glm::normalize(target - o)}, b = a;
        Hit ha, hb;
        const bool ma = intersect(refitted, a, ha, counters), mb = intersect(fresh, b, hb, counters);
        ASSERT_EQ(ma, mb) << i;
        if (!ma) continue;
        ++hits;
        EXPECT_EQ(ha.t, hb.t) << i;
        EXPECT_EQ(ha.prim, hb.prim) << i;
        EXPECT_EQ(occluded(refitted, a, counters), occluded(fresh, b, counters));
    }
    EXPECT_GT(hits, 10'000);
    // Under the default bound a tree that far from its shape is built instead, and says why.
    RenderSceneOptions bounded = refit;
    bounded.refit_max_sah_growth = RenderSceneOptions{}.refit_max_sah_growth;
    const RenderScene built = build_render_scene(moved, bounded, &cache);
    EXPECT_EQ(cache.world_refits, 2u);
    EXPECT_TRUE(same_blocks(built, fresh));
    bool refused = false;
    for (const std::string& b : built.report.built) refused |= b.find("refit refused") != std::string::npos;
    EXPECT_TRUE(refused);
    EXPECT_TRUE(cache.world.has_value());  // still the kept tree, for the next frames
    build_render_scene(twisted(0.f), keep, &cache);
    // Other meshes (another count of triangles) are built anew and not kept; the kept tree
    // stays for the next build (what a frame is built from depends on the kept tree's frame
    // alone). A build that neither keeps nor refits drops it; the default keeps no tree.
    build_render_scene(cornell_box(), refit, &cache);
    EXPECT_EQ(cache.world_builds, 2u);
    EXPECT_EQ(cache.world_refits, 2u);
    EXPECT_TRUE(cache.world.has_value());
    build_render_scene(cornell_box(), {}, &cache);
    EXPECT_FALSE(cache.world.has_value());
    PrototypeCache plain;
    build_render_scene(moved, {}, &plain);
    EXPECT_FALSE(plain.world.has_value());
}

}  // namespace
}  // namespace tessera
