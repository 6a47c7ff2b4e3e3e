// glTF loader: the Khronos samples, small inline files built here (buffers as base64 data URIs),
// and the broken/hostile corpus in tests/corpus/gltf, each of which must raise SceneError.
#include "build_paths.h"
#include "engine/io/gltf_loader.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <numbers>
#include <utility>

#include <unistd.h>

#include "engine/scene/instancing.h"
#include "tests/engine/io/gltf_test_files.h"
#include "tests/test_paths.h"

namespace tessera {
namespace {

namespace fs = std::filesystem;
using namespace test::gltf;

std::pair<glm::vec3, glm::vec3> bounds(const SceneDescription& s) {
    glm::vec3 lo(INFINITY), hi(-INFINITY);
    for (const auto& m : s.meshes)
        for (const auto& p : m.positions) lo = glm::min(lo, p), hi = glm::max(hi, p);
    return {lo, hi};
}

bool has_warning(const SceneDescription& s, const std::string& text) {
    for (const auto& w : s.warnings)
        if (w.find(text) != std::string::npos) return true;
    return false;
}

// --- the Khronos samples ---------------------------------------------------------------------

TEST(GltfSamples, BoxAppliesMatrixHierarchyAndMaterial) {
    TESSERA_REQUIRE_GLTF_SAMPLES(dir);
    const SceneDescription s = load_gltf(dir + "/Box.gltf");
    EXPECT_EQ(s.source, dir + "/Box.gltf");
    ASSERT_EQ(s.meshes.size(), 1u);
    EXPECT_EQ(s.triangle_count(), 12u);
    ASSERT_EQ(s.materials.size(), 1u);
    EXPECT_EQ(s.meshes[0].material, 0);
    expect_near(s.materials[0].albedo, {0.8f, 0.0f, 0.0f});
    EXPECT_EQ(s.materials[0].kind, MaterialKind::metallic_roughness);  // glTF's defaults: a rough metal
    EXPECT_EQ(s.materials[0].metallic, 1.f);
    EXPECT_EQ(s.materials[0].roughness, 1.f);
    EXPECT_EQ(s.meshes[0].origin.pointer, "/meshes/0/primitives/0");
    const auto [lo, hi] = bounds(s);
    expect_near(lo, glm::vec3(-0.5f));
    expect_near(hi, glm::vec3(0.5f));
    // The root matrix turns Y up into Z: the first face's normal (0,0,1) ends up (0,1,0).
    ASSERT_EQ(s.meshes[0].normals.size(), 24u);
    expect_near(s.meshes[0].normals[0], {0, 1, 0});
    EXPECT_FALSE(s.camera.has_value());
    EXPECT_TRUE(has_warning(s, "no lights or emissive materials"));
}

TEST(GltfSamples, TriangleWithoutIndices) {
    TESSERA_REQUIRE_GLTF_SAMPLES(dir);
    const SceneDescription s = load_gltf(dir + "/TriangleWithoutIndices.gltf");
    ASSERT_EQ(s.meshes.size(), 1u);
    EXPECT_EQ(s.triangle_count(), 1u);
    EXPECT_EQ(s.meshes[0].indices, (std::vector<uint32_t>{0, 1, 2}));
    EXPECT_EQ(s.meshes[0].material, -1);
    EXPECT_TRUE(s.meshes[0].normals.empty());
    EXPECT_TRUE(s.meshes[0].flat_normals);  // glTF's rule for meshes without NORMAL
}

TEST(GltfSamples, SimpleMeshesInstancesOneMeshTwice) {
    TESSERA_REQUIRE_GLTF_SAMPLES(dir);
    const SceneDescription stored = load_gltf(dir + "/SimpleMeshes.gltf");
    ASSERT_EQ(stored.prototypes.size(), 1u);  // one mesh, stored once and placed twice
    ASSERT_EQ(stored.instances.size(), 2u);
    EXPECT_EQ(stored.triangle_count(), 1u);
    SceneDescription s = stored;
    flatten_instances(s);
    ASSERT_EQ(s.meshes.size(), 2u);
    EXPECT_EQ(s.placed_triangle_count(), 2u);
    expect_near(s.meshes[0].positions[1], {1, 0, 0});
    expect_near(s.meshes[1].positions[1], {2, 0, 0});  // second node translates by +x
    ASSERT_EQ(s.meshes[1].normals.size(), 3u);
    expect_near(s.meshes[1].normals[2], {0, 0, 1});
}

TEST(GltfSamples, CamerasTakesPerspectiveAndWarnsAboutOrthographic) {
    TESSERA_REQUIRE_GLTF_SAMPLES(dir);
    const SceneDescription s = load_gltf(dir + "/Cameras.gltf");
    ASSERT_TRUE(s.camera.has_value());
    const CameraDesc& c = *s.camera;
    expect_near(c.position, {0.5f, 0.5f, 3.0f});
    expect_near(c.look_at, {0.5f, 0.5f, 2.0f});
    expect_near(c.up, {0, 1, 0});
    EXPECT_NEAR(c.vfov_deg, 0.7 * 180 / std::numbers::pi, 1e-4);
    EXPECT_NEAR(c.hfov_deg, c.vfov_deg, 1e-4);  // aspectRatio 1
    EXPECT_NEAR(c.znear, 0.01f, 1e-7);
    EXPECT_NEAR(c.zfar, 100.0f, 1e-4);
    EXPECT_EQ(c.focal_px, 0.0f);
    EXPECT_EQ(c.origin.pointer, "/nodes/1");
    EXPECT_TRUE(has_warning(s, "orthographic camera 1 (/nodes/2) is not supported"));
    // The mesh node turns -45 degrees about x: (0,1,0) goes to (0, cos 45, -sin 45).
    ASSERT_EQ(s.meshes.size(), 1u);
    expect_near(s.meshes[0].positions[2], {0, 0.7071f, -0.7071f}, 1e-3f);
}

// --- transforms ------------------------------------------------------------------------------

TEST(GltfTransforms, TrsIsTranslateRotateScale) {
    // S scales x by 2, R turns 90 degrees about z, T moves by (1,2,3): (1,0,0) -> (2,0,0) -> (0,2,0) -> (1,4,3).
    const SceneDescription s = parse(triangle_file(
        R"([{"mesh":0,"translation":[1,2,3],"rotation":[0,0,0.70710678,0.70710678],"scale":[2,1,1]}])"));
    ASSERT_EQ(s.meshes.size(), 1u);
    expect_near(s.meshes[0].positions[0], {1, 2, 3});
    expect_near(s.meshes[0].positions[1], {1, 4, 3});
    expect_near(s.meshes[0].positions[2], {0, 2, 3});
}

TEST(GltfTransforms, MatrixIsColumnMajorAndParentsMultiplyFromTheLeft) {
    // Parent: scale 2 then move by (10,0,0); child: move by (1,0,0). (0,0,0) -> (1,0,0) -> (12,0,0).
    const SceneDescription s = parse(triangle_file(
        R"([{"children":[1],"matrix":[2,0,0,0, 0,2,0,0, 0,0,2,0, 10,0,0,1]},{"mesh":0,"translation":[1,0,0]}])"));
    ASSERT_EQ(s.meshes.size(), 1u);
    expect_near(s.meshes[0].positions[0], {12, 0, 0});
    expect_near(s.meshes[0].positions[2], {12, 2, 0});
}

TEST(GltfTransforms, MirroringKeepsFrontFacesFront) {
    const SceneDescription s = parse(triangle_file(R"([{"mesh":0,"scale":[-1,1,1]}])"));
    EXPECT_EQ(s.meshes[0].indices, (std::vector<uint32_t>{0, 2, 1}));
}

TEST(GltfTransforms, NormalsUseTheInverseTranspose) {
    Blob b;
    const size_t pos = b.add<float>({0, 0, 0, 1, 0, 0, 0, 1, 0});
    const size_t nrm = b.add<float>({0.70710678f, 0.70710678f, 0, 0, 0, 1, 0, 0, 1});
    const std::string file = replace_all(R"({"asset":{"version":"2.0"},"nodes":[{"mesh":0,"scale":[2,1,1]}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0,"NORMAL":1}}]}],
        "buffers":[{"byteLength":$LEN,"uri":"$URI"}],
        "bufferViews":[{"buffer":0,"byteOffset":$POS,"byteLength":36},{"buffer":0,"byteOffset":$NRM,"byteLength":36}],
        "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"},
                     {"bufferView":1,"componentType":5126,"count":3,"type":"VEC3"}]})",
                                         {{"$LEN", std::to_string(b.bytes.size())}, {"$URI", b.uri()},
                                          {"$POS", std::to_string(pos)}, {"$NRM", std::to_string(nrm)}});
    const SceneDescription s = parse(file);
    ASSERT_EQ(s.meshes[0].normals.size(), 3u);
    expect_near(s.meshes[0].normals[0], glm::normalize(glm::vec3(0.5f, 1.0f, 0.0f)));
    expect_near(s.meshes[0].normals[1], {0, 0, 1});
}

TEST(GltfTransforms, NodeDepthLimit) {
    std::string nodes = "[";
    for (int i = 0; i < 10; ++i) nodes += R"({"children":[)" + std::to_string(i + 1) + "]},";
    nodes += R"({"mesh":0}])";
    LoadLimits limits;
    EXPECT_EQ(parse(triangle_file(nodes), limits).meshes.size(), 1u);
    limits.max_node_depth = 5;
    const SceneError e = error_of([&] { parse(triangle_file(nodes), limits); });
    EXPECT_NE(std::string(e.what()).find("deeper than 5"), std::string::npos) << e.what();
}

// --- instances -------------------------------------------------------------------------------

TEST(GltfInstances, AMeshTwoNodesPlaceIsStoredOnce) {
    const SceneDescription s = parse(triangle_file(R"([{"children":[1,2]},{"mesh":0,"translation":[5,0,0]},
        {"mesh":0,"scale":[-1,1,1]}])", "", R"([{"nodes":[0]}])"));
    EXPECT_TRUE(s.meshes.empty());
    ASSERT_EQ(s.prototypes.size(), 1u);
    ASSERT_EQ(s.instances.size(), 2u);
    EXPECT_EQ(s.triangle_count(), 1u);
    EXPECT_EQ(s.placed_triangle_count(), 2u);
    expect_near(s.prototypes[0].positions[1], {1, 0, 0});  // in the mesh's own space
    expect_near(glm::vec3(s.instances[0].to_world[3]), {5, 0, 0});
    EXPECT_EQ(s.instances[1].to_world[0][0], -1.f);
    EXPECT_EQ(s.instances[0].origin.pointer, "/nodes/1");
    // The instance limit counts placements.
    LoadLimits limits;
    limits.max_instances = 1;
    const SceneError e = error_of([&] {
        parse(triangle_file(R"([{"mesh":0},{"mesh":0,"translation":[5,0,0]}])", "", R"([{"nodes":[0,1]}])"), limits);
    });
    EXPECT_NE(std::string(e.what()).find("instance limit"), std::string::npos) << e.what();
}

TEST(GltfInstances, ASingularNodeIsDrawnFlatAndAMeshUsedOnceIsNotInstanced) {
    // glTF hides a node by scaling it to zero: no inverse, so it is not an instance.
    const SceneDescription hidden = parse(triangle_file(R"([{"mesh":0},{"mesh":0,"scale":[0,0,0]}])", "", R"([{"nodes":[0,1]}])"));
    EXPECT_EQ(hidden.instances.size(), 1u);
    EXPECT_EQ(hidden.meshes.size(), 1u);
    const SceneDescription once = parse(triangle_file(R"([{"mesh":0}])"));
    EXPECT_TRUE(once.instances.empty());
    EXPECT_EQ(once.meshes.size(), 1u);
}

// --- geometry --------------------------------------------------------------------------------

// A unit quad (two triangles) indexed with the given component type.
std::string quad_file(int component_type, const std::string& index_bytes, const std::string& mode = "") {
    Blob b;
    b.add<float>({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0});
    b.bytes += index_bytes;
    const size_t size = component_type == 5121 ? 1 : component_type == 5123 ? 2 : 4;
    return replace_all(R"({"asset":{"version":"2.0"},"nodes":[{"mesh":0}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1$MODE}]}],
        "buffers":[{"byteLength":$LEN,"uri":"$URI"}],
        "bufferViews":[{"buffer":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":$ILEN}],
        "accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3"},
                     {"bufferView":1,"componentType":$CT,"count":$COUNT,"type":"SCALAR"}]})",
                       {{"$MODE", mode}, {"$LEN", std::to_string(b.bytes.size())}, {"$URI", b.uri()},
                        {"$ILEN", std::to_string(index_bytes.size())}, {"$CT", std::to_string(component_type)},
                        {"$COUNT", std::to_string(index_bytes.size() / size)}});
}

template <class T>
std::string bytes_of(std::initializer_list<T> v) {
    return std::string(reinterpret_cast<const char*>(std::data(v)), v.size() * sizeof(T));
}

TEST(GltfGeometry, IndexComponentTypes) {
    const std::vector<uint32_t> want{0, 1, 2, 0, 2, 3};
    EXPECT_EQ(parse(quad_file(5121, bytes_of<uint8_t>({0, 1, 2, 0, 2, 3}))).meshes[0].indices, want);
    EXPECT_EQ(parse(quad_file(5123, bytes_of<uint16_t>({0, 1, 2, 0, 2, 3}))).meshes[0].indices, want);
    EXPECT_EQ(parse(quad_file(5125, bytes_of<uint32_t>({0, 1, 2, 0, 2, 3}))).meshes[0].indices, want);
    // Signed or float indices are not allowed.
    const SceneError e = error_of([] { parse(quad_file(5122, bytes_of<int16_t>({0, 1, 2, 0, 2, 3}))); });
    EXPECT_EQ(e.where().pointer, "/accessors/1");
}

TEST(GltfGeometry, IndexOutOfRangeNamesThePrimitive) {
    const SceneError e = error_of([] { parse(quad_file(5123, bytes_of<uint16_t>({0, 1, 2, 0, 2, 4}))); });
    EXPECT_EQ(e.where().pointer, "/meshes/0/primitives/0/indices");
    EXPECT_EQ(e.where().file, "inline.gltf");
    EXPECT_NE(std::string(e.what()).find("index 5 = 4 is out of range (4 vertices)"), std::string::npos) << e.what();
}

TEST(GltfGeometry, TriangleStripAndFan) {
    const SceneDescription strip = parse(quad_file(5123, bytes_of<uint16_t>({0, 1, 3, 2}), R"(,"mode":5)"));
    EXPECT_EQ(strip.meshes[0].indices, (std::vector<uint32_t>{0, 1, 3, 1, 2, 3}));
    const SceneDescription fan = parse(quad_file(5123, bytes_of<uint16_t>({0, 1, 2, 3}), R"(,"mode":6)"));
    EXPECT_EQ(fan.meshes[0].indices, (std::vector<uint32_t>{1, 2, 0, 2, 3, 0}));
    const SceneDescription short_strip = parse(quad_file(5123, bytes_of<uint16_t>({0, 1}), R"(,"mode":5)"));
    EXPECT_EQ(short_strip.triangle_count(), 0u);
}

TEST(GltfGeometry, PointsAndLinesAreSkippedWithOneWarning) {
    const SceneDescription s = parse(quad_file(5123, bytes_of<uint16_t>({0, 1, 2, 3}), R"(,"mode":1)"));
    EXPECT_TRUE(s.meshes.empty());
    EXPECT_TRUE(has_warning(s, "1 point/line primitive(s) skipped"));
}

TEST(GltfGeometry, InterleavedByteStride) {
    Blob b;  // position, normal, position, normal, ...
    b.add<float>({0, 0, 0, 0, 0, 1, 1, 0, 0, 0, 0, 1, 0, 1, 0, 0, 0, 1});
    const std::string file = replace_all(R"({"asset":{"version":"2.0"},"nodes":[{"mesh":0}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0,"NORMAL":1}}]}],
        "buffers":[{"byteLength":72,"uri":"$URI"}],
        "bufferViews":[{"buffer":0,"byteLength":72,"byteStride":24}],
        "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"},
                     {"bufferView":0,"byteOffset":12,"componentType":5126,"count":3,"type":"VEC3"}]})",
                                         {{"$URI", b.uri()}});
    const SceneDescription s = parse(file);
    ASSERT_EQ(s.meshes.size(), 1u);
    expect_near(s.meshes[0].positions[1], {1, 0, 0});
    expect_near(s.meshes[0].positions[2], {0, 1, 0});
    ASSERT_EQ(s.meshes[0].normals.size(), 3u);
    expect_near(s.meshes[0].normals[2], {0, 0, 1});
}

TEST(GltfGeometry, NanPositionNamesTheAccessor) {
    Blob b;
    b.add<float>({0, 0, 0, 1, 0, NAN, 0, 1, 0});
    std::string file = triangle_file(R"([{"mesh":0}])");
    file = replace_all(file, {{triangle_blob().uri(), b.uri()}});
    const SceneError e = error_of([&] { parse(file); });
    EXPECT_EQ(e.where().pointer, "/accessors/0");
}

TEST(GltfGeometry, LimitsAreCheckedBeforeAllocating) {
    LoadLimits limits;
    limits.max_triangles = 1;
    const SceneError e = error_of([&] { parse(quad_file(5123, bytes_of<uint16_t>({0, 1, 2, 0, 2, 3})), limits); });
    EXPECT_EQ(e.where().pointer, "/accessors/1");
    limits = {};
    limits.max_vertices = 3;
    error_of([&] { parse(quad_file(5123, bytes_of<uint16_t>({0, 1, 2, 0, 2, 3})), limits); });
    // A mesh placed twice is stored once: the triangle limit (memory) counts it once, the
    // instance limit counts its placements.
    limits = {};
    limits.max_triangles = 1;
    const SceneDescription twice = parse(triangle_file(R"([{"mesh":0},{"mesh":0}])", "", R"([{"nodes":[0,1]}])"), limits);
    EXPECT_EQ(twice.triangle_count(), 1u);
    EXPECT_EQ(twice.placed_triangle_count(), 2u);
    limits.max_instances = 1;
    error_of([&] { parse(triangle_file(R"([{"mesh":0},{"mesh":0}])", "", R"([{"nodes":[0,1]}])"), limits); });
}

// --- materials, lights, camera -----------------------------------------------------------------

TEST(GltfMaterials, FactorsEmissiveStrengthAndDoubleSided) {
    const SceneDescription s = parse(triangle_file(R"([{"mesh":0}])",
                                                   R"("materials":[{"name":"lamp","doubleSided":true,
            "pbrMetallicRoughness":{"baseColorFactor":[0.2,0.4,0.6,1]},"emissiveFactor":[1,0.5,0],
            "extensions":{"KHR_materials_emissive_strength":{"emissiveStrength":4}}},{"name":"plain"}],
            "extensionsUsed":["KHR_materials_emissive_strength"])",
                                                   R"([{"nodes":[0]}])", R"(,"material":0)"));
    ASSERT_EQ(s.materials.size(), 2u);
    const MaterialDesc& lamp = s.materials[0];
    EXPECT_EQ(lamp.name, "lamp");
    EXPECT_EQ(lamp.kind, MaterialKind::metallic_roughness);
    EXPECT_TRUE(lamp.emits());
    expect_near(lamp.emission, {4, 2, 0});
    expect_near(lamp.albedo, {0.2f, 0.4f, 0.6f});
    EXPECT_TRUE(lamp.double_sided);
    EXPECT_EQ(lamp.origin.pointer, "/materials/0");
    EXPECT_EQ(s.materials[1].kind, MaterialKind::metallic_roughness);
    expect_near(s.materials[1].albedo, {1, 1, 1});  // glTF's defaults: white, metallic 1, roughness 1
    EXPECT_EQ(s.materials[1].metallic, 1.f);
    EXPECT_EQ(s.materials[1].roughness, 1.f);
    EXPECT_FALSE(s.materials[1].double_sided);
    EXPECT_EQ(s.meshes[0].material, 0);
    EXPECT_FALSE(has_warning(s, "no lights"));  // the emitter lights the scene
    EXPECT_FALSE(has_warning(s, "extensions used by the file are ignored"));
}

// Metallic and roughness factors, KHR_materials_ior and KHR_materials_specular are read; a base
// with neither metal nor specular layer is Lambertian (what our own scenes write).
TEST(GltfMaterials, MetallicRoughnessIorAndSpecular) {
    const SceneDescription s = parse(triangle_file(R"([{"mesh":0}])",
                                                   R"("materials":[
            {"name":"gold","pbrMetallicRoughness":{"baseColorFactor":[1,0.8,0.3,1],"metallicFactor":1,"roughnessFactor":0.3}},
            {"name":"plastic","pbrMetallicRoughness":{"metallicFactor":0,"roughnessFactor":0.5},
             "extensions":{"KHR_materials_ior":{"ior":1.7},"KHR_materials_specular":{"specularFactor":0.5}}},
            {"name":"matte","pbrMetallicRoughness":{"metallicFactor":0},"extensions":{"KHR_materials_specular":{"specularFactor":0}}}],
            "extensionsUsed":["KHR_materials_ior","KHR_materials_specular"])",
                                                   R"([{"nodes":[0]}])", R"(,"material":0)"));
    ASSERT_EQ(s.materials.size(), 3u);
    EXPECT_EQ(s.materials[0].kind, MaterialKind::metallic_roughness);
    EXPECT_EQ(s.materials[0].metallic, 1.f);
    EXPECT_FLOAT_EQ(s.materials[0].roughness, 0.3f);
    EXPECT_EQ(s.materials[1].kind, MaterialKind::metallic_roughness);
    EXPECT_FLOAT_EQ(s.materials[1].ior, 1.7f);
    EXPECT_FLOAT_EQ(s.materials[1].specular, 0.5f);
    EXPECT_EQ(s.materials[2].kind, MaterialKind::diffuse);
    EXPECT_FALSE(has_warning(s, "extensions used by the file are ignored"));
    const SceneError e = error_of([&] {
        parse(triangle_file(R"([{"mesh":0}])", R"("materials":[{"pbrMetallicRoughness":{"metallicFactor":1.5}}])",
                            R"([{"nodes":[0]}])", R"(,"material":0)"));
    });
    EXPECT_EQ(e.where().pointer, "/materials/0/pbrMetallicRoughness/metallicFactor");
    const SceneError e2 = error_of([&] {
        parse(triangle_file(R"([{"mesh":0}])", R"("materials":[{"extensions":{"KHR_materials_ior":{"ior":-1}}}])",
                            R"([{"nodes":[0]}])", R"(,"material":0)"));
    });
    EXPECT_EQ(e2.where().pointer, "/materials/0/extensions/KHR_materials_ior/ior");
}

TEST(GltfMaterials, ABrokenImageIsAnErrorOnlyWhereAMaterialUsesIt) {
    const std::string images = R"("images":[{"uri":"data:image/png;base64,AAAA"},{"uri":"data:image/png;base64,iVBORw0KGgoAAAA"}])";
    const SceneError e = error_of([&] {
        parse(triangle_file(R"([{"mesh":0}])",
                            R"("materials":[{"name":"wood","pbrMetallicRoughness":{"baseColorTexture":{"index":0}}}],
                               "textures":[{"source":1}],)" + images,
                            R"([{"nodes":[0]}])", R"(,"material":0)"));
    });
    EXPECT_EQ(e.where().pointer, "/images/1");
    EXPECT_NE(std::string(e.what()).find("cannot be used as a texture"), std::string::npos) << e.what();
    // Unused, the same images do not matter.
    const SceneDescription s = parse(triangle_file(R"([{"mesh":0}])", images.substr(0)));
    EXPECT_TRUE(s.images.empty());
}

TEST(GltfLights, PointDirectionalAndSpot) {
    const SceneDescription s = parse(triangle_file(
        R"([{"mesh":0},
            {"translation":[1,2,3],"extensions":{"KHR_lights_punctual":{"light":0}}},
            {"rotation":[-0.70710678,0,0,0.70710678],"extensions":{"KHR_lights_punctual":{"light":1}}},
            {"translation":[0,5,0],"extensions":{"KHR_lights_punctual":{"light":2}}}])",
        R"("extensionsUsed":["KHR_lights_punctual"],"extensions":{"KHR_lights_punctual":{"lights":[
            {"type":"point","color":[1,0.5,0.25],"intensity":10},
            {"type":"directional","intensity":3},
            {"type":"spot","spot":{"outerConeAngle":0.5}}]}})",
        R"([{"nodes":[0,1,2,3]}])"));
    ASSERT_EQ(s.lights.size(), 3u);
    EXPECT_EQ(s.lights[0].kind, LightKind::point);
    expect_near(s.lights[0].position, {1, 2, 3});
    expect_near(s.lights[0].radiance, {10, 5, 2.5f});
    EXPECT_EQ(s.lights[0].origin.pointer, "/nodes/1");
    EXPECT_EQ(s.lights[1].kind, LightKind::directional);
    expect_near(s.lights[1].direction, {0, -1, 0});  // -z turned -90 degrees about x points down
    expect_near(s.lights[1].radiance, {3, 3, 3});
    EXPECT_EQ(s.lights[2].kind, LightKind::spot);
    expect_near(s.lights[2].position, {0, 5, 0});
    expect_near(s.lights[2].direction, {0, 0, -1});
    EXPECT_TRUE(has_warning(s, "spot lights are rendered as point lights"));
    EXPECT_FALSE(has_warning(s, "no lights"));
}

TEST(GltfCamera, DefaultsWithoutAspectRatioAndZfar) {
    const SceneDescription s = parse(triangle_file(R"([{"mesh":0},{"camera":0,"translation":[0,0,5]},{"camera":0}])",
                                                   R"("cameras":[{"type":"perspective","perspective":{"yfov":1.0,"znear":0.1}}])",
                                                   R"([{"nodes":[0,1,2]}])"));
    ASSERT_TRUE(s.camera.has_value());
    expect_near(s.camera->position, {0, 0, 5});
    EXPECT_NEAR(s.camera->vfov_deg, 1.0 * 180 / std::numbers::pi, 1e-4);
    EXPECT_NEAR(s.camera->hfov_deg, 2 * std::atan(std::tan(0.5) * 4.0 / 3.0) * 180 / std::numbers::pi, 1e-3);
    EXPECT_EQ(s.camera->focal_px, 0.0f);
    EXPECT_EQ(s.camera->zfar, 1000.0f);
    EXPECT_TRUE(has_warning(s, "2 perspective cameras; the first is used"));
}

// --- scenes and extensions ---------------------------------------------------------------------

TEST(GltfScenes, DefaultSceneFallbacks) {
    const std::string nodes = R"([{"mesh":0},{"mesh":0,"translation":[5,0,0]}])";
    auto parse = [](const std::string& file) {
        SceneDescription s = test::gltf::parse(file);
        flatten_instances(s);  // the mesh is placed by two nodes
        return s;
    };
    // "scene" picks the scene; without it scene 0; without scenes every root node.
    EXPECT_EQ(parse(triangle_file(nodes, R"("scene":1)", R"([{"nodes":[0]},{"nodes":[1]}])")).meshes[0].positions[0].x, 5);
    EXPECT_EQ(parse(triangle_file(nodes, "", R"([{"nodes":[1]},{"nodes":[0]}])")).meshes[0].positions[0].x, 5);
    std::string no_scenes = triangle_file(R"([{"mesh":0,"children":[2]},{"mesh":0},{"mesh":0}])");
    no_scenes = replace_all(no_scenes, {{R"("scenes":[{"nodes":[0]}],)", ""}});
    EXPECT_EQ(parse(no_scenes).meshes.size(), 3u);  // roots 0 and 1, node 2 under 0
}

TEST(GltfScenes, ExtensionsRequiredAndUsed) {
    const SceneError e = error_of([] {
        parse(triangle_file(R"([{"mesh":0}])", R"("extensionsRequired":["KHR_mesh_quantization"])"));
    });
    EXPECT_EQ(e.where().pointer, "/extensionsRequired/0");
    EXPECT_NE(std::string(e.what()).find("KHR_mesh_quantization"), std::string::npos);
    const SceneDescription s = parse(triangle_file(R"([{"mesh":0}])",
                                                   R"("extensionsUsed":["KHR_materials_clearcoat","KHR_lights_punctual"],
                                                      "extensionsRequired":["KHR_lights_punctual"])"));
    EXPECT_TRUE(has_warning(s, "ignored: KHR_materials_clearcoat"));
}

// At rest a skin whose joints sit at the origin and a morph target at its default weight (0)
// leave the bind shape as it is (the animated cases are in gltf_animation_test.cpp).
TEST(GltfScenes, SkinsAndMorphTargetsAtRestKeepTheBindShape) {
    const SceneDescription s = parse(triangle_file(R"([{"mesh":0,"skin":0},{}])", R"("skins":[{"joints":[1]}],"animations":[])",
                                                   R"([{"nodes":[0,1]}])", R"(,"targets":[{"POSITION":0}])"));
    ASSERT_EQ(s.meshes.size(), 1u);
    expect_near(s.meshes[0].positions[1], {1, 0, 0});
    expect_near(s.meshes[0].positions[2], {0, 1, 0});
    EXPECT_FALSE(has_warning(s, "not supported"));
    EXPECT_TRUE(s.animations.empty());
}

TEST(GltfBinary, GlbFromMemory) {
    const std::string json = R"({"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"buffers":[{"byteLength":36}],
        "bufferViews":[{"buffer":0,"byteLength":36}],
        "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}]})";
    const std::string data = glb(json, triangle_blob().bytes);
    const SceneDescription s = parse_gltf(data, true, "", "mem.glb");
    ASSERT_EQ(s.meshes.size(), 1u);
    expect_near(s.meshes[0].positions[1], {1, 0, 0});
    // Text data handed over as binary and the reverse are refused cleanly.
    error_of([&] { parse_gltf(json, true, "", "x.glb"); });
    error_of([&] { parse_gltf(data, false, "", "x.gltf"); });
}

// Every prefix and many single-byte corruptions of a valid GLB and .gltf end in a scene or a
// SceneError, never in a crash or another exception (run under ASan/UBSan in CI).
TEST(GltfBinary, TruncationsAndCorruptionsOnlyRaiseSceneError) {
    const std::string json = R"({"asset":{"version":"2.0"},"nodes":[{"mesh":0}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],"buffers":[{"byteLength":44}],
        "bufferViews":[{"buffer":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":6}],
        "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"},
                     {"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}]})";
    std::string bin = triangle_blob().bytes + bytes_of<uint16_t>({0, 1, 2, 0});
    const std::string inputs[] = {glb(json, bin), triangle_file(R"([{"mesh":0}])")};
    for (const std::string& good : inputs) {
        const bool binary = good.starts_with("glTF");
        auto attempt = [&](const std::string& bytes) {
            try {
                parse_gltf(bytes, binary, "", "fuzz");
            } catch (const SceneError&) {
            } catch (const std::exception& e) {
                ADD_FAILURE() << "unexpected exception: " << e.what();
            }
        };
        for (size_t n = 0; n < good.size(); n += binary ? 1 : 7) attempt(good.substr(0, n));
        for (size_t i = 0; i < good.size(); i += binary ? 1 : 3)
            for (int v : {0x00, 0xff, 0x7f, 0x80, int('9'), int('"'), int('-')}) {
                std::string bad = good;
                bad[i] = static_cast<char>(v);
                attempt(bad);
            }
    }
}

// --- external files --------------------------------------------------------------------------

struct TempDir {
    fs::path path;
    TempDir() {
        path = fs::temp_directory_path() / ("tessera_gltf_" + std::to_string(::getpid()) + "_" +
                                            ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(path);
        fs::create_directories(path / "scene" / "bin");
    }
    ~TempDir() { fs::remove_all(path); }
    void write(const fs::path& rel, const std::string& bytes) const {
        std::ofstream(path / rel, std::ios::binary) << bytes;
    }
};

std::string external_file(const std::string& uri) {
    return replace_all(triangle_file(R"([{"mesh":0}])"), {{triangle_blob().uri(), uri}});
}

TEST(GltfExternal, BuffersInsideTheFolderLoad) {
    TempDir t;
    t.write("scene/bin/tri.bin", triangle_blob().bytes);
    t.write("scene/a.gltf", external_file("bin/tri.bin"));
    t.write("scene/b.gltf", external_file("bin/../bin/tri%2Ebin"));  // URL-encoded, still inside
    EXPECT_EQ(load_gltf((t.path / "scene/a.gltf").string()).triangle_count(), 1u);
    EXPECT_EQ(load_gltf((t.path / "scene/b.gltf").string()).triangle_count(), 1u);
    // The same from memory with the folder as base_dir, and refused with no base_dir.
    EXPECT_EQ(parse_gltf(external_file("bin/tri.bin"), false, (t.path / "scene").string(), "m").triangle_count(), 1u);
    const SceneError e = error_of([] { parse_gltf(external_file("bin/tri.bin"), false, "", "upload.gltf"); });
    EXPECT_NE(std::string(e.what()).find("may not reference external files"), std::string::npos) << e.what();
}

TEST(GltfExternal, EscapesAreRefused) {
    TempDir t;
    t.write("secret.bin", triangle_blob().bytes);  // exists, right size, but outside the folder
    t.write("scene/up.gltf", external_file("../secret.bin"));
    t.write("scene/abs.gltf", external_file((t.path / "secret.bin").string()));
    fs::create_symlink(t.path / "secret.bin", t.path / "scene" / "link.bin");
    t.write("scene/link.gltf", external_file("link.bin"));
    for (const char* name : {"up.gltf", "abs.gltf", "link.gltf"}) {
        const SceneError e = error_of([&] { load_gltf((t.path / "scene" / name).string()); });
        EXPECT_NE(std::string(e.what()).find("refused"), std::string::npos) << name << ": " << e.what();
        // Under a name (a catalog's), whose folder tinygltf is handed instead of the real one.
        for (const std::string& shown : {std::string(name), std::string("/").append(name), std::string("sub/").append(name)}) {
            const SceneError named = error_of([&] { load_gltf((t.path / "scene" / name).string(), {}, shown); });
            EXPECT_NE(std::string(named.what()).find("refused"), std::string::npos) << shown << ": " << named.what();
        }
    }
}

// A file loaded under a name (a server's catalog name for it) is named so in every message,
// tinygltf's own about the files beside it too ("File size mismatch : <path>"): never by the
// folder it was read from.
TEST(GltfExternal, MessagesNameTheFilesBesideItByTheFilesName) {
    TempDir t;
    t.write("scene/bin/short.bin", triangle_blob().bytes.substr(0, 10));  // shorter than its byteLength
    t.write("scene/bin/empty.bin", "");
    t.write("scene/short.gltf", external_file("bin/short.bin"));
    t.write("scene/empty.gltf", external_file("bin/empty.bin"));
    for (const char* name : {"short", "empty"}) {
        const std::string path = (t.path / "scene" / (std::string(name) + ".gltf")).string();
        const SceneError e = error_of([&] { load_gltf(path, {}, std::string("sub/") + name + ".gltf"); });
        const std::string what = e.what();
        EXPECT_EQ(what.find(t.path.string()), std::string::npos) << what;
        EXPECT_NE(what.find(std::string("sub/bin/") + name + ".bin"), std::string::npos) << what;
        EXPECT_EQ(what.rfind(std::string("sub/") + name + ".gltf", 0), 0u) << what;
        // At the catalog's top, the file's folder is "./".
        const SceneError top = error_of([&] { load_gltf(path, {}, std::string(name) + ".gltf"); });
        EXPECT_EQ(std::string(top.what()).find(t.path.string()), std::string::npos) << top.what();
        EXPECT_NE(std::string(top.what()).find(std::string("./bin/") + name + ".bin"), std::string::npos) << top.what();
    }
    // Loaded without a name, the path is the name.
    const SceneError plain = error_of([&] { load_gltf((t.path / "scene" / "short.gltf").string()); });
    EXPECT_NE(std::string(plain.what()).find((t.path / "scene" / "bin" / "short.bin").string()), std::string::npos) << plain.what();
}

TEST(GltfExternal, FileSizeLimit) {
    TempDir t;
    t.write("scene/bin/tri.bin", triangle_blob().bytes);
    t.write("scene/a.gltf", external_file("bin/tri.bin"));
    LoadLimits limits;
    limits.max_file_bytes = 20;
    error_of([&] { load_gltf((t.path / "scene/a.gltf").string(), limits); });  // the .gltf itself
    t.write("scene/big.bin", std::string(4096, '\0'));
    const std::string text = external_file("big.bin");
    limits.max_file_bytes = text.size();
    const SceneError e = error_of([&] { parse_gltf(text, false, (t.path / "scene").string(), "m", limits); });
    EXPECT_NE(std::string(e.what()).find("above the limit"), std::string::npos) << e.what();
    error_of([] { load_gltf("/nonexistent/x.gltf"); });
}

// --- the broken corpus -----------------------------------------------------------------------

TEST(GltfCorpus, EveryBrokenFileRaisesSceneErrorNamingTheFile) {
    const fs::path dir = fs::path(TESSERA_CORPUS_DIR) / "gltf";
    ASSERT_TRUE(fs::is_directory(dir)) << dir;
    size_t files = 0;
    for (const auto& entry : fs::directory_iterator(dir)) {
        const std::string path = entry.path().string();
        ++files;
        try {
            load_gltf(path);
            ADD_FAILURE() << path << " loaded without error";
        } catch (const SceneError& e) {
            EXPECT_NE(std::string(e.what()).find(entry.path().filename().string()), std::string::npos) << e.what();
        } catch (const std::exception& e) {
            ADD_FAILURE() << path << ": not a SceneError: " << e.what();
        }
    }
    EXPECT_GE(files, 15u);
}

// Spot checks that the corpus errors point where they should.
TEST(GltfCorpus, PointersOfSelectedErrors) {
    const fs::path dir = fs::path(TESSERA_CORPUS_DIR) / "gltf";
    auto pointer = [&](const char* name) { return error_of([&] { load_gltf((dir / name).string()); }).where().pointer; };
    EXPECT_EQ(pointer("index_out_of_range.gltf"), "/meshes/0/primitives/0/indices");
    EXPECT_EQ(pointer("nan_position.gltf"), "/accessors/0");
    EXPECT_EQ(pointer("accessor_past_buffer_view.gltf"), "/accessors/0");
    EXPECT_EQ(pointer("buffer_view_past_buffer.gltf"), "/bufferViews/0");
    EXPECT_EQ(pointer("stride_smaller_than_element.gltf"), "/bufferViews/0");
    EXPECT_EQ(pointer("absurd_accessor_count.gltf"), "/accessors/0");
    EXPECT_EQ(pointer("normal_count_mismatch.gltf"), "/meshes/0/primitives/0/attributes/NORMAL");
    EXPECT_EQ(pointer("position_wrong_component_type.gltf"), "/accessors/0");
    EXPECT_EQ(pointer("draco_required.gltf"), "/extensionsRequired/0");
    EXPECT_EQ(pointer("node_cycle.gltf"), "/nodes/2/children/0");
    EXPECT_EQ(pointer("sparse_accessor.gltf"), "/accessors/0");
    EXPECT_EQ(pointer("image_buffer_view_huge_offset.gltf"), "/bufferViews/1");
    EXPECT_EQ(pointer("animation_node_out_of_range.gltf"), "/animations/0/channels/0/target/node");
    EXPECT_EQ(pointer("animation_sampler_out_of_range.gltf"), "/animations/0/channels/0/sampler");
    EXPECT_EQ(pointer("animation_times_decrease.gltf"), "/accessors/1");
    EXPECT_EQ(pointer("animation_output_too_short.gltf"), "/animations/0/samplers/0/output");
    EXPECT_EQ(pointer("animation_matrix_node.gltf"), "/animations/0/channels/0/target");
    EXPECT_EQ(pointer("animation_weights_without_targets.gltf"), "/animations/0/channels/0/target");
    EXPECT_EQ(pointer("skin_joint_out_of_range.gltf"), "/meshes/0/primitives/0/attributes/JOINTS_0");
    EXPECT_EQ(pointer("skin_joint_not_in_scene.gltf"), "/skins/0/joints/0");
    EXPECT_EQ(pointer("skin_joints_without_weights.gltf"), "/meshes/0/primitives/0/attributes");
    EXPECT_EQ(pointer("morph_weights_count_mismatch.gltf"), "/meshes/0/weights");
    EXPECT_EQ(pointer("morph_target_nan.gltf"), "/accessors/1");
}

}  // namespace
}  // namespace tessera
