#include "engine/io/gltf_writer.h"

#include <gtest/gtest.h>

#include "engine/io/gltf_loader.h"
#include "engine/scene/procedural.h"

namespace tessera {
namespace {

// What we write, our loader reads back: geometry, materials (emission through
// KHR_materials_emissive_strength), lights and the camera.
TEST(GltfWriter, RoundTripsThroughTheLoader) {
    const SceneDescription src = cornell_spheres();
    const std::string text = to_gltf(src, 2);
    const SceneDescription back = parse_gltf(text, false, "", "roundtrip.gltf");
    // Two spheres become icospheres of 20·4² faces each.
    EXPECT_EQ(back.triangle_count(), src.triangle_count() + 2 * 320);
    ASSERT_EQ(back.materials.size(), src.materials.size());
    for (size_t i = 0; i < src.materials.size(); ++i) {
        EXPECT_NEAR(back.materials[i].albedo.x, src.materials[i].albedo.x, 1e-6);
        EXPECT_NEAR(back.materials[i].emission.y, src.materials[i].emission.y, 1e-5);
    }
    ASSERT_TRUE(back.camera.has_value());
    EXPECT_NEAR(glm::length(back.camera->position - src.camera->position), 0.f, 1e-5f);
    EXPECT_NEAR(back.camera->vfov_deg, src.camera->vfov_deg, 1e-3f);
    const glm::vec3 dir_src = glm::normalize(src.camera->look_at - src.camera->position);
    const glm::vec3 dir_back = glm::normalize(back.camera->look_at - back.camera->position);
    EXPECT_GT(glm::dot(dir_src, dir_back), 0.99999f);

    const SceneDescription big = displaced_sphere(5000);
    const SceneDescription big_back = parse_gltf(to_gltf(big), false, "", "big.gltf");
    EXPECT_EQ(big_back.triangle_count(), big.triangle_count());
    ASSERT_EQ(big_back.lights.size(), 1u);
    EXPECT_EQ(big_back.lights[0].kind, LightKind::directional);
    EXPECT_NEAR(glm::dot(big_back.lights[0].direction, big.lights[0].direction), 1.f, 1e-5f);
}

}  // namespace
}  // namespace tessera
