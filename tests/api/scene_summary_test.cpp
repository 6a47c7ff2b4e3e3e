// A scene's counts and bounds as GET /v1/scenes reports them (scene_summary.cpp): counted from
// the description as loaded, on built-in scenes whose contents are known and on small scenes
// made here for the cases they lack (textures, scenes without geometry), in the shape
// api/openapi.yaml's Scene gives them.
#include "build_paths.h"
#include "api/scene_summary.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <memory>
#include <set>
#include <string>

#include "engine/io/scene_loader.h"
#include "engine/scene/procedural.h"

namespace tessera::api {
namespace {

using nlohmann::json;

void expect_bounds(const json& d, glm::vec3 lo, glm::vec3 hi) {
    ASSERT_TRUE(d["bounds"].is_object()) << d["bounds"];
    const json& b = d["bounds"];
    ASSERT_EQ(b["min"].size(), 3u);
    ASSERT_EQ(b["max"].size(), 3u);
    for (int a = 0; a < 3; ++a) {
        EXPECT_FLOAT_EQ(b["min"][size_t(a)].get<float>(), lo[a]) << "min, axis " << a;
        EXPECT_FLOAT_EQ(b["max"][size_t(a)].get<float>(), hi[a]) << "max, axis " << a;
    }
}

// The CS184 box: five walls and a lamp, two triangles each, four materials, the lamp emissive.
TEST(SceneSummary, CountsTheCornellBox) {
    const json d = describe_scene(load_scene("builtin:cornell_box"));
    EXPECT_EQ(d["triangles"].get<size_t>(), 12u);
    EXPECT_EQ(d["spheres"].get<size_t>(), 0u);
    EXPECT_EQ(d["lights"].get<size_t>(), 0u) << "the lamp is an emissive mesh, not a light";
    EXPECT_EQ(d["emissive_meshes"].get<size_t>(), 1u);
    EXPECT_EQ(d["materials"].get<size_t>(), 4u);
    EXPECT_EQ(d["textured_materials"].get<size_t>(), 0u);
    EXPECT_EQ(d["images"].get<size_t>(), 0u);
    EXPECT_EQ(d["texel_bytes"].get<size_t>(), 0u);
    EXPECT_EQ(d["warnings"], json::array());
    // The geometry's box only: the camera at z = 3.6 is not in it.
    expect_bounds(d, {-1.f, 0.f, -1.f}, {1.f, 1.5f, 1.f});
}

TEST(SceneSummary, CountsSpheresApartFromTriangles) {
    const json d = describe_scene(load_scene("builtin:cornell_spheres"));
    EXPECT_EQ(d["triangles"].get<size_t>(), 12u);
    EXPECT_EQ(d["spheres"].get<size_t>(), 2u);
    EXPECT_EQ(d["materials"].get<size_t>(), 4u) << "the spheres share the white walls' material";
    expect_bounds(d, {-1.f, 0.f, -1.f}, {1.f, 1.5f, 1.f});
}

// Emissive meshes, not emissive materials: many_lights keeps the big lamp's material after
// removing its mesh, so the two counts differ by one.
TEST(SceneSummary, CountsEmissiveMeshesNotMaterials) {
    const SceneDescription s = many_lights(5);
    size_t emissive_materials = 0;
    for (const MaterialDesc& m : s.materials) emissive_materials += m.emits();
    ASSERT_EQ(emissive_materials, 6u) << "the premise: the unused lamp material and five lamps";
    const json d = describe_scene(s);
    EXPECT_EQ(d["emissive_meshes"].get<size_t>(), 5u);
    EXPECT_EQ(d["materials"].get<size_t>(), 9u);
    EXPECT_EQ(d["triangles"].get<size_t>(), 2u * (5 + 5)) << "five walls and five lamps";
    EXPECT_EQ(d["spheres"].get<size_t>(), 2u);
}

TEST(SceneSummary, CountsLights) {
    const json d = describe_scene(load_scene("builtin:displaced_sphere?triangles=8"));
    EXPECT_EQ(d["triangles"].get<size_t>(), 8u);
    EXPECT_EQ(d["lights"].get<size_t>(), 1u) << "its sun";
    EXPECT_EQ(d["emissive_meshes"].get<size_t>(), 0u);
    EXPECT_EQ(d["materials"].get<size_t>(), 1u);
    ASSERT_TRUE(d["bounds"].is_object());
    for (int a = 0; a < 3; ++a)
        EXPECT_LT(d["bounds"]["min"][size_t(a)].get<double>(), d["bounds"]["max"][size_t(a)].get<double>());
}

// A sphere's box is its centre ± its radius on every axis, not its centre alone.
TEST(SceneSummary, SphereBoundsReachTheirRadius) {
    SceneDescription s;
    s.spheres.push_back({glm::vec3(1.f, 2.f, 3.f), 0.5f, -1, {}});
    s.spheres.push_back({glm::vec3(-4.f, 2.f, 3.f), 0.25f, -1, {}});
    const json d = describe_scene(s);
    EXPECT_EQ(d["triangles"].get<size_t>(), 0u);
    EXPECT_EQ(d["spheres"].get<size_t>(), 2u);
    expect_bounds(d, {-4.25f, 1.5f, 2.5f}, {1.5f, 2.5f, 3.5f});
}

TEST(SceneSummary, MeshesAndSpheresShareOneBox) {
    SceneDescription s;
    MeshDesc m;
    m.positions = {{0.f, 0.f, 0.f}, {1.f, 0.f, 0.f}, {0.f, -2.f, 0.f}};
    m.indices = {0, 1, 2};
    s.meshes.push_back(m);
    s.spheres.push_back({glm::vec3(0.f, 0.f, 5.f), 1.f, -1, {}});
    expect_bounds(describe_scene(s), {-1.f, -2.f, 0.f}, {1.f, 1.f, 6.f});
}

// No geometry, no box: null, as the schema says, not a box from +inf to -inf (which JSON would
// write as nulls inside an object). Lights are not geometry.
TEST(SceneSummary, NoGeometryHasNullBounds) {
    SceneDescription empty;
    json d = describe_scene(empty);
    EXPECT_TRUE(d.contains("bounds"));
    EXPECT_TRUE(d["bounds"].is_null());
    for (const char* count : {"triangles", "spheres", "lights", "emissive_meshes", "materials", "textured_materials", "images",
                              "texel_bytes"})
        EXPECT_EQ(d[count].get<size_t>(), 0u) << count;

    SceneDescription lit;
    LightDesc sun;
    sun.kind = LightKind::directional;
    lit.lights.push_back(sun);
    LightDesc lamp;
    lamp.position = glm::vec3(100.f);
    lit.lights.push_back(lamp);
    d = describe_scene(lit);
    EXPECT_EQ(d["lights"].get<size_t>(), 2u);
    EXPECT_TRUE(d["bounds"].is_null());
}

// A mesh without a material (-1: the default grey) is not emissive and indexes nothing.
TEST(SceneSummary, AMeshWithoutAMaterialIsNotEmissive) {
    SceneDescription s;
    MaterialDesc lamp;
    lamp.emission = glm::vec3(0.f, 0.f, 2.f);
    s.materials.push_back(lamp);
    MeshDesc grey;
    grey.positions = {{0.f, 0.f, 0.f}, {1.f, 0.f, 0.f}, {0.f, 1.f, 0.f}};
    grey.indices = {0, 1, 2};
    MeshDesc lit = grey;
    lit.material = 0;
    s.meshes = {grey, lit, grey};
    const json d = describe_scene(s);
    EXPECT_EQ(d["emissive_meshes"].get<size_t>(), 1u);
    EXPECT_EQ(d["triangles"].get<size_t>(), 3u);
}

// Textures: materials reading any map count once; images count once however many materials
// read them; their bytes are the decoded texels.
TEST(SceneSummary, CountsTexturesAndTheirBytes) {
    SceneDescription s;
    auto image = std::make_shared<TextureImage>();
    image->width = 2;
    image->height = 3;
    image->rgba.assign(2 * 3 * 4, 255);
    auto small = std::make_shared<TextureImage>();
    small->width = 1;
    small->height = 1;
    small->rgba.assign(4, 0);
    s.images = {image, small};
    s.textures.resize(2);
    s.textures[1].image = 1;
    MaterialDesc base, normal, both, plain;
    base.base_color_tex.texture = 0;
    normal.normal_tex.texture = 0;
    both.metallic_roughness_tex.texture = 1;
    both.emissive_tex.texture = 0;
    s.materials = {base, normal, both, plain};
    const json d = describe_scene(s);
    EXPECT_EQ(d["materials"].get<size_t>(), 4u);
    EXPECT_EQ(d["textured_materials"].get<size_t>(), 3u);
    EXPECT_EQ(d["images"].get<size_t>(), 2u);
    EXPECT_EQ(d["texel_bytes"].get<size_t>(), 28u);
}

TEST(SceneSummary, PassesTheWarningsOn) {
    SceneDescription s = cornell_box();
    s.warnings = {"spot light 'a': its cone angles are not kept", "a second"};
    EXPECT_EQ(describe_scene(s)["warnings"], json({"spot light 'a': its cone angles are not kept", "a second"}));
}

// Every key describe_scene writes is a property of the OpenAPI Scene, with its type (the
// catalog adds name, source and format itself).
TEST(SceneSummary, MatchesTheOpenApiScene) {
    static const YAML::Node root = YAML::LoadFile(TESSERA_OPENAPI_FILE);
    const YAML::Node props = root["components"]["schemas"]["Scene"]["properties"];
    ASSERT_TRUE(props);
    const json d = describe_scene(load_scene("builtin:cornell_spheres"));
    for (const auto& [k, v] : d.items()) {
        const YAML::Node p = props[k];
        if (!p) {
            ADD_FAILURE() << k << " is written but not a property of Scene";
            continue;
        }
        const std::string type = p["type"] ? p["type"].as<std::string>() : "";
        if (type == "integer") { EXPECT_TRUE(v.is_number_integer()) << k << " = " << v; }
        if (type == "array") { EXPECT_TRUE(v.is_array()) << k << " = " << v; }
        if (type == "object") { EXPECT_TRUE(v.is_object() || (v.is_null() && p["nullable"] && p["nullable"].as<bool>())) << k; }
    }
    const YAML::Node bounds = props["bounds"]["required"];
    ASSERT_TRUE(bounds);
    for (const auto& r : bounds) EXPECT_TRUE(d["bounds"].contains(r.as<std::string>())) << r.as<std::string>();
}

}  // namespace
}  // namespace tessera::api
