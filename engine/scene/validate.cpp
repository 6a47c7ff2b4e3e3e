#include <cmath>
#include <string>

#include "engine/geometry/aabb.h"
#include "engine/scene/scene_description.h"

namespace tessera {
namespace {

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
bool finite(const glm::vec2& v) { return std::isfinite(v.x) && std::isfinite(v.y); }
bool finite(const glm::vec4& v) { return finite(glm::vec3(v)) && std::isfinite(v.w); }

// A per-vertex array is empty or pairs with positions, with finite entries.
template <class T>
void check_vertex_array(const MeshDesc& mesh, const std::vector<T>& a, const char* what) {
    if (a.empty()) return;
    if (a.size() != mesh.positions.size())
        throw SceneError(mesh.origin, "mesh '" + mesh.name + "' has " + std::to_string(a.size()) + " " + what + " for " +
                                          std::to_string(mesh.positions.size()) + " vertices");
    for (size_t i = 0; i < a.size(); ++i)
        if (!finite(a[i])) throw SceneError(mesh.origin, "mesh '" + mesh.name + "' " + what + " " + std::to_string(i) + " is not finite");
}

std::string vec_str(const glm::vec3& v) {
    return "(" + std::to_string(v.x) + ", " + std::to_string(v.y) + ", " + std::to_string(v.z) + ")";
}

}  // namespace

void validate(const SceneDescription& scene) {
    const int nmat = static_cast<int>(scene.materials.size());
    for (const auto& img : scene.images)
        if (!img || img->width <= 0 || img->height <= 0 ||
            img->rgba.size() != 4 * size_t(img->width) * size_t(img->height))
            throw SceneError(SourceLocation{scene.source, 0, ""}, "an image's texels do not match its size");
    for (const auto& t : scene.textures)
        if (t.image >= scene.images.size())
            throw SceneError(SourceLocation{scene.source, 0, ""}, "a texture refers to image " + std::to_string(t.image) +
                                                                     " of " + std::to_string(scene.images.size()));
    for (const auto& m : scene.materials) {
        for (const TextureSlot* slot : {&m.base_color_tex, &m.metallic_roughness_tex, &m.emissive_tex, &m.normal_tex}) {
            if (slot->texture >= int(scene.textures.size()) || slot->texture < -1 || slot->texcoord > 1)
                throw SceneError(m.origin, "material '" + m.name + "' refers to texture " + std::to_string(slot->texture) +
                                               " (coordinate set " + std::to_string(slot->texcoord) + ") of " +
                                               std::to_string(scene.textures.size()));
            if (!finite(slot->row_u) || !finite(slot->row_v) || !std::isfinite(slot->scale))
                throw SceneError(m.origin, "material '" + m.name + "' has a non-finite texture transform");
        }
        if (!std::isfinite(m.alpha) || !std::isfinite(m.alpha_cutoff) || m.alpha < 0 || m.alpha_cutoff < 0)
            throw SceneError(m.origin, "material '" + m.name + "' has an alpha or alpha cutoff that is negative or not finite");
        if (!finite(m.albedo) || !finite(m.emission) || !finite(m.transmittance) || !std::isfinite(m.ior) ||
            !std::isfinite(m.roughness) || !finite(m.eta) || !finite(m.k) || !std::isfinite(m.metallic) ||
            !std::isfinite(m.specular) || !std::isfinite(m.shininess))
            throw SceneError(m.origin, "material '" + m.name + "' has a non-finite parameter");
        if (!(m.ior > 0.f))
            throw SceneError(m.origin, "material '" + m.name + "' has index of refraction " + std::to_string(m.ior) + ", not > 0");
        if (m.transmittance.x < 0 || m.transmittance.y < 0 || m.transmittance.z < 0 || m.eta.x < 0 || m.eta.y < 0 ||
            m.eta.z < 0 || m.k.x < 0 || m.k.y < 0 || m.k.z < 0 || m.roughness < 0 || m.metallic < 0 || m.metallic > 1 ||
            m.specular < 0 || m.shininess < 0)
            throw SceneError(m.origin, "material '" + m.name + "' has a parameter out of its range (transmittance, eta, k, "
                                       "roughness, specular and shininess >= 0; metallic in [0, 1])");
        if (m.emission.x < 0 || m.emission.y < 0 || m.emission.z < 0)
            throw SceneError(m.origin, "material '" + m.name + "' has negative emission " + vec_str(m.emission));
        if (m.albedo.x < 0 || m.albedo.y < 0 || m.albedo.z < 0)
            throw SceneError(m.origin, "material '" + m.name + "' has negative albedo " + vec_str(m.albedo));
    }
    auto check_mesh = [&](const MeshDesc& mesh) {
        if (mesh.indices.size() % 3 != 0)
            throw SceneError(mesh.origin, "mesh '" + mesh.name + "' has " + std::to_string(mesh.indices.size()) +
                                              " indices, not a multiple of 3");
        if (mesh.material < -1 || mesh.material >= nmat)
            throw SceneError(mesh.origin, "mesh '" + mesh.name + "' refers to material " + std::to_string(mesh.material) +
                                              " of " + std::to_string(nmat));
        for (size_t i = 0; i < mesh.positions.size(); ++i)
            if (!finite(mesh.positions[i]))
                throw SceneError(mesh.origin, "mesh '" + mesh.name + "' vertex " + std::to_string(i) +
                                                  " has a non-finite position " + vec_str(mesh.positions[i]));
        if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size())
            throw SceneError(mesh.origin, "mesh '" + mesh.name + "' has " + std::to_string(mesh.normals.size()) +
                                              " normals for " + std::to_string(mesh.positions.size()) + " vertices");
        for (size_t i = 0; i < mesh.normals.size(); ++i)
            if (!finite(mesh.normals[i]))
                throw SceneError(mesh.origin, "mesh '" + mesh.name + "' normal " + std::to_string(i) + " is not finite");
        check_vertex_array(mesh, mesh.uv[0], "texture coordinates (set 0)");
        check_vertex_array(mesh, mesh.uv[1], "texture coordinates (set 1)");
        check_vertex_array(mesh, mesh.colors, "vertex colours");
        check_vertex_array(mesh, mesh.tangents, "tangents");
        for (size_t i = 0; i < mesh.indices.size(); ++i)
            if (mesh.indices[i] >= mesh.positions.size())
                throw SceneError(mesh.origin, "mesh '" + mesh.name + "' index " + std::to_string(i) + " = " +
                                                  std::to_string(mesh.indices[i]) + " is out of range (" +
                                                  std::to_string(mesh.positions.size()) + " vertices)");
    };
    for (const auto& mesh : scene.meshes) check_mesh(mesh);
    for (const auto& mesh : scene.prototypes) check_mesh(mesh);
    std::vector<Aabb> prototype_bounds(scene.prototypes.size());
    for (size_t k = 0; k < scene.prototypes.size(); ++k)
        for (const glm::vec3& p : scene.prototypes[k].positions) prototype_bounds[k].expand(p);
    for (size_t k = 0; k < scene.instances.size(); ++k) {
        const InstanceDesc& in = scene.instances[k];
        const std::string what = "instance " + std::to_string(k);
        if (in.prototype >= scene.prototypes.size())
            throw SceneError(in.origin, what + " places prototype " + std::to_string(in.prototype) + " of " +
                                            std::to_string(scene.prototypes.size()));
        const glm::mat4& m = in.to_world;
        for (int c = 0; c < 4; ++c)
            if (!finite(glm::vec3(m[c])) || !std::isfinite(m[c][3]))
                throw SceneError(in.origin, what + " has a non-finite transform");
        if (m[0][3] != 0.f || m[1][3] != 0.f || m[2][3] != 0.f || m[3][3] != 1.f)
            throw SceneError(in.origin, what + " has a projective transform (its bottom row must be 0 0 0 1)");
        // Singular (or so nearly that its inverse overflows): rays cannot be taken into the
        // mesh's space, and the placed mesh would be flat.
        const glm::dmat3 l(m);
        const double det = glm::determinant(l);
        const glm::dmat3 inv = det != 0.0 ? glm::inverse(l) : glm::dmat3(0.0);
        bool ok = det != 0.0 && std::isfinite(det);
        for (int c = 0; c < 3 && ok; ++c)
            for (int r = 0; r < 3; ++r) ok &= std::abs(inv[c][r]) < 1e30;
        if (!ok) throw SceneError(in.origin, what + " has a singular transform (no inverse)");
        // Placed, every vertex must stay finite in single precision: an affine map takes the
        // prototype's box to a parallelepiped spanned by the images of its corners.
        const std::vector<Aabb>& boxes = prototype_bounds;
        for (int corner = 0; corner < 8; ++corner) {
            const Aabb& b = boxes[in.prototype];
            if (b.empty()) break;
            const glm::vec3 p(corner & 1 ? b.hi.x : b.lo.x, corner & 2 ? b.hi.y : b.lo.y, corner & 4 ? b.hi.z : b.lo.z);
            if (!finite(glm::vec3(m * glm::vec4(p, 1.f))))
                throw SceneError(in.origin, what + " places prototype '" + scene.prototypes[in.prototype].name +
                                                "' outside the finite range");
        }
    }
    for (const auto& s : scene.spheres) {
        if (!finite(s.center) || !std::isfinite(s.radius) || !(s.radius > 0))
            throw SceneError(s.origin, "sphere needs a finite centre and a positive radius (centre " + vec_str(s.center) +
                                           ", radius " + std::to_string(s.radius) + ")");
        if (s.material < -1 || s.material >= nmat)
            throw SceneError(s.origin, "sphere refers to material " + std::to_string(s.material));
    }
    for (const auto& l : scene.lights) {
        if (!finite(l.radiance) || !finite(l.position) || !finite(l.direction) || !finite(l.dim_x) || !finite(l.dim_y))
            throw SceneError(l.origin, "light has a non-finite parameter");
        if (l.radiance.x < 0 || l.radiance.y < 0 || l.radiance.z < 0)
            throw SceneError(l.origin, "light has negative radiance " + vec_str(l.radiance));
    }
    if (scene.camera) {
        const auto& c = *scene.camera;
        if (!finite(c.position) || !finite(c.look_at) || !finite(c.up) || !std::isfinite(c.hfov_deg) ||
            !std::isfinite(c.vfov_deg) || !std::isfinite(c.znear) || !std::isfinite(c.zfar) || !std::isfinite(c.focal_px))
            throw SceneError(c.origin, "camera has a non-finite parameter");
        if (!(c.hfov_deg > 0 && c.hfov_deg < 180 && c.vfov_deg > 0 && c.vfov_deg < 180))
            throw SceneError(c.origin, "camera field of view must lie in (0, 180) degrees");
        if (!(c.znear >= 0 && c.zfar > c.znear))
            throw SceneError(c.origin, "camera clip range must satisfy 0 <= near < far");
    }
}

}  // namespace tessera
