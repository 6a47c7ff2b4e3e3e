// engine/scene/prototype_cache.h through build_render_scene: a second build of a scene whose
// placements moved reuses each prototype's tree and blocks (the same blocks, so the same image
// bit for bit), a prototype whose triangles changed (a deforming mesh) or whose build options
// changed is built anew, and entries the last build did not use are dropped.
#include "engine/scene/prototype_cache.h"

#include <gtest/gtest.h>

#include <cstring>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/render/renderer.h"
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

}  // namespace
}  // namespace tessera
