#pragma once
// A surface's runtime material: its BSDF and its emission, made once per job from the
// loader's MaterialDesc.
#include <glm/glm.hpp>

#include "engine/material/bsdf.h"
#include "engine/scene/scene_description.h"

namespace tessera {

inline constexpr uint32_t kNoTextures = ~0u;

// What a material reads per hit (engine/scene/surface_textures.h): its glTF textures, alpha and
// the meshes' vertex colours.
struct MaterialTextures {
    TextureSlot base_color, metallic_roughness, emissive, normal;
    float alpha = 1.f;        // baseColorFactor's alpha
    AlphaMode alpha_mode = AlphaMode::opaque;
    float alpha_cutoff = 0.5f;
    bool vertex_colors = false;  // a mesh with this material has COLOR_0
};

struct Material {
    Bsdf bsdf;
    glm::vec3 emission{0.f};
    bool double_sided = false;
    uint32_t textures = kNoTextures;  // into RenderScene::material_textures; none: the constants above are all
    bool emissive() const { return emission.x > 0.f || emission.y > 0.f || emission.z > 0.f; }
};

// The BSDF a description asks for. CS184's names map to their BSDFs (mirror, glass,
// microfacet: Beckmann conductor, glossy: normalised Phong); emission and diffuse are Lambertian.
Material make_material(const MaterialDesc& desc);

// An emitter that reflects nothing (a CS184 area light turned into a mesh).
inline Material emitter_material(const glm::vec3& radiance) {
    Material m;
    m.bsdf.albedo = glm::vec3(0.f);
    m.emission = radiance;
    return m;
}

}  // namespace tessera
