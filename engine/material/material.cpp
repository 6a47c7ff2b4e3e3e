#include "engine/material/material.h"

#include "engine/material/ggx_albedo.h"

#include <algorithm>

namespace tessera {

Material make_material(const MaterialDesc& d) {
    Material m;
    m.emission = d.emission;
    m.double_sided = d.double_sided;
    Bsdf& b = m.bsdf;
    b.albedo = d.albedo;
    switch (d.kind) {
        case MaterialKind::diffuse:
        case MaterialKind::emission: b.kind = BsdfKind::lambertian; break;
        case MaterialKind::mirror: b.kind = BsdfKind::mirror; break;
        case MaterialKind::glass:
            b.kind = BsdfKind::glass;
            b.transmittance = d.transmittance;
            b.ior = d.ior;
            break;
        case MaterialKind::microfacet:
            b.kind = BsdfKind::conductor;
            b.alpha = std::max(d.roughness, 0.f);  // below kSmoothAlpha: a delta lobe
            b.eta = d.eta;
            b.k = d.k;
            break;
        case MaterialKind::glossy:
            b.kind = BsdfKind::phong;
            b.exponent = std::max(0.f, d.shininess);
            break;
        case MaterialKind::metallic_roughness:
            b.kind = BsdfKind::metallic_roughness;
            b.metallic = std::clamp(d.metallic, 0.f, 1.f);
            b.alpha = d.roughness * d.roughness;  // below kSmoothAlpha: a delta lobe
            b.ior = d.ior;
            b.specular = std::max(0.f, d.specular);
            // The albedo tables are integrated here, with the scene, not in the first pixel a
            // render shades (once per process, under a second).
            ggx_albedo_average(1.f);
            break;
    }
    return m;
}

}  // namespace tessera
