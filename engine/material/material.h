#pragma once
// A surface's runtime material: its BSDF and its emission, made once per job from the
// loader's MaterialDesc.
#include <glm/glm.hpp>

#include "engine/material/bsdf.h"
#include "engine/scene/scene_description.h"

namespace tessera {

struct Material {
    Bsdf bsdf;
    glm::vec3 emission{0.f};
    bool double_sided = false;
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
