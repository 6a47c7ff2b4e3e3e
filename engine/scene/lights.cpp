#include "engine/scene/lights.h"

#include "engine/geometry/aabb.h"
#include "engine/scene/render_scene.h"

namespace tessera {

std::vector<MeshDesc> cs184_lamps_as_meshes(const SceneDescription& desc, std::vector<Material>& materials,
                                            BuildReport& report) {
    std::vector<MeshDesc> lamps;
    for (const LightDesc& l : desc.lights) {
        if (l.kind != LightKind::area) continue;
        bool duplicate = false;
        for (const MeshDesc& m : desc.meshes) {
            if (m.material < 0 || !materials[size_t(m.material)].emissive()) continue;
            Aabb mb;
            for (const glm::vec3& p : m.positions) mb.expand(p);
            const glm::vec3 pad = 0.05f * glm::vec3(glm::length(mb.extent())) + 1e-6f;
            if (glm::all(glm::greaterThanEqual(l.position, mb.lo - pad)) && glm::all(glm::lessThanEqual(l.position, mb.hi + pad)))
                duplicate = true;
        }
        if (duplicate) {
            report.left_out.push_back("area light at " + l.origin.str() +
                                      ": it duplicates an emissive mesh, which is used as the light");
            continue;
        }
        MeshDesc q;
        q.name = "area light";
        q.origin = l.origin;
        const glm::vec3 hx = 0.5f * l.dim_x, hy = 0.5f * l.dim_y;
        q.positions = {l.position - hx - hy, l.position + hx - hy, l.position + hx + hy, l.position - hx + hy};
        q.indices = {0, 1, 2, 0, 2, 3};
        if (glm::dot(glm::cross(q.positions[1] - q.positions[0], q.positions[2] - q.positions[0]), l.direction) < 0.f)
            q.indices = {0, 2, 1, 0, 3, 2};  // emit toward the light's direction
        q.material = int(materials.size());
        materials.push_back(emitter_material(l.radiance));
        lamps.push_back(std::move(q));
    }
    return lamps;
}

void add_delta_lights(const SceneDescription& desc, RenderScene& s) {
    for (const LightDesc& l : desc.lights) {
        switch (l.kind) {
            case LightKind::point:
            case LightKind::spot:
                s.delta_lights.push_back({DeltaKind::point, l.position, glm::vec3(0.f), l.radiance});
                break;
            case LightKind::directional: {
                const float len = glm::length(l.direction);
                if (len > 0.f) s.delta_lights.push_back({DeltaKind::directional, glm::vec3(0.f), l.direction / len, l.radiance});
                break;
            }
            case LightKind::ambient: s.sky += l.radiance; s.has_sky = true; break;
            case LightKind::area: break;
        }
    }
}

uint32_t add_area_light(const MeshDesc& mesh, const Material& material, uint32_t material_index, RenderScene& s) {
    AreaLight al{uint32_t(s.light_triangles.size()), 0, 0.f, material.emission, material.double_sided, 0.f, 0.f, material_index};
    for (size_t i = 0; i + 2 < mesh.indices.size(); i += 3) {
        const glm::vec3& p0 = mesh.positions[mesh.indices[i]];
        const glm::vec3 e1 = mesh.positions[mesh.indices[i + 1]] - p0, e2 = mesh.positions[mesh.indices[i + 2]] - p0;
        const float a = 0.5f * glm::length(glm::cross(e1, e2));
        if (!(a > 0.f)) continue;  // degenerate triangles cannot be sampled
        al.area += a;
        s.light_triangles.push_back({p0, e1, e2, glm::normalize(glm::cross(e1, e2)), al.area, uint32_t(s.area_lights.size()), a});
    }
    al.count = uint32_t(s.light_triangles.size()) - al.first;
    if (al.count == 0) return kNoLight;
    for (uint32_t i = al.first; i < al.first + al.count; ++i) s.light_triangles[i].cdf /= al.area;
    s.light_triangles[al.first + al.count - 1].cdf = 1.f;
    s.area_lights.push_back(al);
    return uint32_t(s.area_lights.size() - 1);
}

void build_power_table(std::vector<AreaLight>& lights) {
    auto power = [](const AreaLight& l) {
        return double(0.2126f * l.radiance.x + 0.7152f * l.radiance.y + 0.0722f * l.radiance.z) * l.area *
               (l.double_sided ? 2.0 : 1.0);
    };
    double total_power = 0.0;
    for (const AreaLight& l : lights) total_power += power(l);
    double running = 0.0;
    for (AreaLight& l : lights) {
        const double share = total_power > 0.0 ? power(l) / total_power : 1.0 / double(lights.size());
        running += share;
        l.power_pmf = float(share);
        l.power_cdf = float(running);
    }
    if (!lights.empty()) lights.back().power_cdf = 1.f;
}

void report_lights(const SceneDescription& desc, const RenderScene& s, BuildReport& report) {
    for (const SphereDesc& sd : desc.spheres)
        if (sd.material >= 0 && s.materials[size_t(sd.material)].emissive())
            report.warnings.push_back("emissive sphere at " + sd.origin.str() + " is not a light yet; its emission is ignored");
    if (!s.has_lights()) {
        report.left_out.push_back("light sampling and shadow rays: the scene has no lights or emitters");
        report.warnings.push_back("the scene has no lights or emitters: a path-traced render shows only emitters, "
                                  "so it will be black");
    } else {
        report.built.push_back("lights: " + std::to_string(s.area_lights.size()) + " area, " +
                               std::to_string(s.delta_lights.size()) + " delta" + (s.has_sky ? ", sky" : ""));
    }
}

}  // namespace tessera
