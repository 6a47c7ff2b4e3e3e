#pragma once
// The plain description of a scene as loaders produce it: world-space geometry, materials,
// lights and camera, each remembering where it came from. Nothing here is built for speed;
// RenderScene is built from it once per job.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "engine/core/scene_error.h"
#include "engine/material/texture.h"

namespace tessera {

// emission: emits, and reflects as diffuse. metallic_roughness: glTF 2.0's model (albedo is the
// base colour, roughness the perceptual roughness).
enum class MaterialKind { diffuse, emission, mirror, glass, microfacet, glossy, metallic_roughness };

// glTF alphaMode: opaque; mask: cut out where alpha < cutoff; blend: stochastically transparent
// with probability 1 − alpha (each ray decides by a hash of itself, as pbrt-v4 does).
enum class AlphaMode : uint8_t { opaque, mask, blend };

struct MaterialDesc {
    std::string name;
    MaterialKind kind = MaterialKind::diffuse;
    glm::vec3 albedo{0.5f};        // diffuse reflectance (or mirror/glass reflectance)
    glm::vec3 emission{0.0f};      // emitted radiance; non-zero makes the surface a light
    glm::vec3 transmittance{0.0f}; // glass
    float ior = 1.5f;              // glass; metallic_roughness: KHR_materials_ior
    float roughness = 0.0f;        // microfacet: Beckmann alpha; metallic_roughness: glTF roughness (alpha = roughness²)
    float metallic = 0.0f;         // metallic_roughness
    float specular = 1.0f;         // metallic_roughness: KHR_materials_specular's specularFactor
    float shininess = 0.0f;        // glossy
    glm::vec3 eta{0.0f}, k{0.0f};  // microfacet conductor
    bool double_sided = false;     // emission on both sides (glTF doubleSided)
    // glTF textures (index into SceneDescription::textures) and alpha. Base colour and emissive
    // multiply their factors; metallic-roughness multiplies metallic (blue) and roughness (green).
    TextureSlot base_color_tex, metallic_roughness_tex, emissive_tex, normal_tex;
    float alpha = 1.f;             // baseColorFactor's alpha
    AlphaMode alpha_mode = AlphaMode::opaque;
    float alpha_cutoff = 0.5f;
    SourceLocation origin;
    bool textured() const {
        return base_color_tex.used() || metallic_roughness_tex.used() || emissive_tex.used() || normal_tex.used();
    }
    bool emits() const { return emission.x > 0.f || emission.y > 0.f || emission.z > 0.f; }
};

// A triangle mesh already transformed to world space.
struct MeshDesc {
    std::string name;
    std::vector<glm::vec3> positions;
    std::vector<glm::vec3> normals;  // per vertex, empty when the file had none
    // Without normals: true shades with face normals (glTF's rule), false with area-weighted
    // vertex normals (what the CS184 loader does).
    bool flat_normals = false;
    std::vector<uint32_t> indices;   // three per triangle, all < positions.size()
    // Per vertex like positions, each empty when the file had none: texture coordinates 0 and 1,
    // COLOR_0 (multiplies the base colour) and tangents (xyz, handedness in w).
    std::vector<glm::vec2> uv[2];
    std::vector<glm::vec4> colors;
    std::vector<glm::vec4> tangents;
    int material = -1;               // index into SceneDescription::materials, -1 = default grey
    SourceLocation origin;
};

// A placement of a prototype mesh (SceneDescription::prototypes, in the mesh's own space): a
// mesh that several nodes use is stored once and built once, however many times it is placed.
struct InstanceDesc {
    uint32_t prototype = 0;
    glm::mat4 to_world{1.f};  // affine (bottom row 0 0 0 1), invertible
    SourceLocation origin;
};

struct SphereDesc {
    glm::vec3 center{0.0f};
    float radius = 1.0f;
    int material = -1;
    SourceLocation origin;
};

enum class LightKind { point, directional, area, ambient, spot };

struct LightDesc {
    LightKind kind = LightKind::point;
    glm::vec3 radiance{1.0f};   // radiance (area, ambient) or intensity (point, spot) or irradiance (directional)
    glm::vec3 position{0.0f};   // point, spot, area (centre of the parallelogram)
    glm::vec3 direction{0.0f, -1.0f, 0.0f};  // directional: direction light travels; area: normal of the emitting side
    glm::vec3 dim_x{0.0f}, dim_y{0.0f};       // area: full edge vectors of the parallelogram
    SourceLocation origin;
};

struct CameraDesc {
    glm::vec3 position{0.0f, 0.0f, 1.0f};
    glm::vec3 look_at{0.0f};
    glm::vec3 up{0.0f, 1.0f, 0.0f};
    float hfov_deg = 50.0f;
    float vfov_deg = 35.0f;
    float znear = 0.001f;
    float zfar = 1000.0f;
    // CS184 convention: the focal length in pixels is fixed (fitted to 800x600) and a different
    // output size crops or extends the view. Zero means: fit vfov to the output's aspect (glTF).
    float focal_px = 0.0f;
    // The CS184 app places the camera by orbiting the scene's bounding box along this direction
    // (see CS184 README); when set, RenderScene computes position/look_at from the final bounds.
    std::optional<glm::vec3> cs184_orbit_dir;
    SourceLocation origin;
};

// A moment of an animated scene: the time, and which animations play ("" every one at once, as
// glTF viewers play them; otherwise one animation's name, or its index in decimal).
struct ScenePose {
    double time_s = 0;
    std::string animation;  // a name, else the index its digits spell; empty: every animation
    bool by_index = false;  // `animation` is an index's digits, never a name
};

// What a file animates, as a job's frames and the scene summary need to know it.
struct AnimationSummary {
    std::string name;
    double start_s = 0, end_s = 0;  // the first and last key
    int channels = 0;
};

// Which of `list` (items with a `name`) a pose's one animation is: the one of that name, unless
// `by_index`; else the one at the index its digits spell. nullopt: none. One rule for the
// reader that plays it and the runner that refuses a job before its first frame.
template <class List>
std::optional<size_t> chosen_animation(const List& list, const std::string& animation, bool by_index) {
    if (!by_index)
        for (size_t i = 0; i < list.size(); ++i)
            if (list[i].name == animation) return i;
    if (animation.empty() || animation.size() >= 10) return std::nullopt;
    for (const char ch : animation)
        if (ch < '0' || ch > '9') return std::nullopt;
    const size_t i = std::stoul(animation);
    return i < list.size() ? std::optional<size_t>(i) : std::nullopt;
}

struct SceneDescription {
    std::string source;                  // path or name it was loaded from
    std::vector<MaterialDesc> materials;
    std::vector<std::shared_ptr<const TextureImage>> images;  // decoded, shared with the render scene
    std::vector<Texture> textures;       // Texture::image indexes images
    std::vector<MeshDesc> meshes;        // world space, each placed once
    std::vector<MeshDesc> prototypes;    // object space, placed by instances (none of them emissive
                                         // is required: the render scene flattens emitters)
    std::vector<InstanceDesc> instances;
    std::vector<SphereDesc> spheres;
    std::vector<LightDesc> lights;
    std::optional<CameraDesc> camera;    // absent: a default camera frames the scene
    std::vector<AnimationSummary> animations;  // what the file animates (posed or not)
    std::vector<std::string> warnings;   // things that were read but are not (yet) rendered as written
    // The files besides its own that the loader read (a glTF's external buffers and images), by
    // their paths: what a cache of prepared scenes watches for edits besides the file itself.
    std::vector<std::string> files_read;

    // Triangles stored: each prototype once (what memory and the triangle limit count).
    size_t triangle_count() const {
        size_t n = 0;
        for (const auto& m : meshes) n += m.indices.size() / 3;
        for (const auto& m : prototypes) n += m.indices.size() / 3;
        return n;
    }
    // Triangles in the world: each prototype as often as it is placed.
    size_t placed_triangle_count() const {
        size_t n = 0;
        for (const auto& m : meshes) n += m.indices.size() / 3;
        for (const auto& i : instances) n += prototypes[i.prototype].indices.size() / 3;
        return n;
    }
};

// Limits that protect a loader from absurd or hostile input.
struct LoadLimits {
    uint64_t max_file_bytes = 1ull << 30;     // 1 GiB
    uint64_t max_triangles = 50'000'000;
    uint64_t max_vertices = 50'000'000;
    int max_node_depth = 256;                 // nested scene-graph nodes
    int max_json_depth = 64;                  // nested arrays and objects of a glTF's JSON
    uint64_t max_texture_bytes = 512ull << 20;  // decoded texels of all images (4 bytes each), and each one's decoding peak
    int max_texture_size = 16384;               // width or height of one image
    uint64_t max_instances = 1'000'000;         // mesh primitives placed by nodes (a node per placement)
};

// Checks the invariants every consumer relies on (finite numbers, indices in range, positive
// radii). Throws SceneError naming the item's origin. Loaders call it last.
void validate(const SceneDescription& scene);

}  // namespace tessera
