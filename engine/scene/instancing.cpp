#include "engine/scene/instancing.h"

#include <cmath>
#include <utility>

namespace tessera {

MeshDesc placed_mesh(const MeshDesc& prototype, const glm::mat4& to_world) {
    MeshDesc out = prototype;
    const glm::dmat4 m(to_world);
    const glm::dmat3 linear(m);
    const glm::dmat3 normal_matrix = glm::transpose(glm::inverse(linear));
    for (glm::vec3& p : out.positions) p = glm::vec3(m * glm::dvec4(p, 1.0));
    for (glm::vec3& n : out.normals) {
        const glm::dvec3 w = normal_matrix * glm::dvec3(n);
        const double len = glm::length(w);
        if (!(len > 1e-30) || !std::isfinite(len)) {
            out.normals.clear();  // shaded with geometric normals, as the loader does
            break;
        }
        n = glm::vec3(w / len);
    }
    const bool mirrored = glm::determinant(linear) < 0.0;
    for (glm::vec4& t : out.tangents) {
        const glm::dvec3 w = linear * glm::dvec3(t);
        const double len = glm::length(w);
        const float sign = (t.w < 0.f ? -1.f : 1.f) * (mirrored ? -1.f : 1.f);
        t = len > 1e-30 && std::isfinite(len) ? glm::vec4(glm::vec3(w / len), sign) : glm::vec4(0.f);
    }
    if (mirrored)
        for (size_t i = 0; i + 2 < out.indices.size(); i += 3) std::swap(out.indices[i + 1], out.indices[i + 2]);
    return out;
}

void flatten_instances(SceneDescription& scene, const std::function<bool(const InstanceDesc&)>& which) {
    std::vector<InstanceDesc> kept;
    for (const InstanceDesc& in : scene.instances) {
        if (which && !which(in)) {
            kept.push_back(in);
            continue;
        }
        MeshDesc placed = placed_mesh(scene.prototypes[in.prototype], in.to_world);
        placed.origin = in.origin;
        scene.meshes.push_back(std::move(placed));
    }
    scene.instances = std::move(kept);
}

Aabb transformed_bounds(const Aabb& box, const glm::mat4& to_world) {
    Aabb out;
    if (box.empty()) return out;
    for (int c = 0; c < 8; ++c) {
        const glm::vec3 p(c & 1 ? box.hi.x : box.lo.x, c & 2 ? box.hi.y : box.lo.y, c & 4 ? box.hi.z : box.lo.z);
        out.expand(glm::vec3(to_world * glm::vec4(p, 1.f)));
    }
    return out;
}

Aabb scene_bounds(const SceneDescription& scene) {
    Aabb b;
    for (const MeshDesc& m : scene.meshes)
        for (const glm::vec3& p : m.positions) b.expand(p);
    std::vector<Aabb> proto(scene.prototypes.size());
    for (size_t k = 0; k < scene.prototypes.size(); ++k)
        for (const glm::vec3& p : scene.prototypes[k].positions) proto[k].expand(p);
    for (const InstanceDesc& in : scene.instances) b.expand(transformed_bounds(proto[in.prototype], in.to_world));
    for (const SphereDesc& s : scene.spheres) {
        b.expand(s.center - glm::vec3(s.radius));
        b.expand(s.center + glm::vec3(s.radius));
    }
    return b;
}

}  // namespace tessera
