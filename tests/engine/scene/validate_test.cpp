// validate(): every invariant a consumer relies on is refused when broken, each refusal naming
// the broken item's own origin (not a neighbour's, not the scene's) and what is wrong with it;
// and the edges of each range (metallic 1, texcoord 1, index n-1, material -1, a near plane at
// 0) are taken, so that loaders calling it last never turn away a valid file.
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "engine/scene/procedural.h"
#include "engine/scene/scene_description.h"

namespace tessera {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

// Each item a different origin: a refusal that names the wrong item shows up as a mismatch.
const SourceLocation kMaterialAt{"scene.gltf", 0, "/materials/0"};
const SourceLocation kMeshAt{"scene.gltf", 0, "/meshes/0/primitives/0"};
const SourceLocation kSphereAt{"scene.dae", 12, ""};
const SourceLocation kLightAt{"scene.dae", 31, ""};
const SourceLocation kCameraAt{"scene.gltf", 0, "/cameras/0"};
const SourceLocation kSceneAt{"scene.gltf", 0, ""};

// A valid scene holding one of everything validate() looks at, every optional array filled.
SceneDescription valid_scene() {
    SceneDescription s;
    s.source = "scene.gltf";
    auto img = std::make_shared<TextureImage>();
    img->width = 2;
    img->height = 1;
    img->rgba.assign(8, 200);
    s.images.push_back(img);
    s.textures.push_back(Texture{});
    MaterialDesc m;
    m.name = "paint";
    m.base_color_tex.texture = 0;
    m.normal_tex.texture = 0;
    m.normal_tex.texcoord = 1;
    m.origin = kMaterialAt;
    s.materials.push_back(m);
    MeshDesc mesh;
    mesh.name = "tri";
    mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    mesh.normals.assign(3, glm::vec3(0, 0, 1));
    mesh.uv[0].assign(3, glm::vec2(0.5f));
    mesh.uv[1].assign(3, glm::vec2(0.25f));
    mesh.colors.assign(3, glm::vec4(1.f));
    mesh.tangents.assign(3, glm::vec4(1, 0, 0, 1));
    mesh.indices = {0, 1, 2};
    mesh.material = 0;
    mesh.origin = kMeshAt;
    s.meshes.push_back(mesh);
    s.spheres.push_back(SphereDesc{glm::vec3(0, 0, -2), 0.5f, 0, kSphereAt});
    LightDesc l;
    l.kind = LightKind::area;
    l.radiance = glm::vec3(5.f);
    l.position = {0, 2, 0};
    l.direction = {0, -1, 0};
    l.dim_x = {0.5f, 0, 0};
    l.dim_y = {0, 0, 0.5f};
    l.origin = kLightAt;
    s.lights.push_back(l);
    CameraDesc c;
    c.origin = kCameraAt;
    s.camera = c;
    return s;
}

struct Refusal {
    const char* what;
    std::function<void(SceneDescription&)> edit;
    SourceLocation where;
    std::string says;  // a part of the message
};

void expect_refused(const Refusal& r) {
    SceneDescription s = valid_scene();
    r.edit(s);
    try {
        validate(s);
        ADD_FAILURE() << r.what << ": accepted";
    } catch (const SceneError& e) {
        EXPECT_EQ(e.where().file, r.where.file) << r.what << ": " << e.what();
        EXPECT_EQ(e.where().line, r.where.line) << r.what << ": " << e.what();
        EXPECT_EQ(e.where().pointer, r.where.pointer) << r.what << ": " << e.what();
        EXPECT_NE(e.detail().find(r.says), std::string::npos) << r.what << ": " << e.detail();
        EXPECT_EQ(std::string(e.what()).rfind(r.where.str() + ": ", 0), 0u) << r.what << ": " << e.what();
    }
}

TEST(Validate, TheFixtureAndEveryBuiltInSceneAreValid) {
    EXPECT_NO_THROW(validate(valid_scene()));
    EXPECT_NO_THROW(validate(SceneDescription{}));
    // Built-in scenes do not pass through a loader, so nothing else holds them to the invariants.
    for (const char* name : {"builtin:cornell_box", "builtin:cornell_spheres", "builtin:cornell_glossy", "builtin:lamp_room",
                             "builtin:furnace", "builtin:many_lights", "builtin:scattered_lights", "builtin:lamp_field",
                             "builtin:displaced_sphere?triangles=500"})
        EXPECT_NO_THROW(validate(builtin_scene(name))) << name;
    EXPECT_NO_THROW(validate(furnace_sphere(0.5f, 1.f, 2.f, glm::vec3(1, 2, 3), 3)));
    EXPECT_NO_THROW(validate(lamp_field(20, false)));
}

TEST(Validate, ImagesAndTexturesNameTheScene) {
    const std::vector<Refusal> cases = {
        {"null image", [](SceneDescription& s) { s.images[0] = nullptr; }, kSceneAt, "an image's texels do not match its size"},
        {"zero width",
         [](SceneDescription& s) {
             auto img = std::make_shared<TextureImage>();
             img->height = 1;
             s.images[0] = img;
         },
         kSceneAt, "an image's texels do not match its size"},
        {"texels short of the size",
         [](SceneDescription& s) {
             auto img = std::make_shared<TextureImage>(*s.images[0]);
             img->rgba.pop_back();
             s.images[0] = img;
         },
         kSceneAt, "an image's texels do not match its size"},
        {"texels past the size",
         [](SceneDescription& s) {
             auto img = std::make_shared<TextureImage>(*s.images[0]);
             img->rgba.resize(12, 0);
             s.images[0] = img;
         },
         kSceneAt, "an image's texels do not match its size"},
        {"texture past the images", [](SceneDescription& s) { s.textures[0].image = 1; }, kSceneAt,
         "a texture refers to image 1 of 1"},
    };
    for (const Refusal& r : cases) expect_refused(r);
}

TEST(Validate, MaterialRefusalsNameTheMaterial) {
    auto set = [](auto member, float v) {
        return [member, v](SceneDescription& s) { s.materials[0].*member = v; };
    };
    auto set3 = [](auto member, glm::vec3 v) {
        return [member, v](SceneDescription& s) { s.materials[0].*member = v; };
    };
    const std::vector<Refusal> cases = {
        {"texture past the list", [](SceneDescription& s) { s.materials[0].emissive_tex.texture = 1; }, kMaterialAt,
         "material 'paint' refers to texture 1 (coordinate set 0) of 1"},
        {"texture below -1", [](SceneDescription& s) { s.materials[0].metallic_roughness_tex.texture = -2; }, kMaterialAt,
         "refers to texture -2"},
        {"coordinate set 2", [](SceneDescription& s) { s.materials[0].base_color_tex.texcoord = 2; }, kMaterialAt,
         "(coordinate set 2)"},
        {"NaN texture transform", [](SceneDescription& s) { s.materials[0].base_color_tex.row_u.z = kNaN; }, kMaterialAt,
         "non-finite texture transform"},
        {"infinite texture transform", [](SceneDescription& s) { s.materials[0].emissive_tex.row_v.x = kInf; }, kMaterialAt,
         "non-finite texture transform"},
        {"infinite normal scale", [](SceneDescription& s) { s.materials[0].normal_tex.scale = kInf; }, kMaterialAt,
         "non-finite texture transform"},
        {"NaN alpha", set(&MaterialDesc::alpha, kNaN), kMaterialAt, "alpha or alpha cutoff"},
        {"negative alpha", set(&MaterialDesc::alpha, -0.1f), kMaterialAt, "alpha or alpha cutoff"},
        {"negative cutoff", set(&MaterialDesc::alpha_cutoff, -1.f), kMaterialAt, "alpha or alpha cutoff"},
        {"infinite cutoff", set(&MaterialDesc::alpha_cutoff, kInf), kMaterialAt, "alpha or alpha cutoff"},
        {"NaN albedo", set3(&MaterialDesc::albedo, {0.5f, kNaN, 0.5f}), kMaterialAt, "non-finite parameter"},
        {"infinite emission", set3(&MaterialDesc::emission, {kInf, 0, 0}), kMaterialAt, "non-finite parameter"},
        {"NaN transmittance", set3(&MaterialDesc::transmittance, {0, 0, kNaN}), kMaterialAt, "non-finite parameter"},
        {"NaN ior", set(&MaterialDesc::ior, kNaN), kMaterialAt, "non-finite parameter"},
        {"NaN roughness", set(&MaterialDesc::roughness, kNaN), kMaterialAt, "non-finite parameter"},
        {"infinite eta", set3(&MaterialDesc::eta, {kInf, 1, 1}), kMaterialAt, "non-finite parameter"},
        {"NaN k", set3(&MaterialDesc::k, {1, kNaN, 1}), kMaterialAt, "non-finite parameter"},
        {"NaN metallic", set(&MaterialDesc::metallic, kNaN), kMaterialAt, "non-finite parameter"},
        {"infinite specular", set(&MaterialDesc::specular, kInf), kMaterialAt, "non-finite parameter"},
        {"infinite shininess", set(&MaterialDesc::shininess, kInf), kMaterialAt, "non-finite parameter"},
        {"zero ior", set(&MaterialDesc::ior, 0.f), kMaterialAt, "index of refraction 0.000000, not > 0"},
        {"negative ior", set(&MaterialDesc::ior, -1.5f), kMaterialAt, "index of refraction -1.500000, not > 0"},
        {"negative transmittance", set3(&MaterialDesc::transmittance, {0, -0.1f, 0}), kMaterialAt, "out of its range"},
        {"negative eta", set3(&MaterialDesc::eta, {1, 1, -1}), kMaterialAt, "out of its range"},
        {"negative k", set3(&MaterialDesc::k, {-2, 1, 1}), kMaterialAt, "out of its range"},
        {"negative roughness", set(&MaterialDesc::roughness, -0.01f), kMaterialAt, "out of its range"},
        {"metallic below 0", set(&MaterialDesc::metallic, -0.01f), kMaterialAt, "out of its range"},
        {"metallic above 1", set(&MaterialDesc::metallic, 1.01f), kMaterialAt, "out of its range"},
        {"negative specular", set(&MaterialDesc::specular, -1.f), kMaterialAt, "out of its range"},
        {"negative shininess", set(&MaterialDesc::shininess, -5.f), kMaterialAt, "out of its range"},
        {"negative emission", set3(&MaterialDesc::emission, {-1, 0, 0}), kMaterialAt,
         "material 'paint' has negative emission (-1.000000, 0.000000, 0.000000)"},
        {"negative albedo", set3(&MaterialDesc::albedo, {0.5f, 0.5f, -0.25f}), kMaterialAt,
         "material 'paint' has negative albedo (0.500000, 0.500000, -0.250000)"},
    };
    for (const Refusal& r : cases) expect_refused(r);
}

TEST(Validate, MeshRefusalsNameTheMesh) {
    const std::vector<Refusal> cases = {
        {"indices not whole triangles", [](SceneDescription& s) { s.meshes[0].indices.push_back(0); }, kMeshAt,
         "mesh 'tri' has 4 indices, not a multiple of 3"},
        {"material past the list", [](SceneDescription& s) { s.meshes[0].material = 1; }, kMeshAt,
         "mesh 'tri' refers to material 1 of 1"},
        {"material below -1", [](SceneDescription& s) { s.meshes[0].material = -2; }, kMeshAt, "refers to material -2 of 1"},
        {"NaN position", [](SceneDescription& s) { s.meshes[0].positions[1].y = kNaN; }, kMeshAt,
         "mesh 'tri' vertex 1 has a non-finite position"},
        {"infinite position", [](SceneDescription& s) { s.meshes[0].positions[2].z = -kInf; }, kMeshAt,
         "vertex 2 has a non-finite position"},
        {"too few normals", [](SceneDescription& s) { s.meshes[0].normals.pop_back(); }, kMeshAt, "has 2 normals for 3 vertices"},
        {"too many normals", [](SceneDescription& s) { s.meshes[0].normals.push_back({0, 0, 1}); }, kMeshAt,
         "has 4 normals for 3 vertices"},
        {"NaN normal", [](SceneDescription& s) { s.meshes[0].normals[2].x = kNaN; }, kMeshAt, "normal 2 is not finite"},
        {"uv set 0 short", [](SceneDescription& s) { s.meshes[0].uv[0].pop_back(); }, kMeshAt,
         "has 2 texture coordinates (set 0) for 3 vertices"},
        {"NaN uv set 1", [](SceneDescription& s) { s.meshes[0].uv[1][0].y = kNaN; }, kMeshAt,
         "texture coordinates (set 1) 0 is not finite"},
        {"colours long", [](SceneDescription& s) { s.meshes[0].colors.push_back(glm::vec4(1)); }, kMeshAt,
         "has 4 vertex colours for 3 vertices"},
        {"infinite colour alpha", [](SceneDescription& s) { s.meshes[0].colors[1].w = kInf; }, kMeshAt,
         "vertex colours 1 is not finite"},
        {"NaN tangent handedness", [](SceneDescription& s) { s.meshes[0].tangents[2].w = kNaN; }, kMeshAt,
         "tangents 2 is not finite"},
        {"index one past the vertices", [](SceneDescription& s) { s.meshes[0].indices[2] = 3; }, kMeshAt,
         "mesh 'tri' index 2 = 3 is out of range (3 vertices)"},
        {"index at the top of uint32", [](SceneDescription& s) { s.meshes[0].indices[0] = 0xFFFFFFFFu; }, kMeshAt,
         "index 0 = 4294967295 is out of range"},
    };
    for (const Refusal& r : cases) expect_refused(r);
}

TEST(Validate, SphereLightAndCameraRefusalsNameTheirItem) {
    const std::vector<Refusal> cases = {
        {"zero radius", [](SceneDescription& s) { s.spheres[0].radius = 0.f; }, kSphereAt, "a positive radius"},
        {"negative radius", [](SceneDescription& s) { s.spheres[0].radius = -0.5f; }, kSphereAt, "a positive radius"},
        {"NaN radius", [](SceneDescription& s) { s.spheres[0].radius = kNaN; }, kSphereAt, "a positive radius"},
        {"infinite radius", [](SceneDescription& s) { s.spheres[0].radius = kInf; }, kSphereAt, "a positive radius"},
        {"NaN centre", [](SceneDescription& s) { s.spheres[0].center.x = kNaN; }, kSphereAt, "finite centre"},
        {"sphere material past the list", [](SceneDescription& s) { s.spheres[0].material = 1; }, kSphereAt,
         "sphere refers to material 1"},
        {"sphere material below -1", [](SceneDescription& s) { s.spheres[0].material = -3; }, kSphereAt,
         "sphere refers to material -3"},
        {"NaN radiance", [](SceneDescription& s) { s.lights[0].radiance.z = kNaN; }, kLightAt, "light has a non-finite parameter"},
        {"infinite position", [](SceneDescription& s) { s.lights[0].position.y = kInf; }, kLightAt, "non-finite parameter"},
        {"NaN direction", [](SceneDescription& s) { s.lights[0].direction.x = kNaN; }, kLightAt, "non-finite parameter"},
        {"NaN edge x", [](SceneDescription& s) { s.lights[0].dim_x.x = kNaN; }, kLightAt, "non-finite parameter"},
        {"infinite edge y", [](SceneDescription& s) { s.lights[0].dim_y.z = kInf; }, kLightAt, "non-finite parameter"},
        {"negative radiance", [](SceneDescription& s) { s.lights[0].radiance = {1, -0.5f, 1}; }, kLightAt,
         "light has negative radiance (1.000000, -0.500000, 1.000000)"},
        {"NaN camera position", [](SceneDescription& s) { s.camera->position.x = kNaN; }, kCameraAt,
         "camera has a non-finite parameter"},
        {"infinite look-at", [](SceneDescription& s) { s.camera->look_at.z = kInf; }, kCameraAt, "non-finite parameter"},
        {"NaN up", [](SceneDescription& s) { s.camera->up.y = kNaN; }, kCameraAt, "non-finite parameter"},
        {"NaN hfov", [](SceneDescription& s) { s.camera->hfov_deg = kNaN; }, kCameraAt, "non-finite parameter"},
        {"NaN vfov", [](SceneDescription& s) { s.camera->vfov_deg = kNaN; }, kCameraAt, "non-finite parameter"},
        {"NaN near", [](SceneDescription& s) { s.camera->znear = kNaN; }, kCameraAt, "non-finite parameter"},
        {"infinite far", [](SceneDescription& s) { s.camera->zfar = kInf; }, kCameraAt, "non-finite parameter"},
        {"NaN focal length", [](SceneDescription& s) { s.camera->focal_px = kNaN; }, kCameraAt, "non-finite parameter"},
        {"zero hfov", [](SceneDescription& s) { s.camera->hfov_deg = 0.f; }, kCameraAt, "field of view must lie in (0, 180)"},
        {"hfov of 180", [](SceneDescription& s) { s.camera->hfov_deg = 180.f; }, kCameraAt, "field of view"},
        {"negative vfov", [](SceneDescription& s) { s.camera->vfov_deg = -30.f; }, kCameraAt, "field of view"},
        {"vfov of 180", [](SceneDescription& s) { s.camera->vfov_deg = 180.f; }, kCameraAt, "field of view"},
        {"negative near", [](SceneDescription& s) { s.camera->znear = -0.1f; }, kCameraAt, "0 <= near < far"},
        {"far at near", [](SceneDescription& s) { s.camera->zfar = s.camera->znear; }, kCameraAt, "0 <= near < far"},
        {"far before near", [](SceneDescription& s) { s.camera->zfar = 0.5f * s.camera->znear; }, kCameraAt,
         "0 <= near < far"},
    };
    for (const Refusal& r : cases) expect_refused(r);
}

// A refusal of the second of two meshes names the second, by its own origin and name.
TEST(Validate, TheRefusedItemIsTheOneThatIsBroken) {
    SceneDescription s = valid_scene();
    MeshDesc second = s.meshes[0];
    second.name = "second";
    second.origin = SourceLocation{"scene.gltf", 0, "/meshes/1/primitives/0"};
    second.positions[0].x = kNaN;
    s.meshes.push_back(second);
    try {
        validate(s);
        ADD_FAILURE() << "accepted";
    } catch (const SceneError& e) {
        EXPECT_EQ(e.where().pointer, "/meshes/1/primitives/0");
        EXPECT_NE(e.detail().find("mesh 'second' vertex 0"), std::string::npos) << e.detail();
    }
}

// The edges of each range are inside it.
TEST(Validate, RangeEdgesAreAccepted) {
    const std::vector<std::pair<const char*, std::function<void(SceneDescription&)>>> edits = {
        {"metallic 0", [](SceneDescription& s) { s.materials[0].metallic = 0.f; }},
        {"metallic 1", [](SceneDescription& s) { s.materials[0].metallic = 1.f; }},
        {"roughness, specular, shininess 0",
         [](SceneDescription& s) {
             s.materials[0].roughness = 0.f;
             s.materials[0].specular = 0.f;
             s.materials[0].shininess = 0.f;
         }},
        {"alpha and cutoff 0",
         [](SceneDescription& s) {
             s.materials[0].alpha = 0.f;
             s.materials[0].alpha_cutoff = 0.f;
         }},
        {"a tiny ior", [](SceneDescription& s) { s.materials[0].ior = 1e-6f; }},
        {"zero albedo and emission",
         [](SceneDescription& s) {
             s.materials[0].albedo = glm::vec3(0.f);
             s.materials[0].emission = glm::vec3(0.f);
         }},
        {"no texture and coordinate set 1",
         [](SceneDescription& s) {
             s.materials[0].base_color_tex.texture = -1;
             s.materials[0].emissive_tex.texcoord = 1;
         }},
        {"no material anywhere",
         [](SceneDescription& s) {
             s.meshes[0].material = -1;
             s.spheres[0].material = -1;
         }},
        {"the last vertex", [](SceneDescription& s) { s.meshes[0].indices = {2, 2, 2}; }},
        {"no optional vertex arrays",
         [](SceneDescription& s) {
             MeshDesc& m = s.meshes[0];
             m.normals.clear();
             m.uv[0].clear();
             m.uv[1].clear();
             m.colors.clear();
             m.tangents.clear();
         }},
        {"a mesh with no triangles",
         [](SceneDescription& s) {
             s.meshes[0].indices.clear();
             s.meshes[0].positions.clear();
             s.meshes[0].normals.clear();
             s.meshes[0].uv[0].clear();
             s.meshes[0].uv[1].clear();
             s.meshes[0].colors.clear();
             s.meshes[0].tangents.clear();
         }},
        {"a tiny radius", [](SceneDescription& s) { s.spheres[0].radius = 1e-30f; }},
        {"black light", [](SceneDescription& s) { s.lights[0].radiance = glm::vec3(0.f); }},
        {"near plane 0", [](SceneDescription& s) { s.camera->znear = 0.f; }},
        {"wide fields of view",
         [](SceneDescription& s) {
             s.camera->hfov_deg = 179.9f;
             s.camera->vfov_deg = 0.01f;
         }},
        {"no camera", [](SceneDescription& s) { s.camera.reset(); }},
        {"an unused texture", [](SceneDescription& s) { s.materials[0] = MaterialDesc{}; }},
    };
    for (const auto& [what, edit] : edits) {
        SceneDescription s = valid_scene();
        edit(s);
        EXPECT_NO_THROW(validate(s)) << what;
    }
}

}  // namespace
}  // namespace tessera
