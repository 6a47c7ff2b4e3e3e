#include "engine/io/gltf_writer.h"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <map>
#include <stdexcept>

#include <nlohmann/json.hpp>
#include "engine/scene/instancing.h"

namespace tessera {
namespace {

using nlohmann::json;

std::string base64(const std::vector<unsigned char>& in) {
    static const char* tbl = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve((in.size() + 2) / 3 * 4);
    for (size_t i = 0; i < in.size(); i += 3) {
        const uint32_t b = (uint32_t(in[i]) << 16) | (i + 1 < in.size() ? uint32_t(in[i + 1]) << 8 : 0) |
                           (i + 2 < in.size() ? uint32_t(in[i + 2]) : 0);
        out += tbl[(b >> 18) & 63];
        out += tbl[(b >> 12) & 63];
        out += i + 1 < in.size() ? tbl[(b >> 6) & 63] : '=';
        out += i + 2 < in.size() ? tbl[b & 63] : '=';
    }
    return out;
}

MeshDesc icosphere(const SphereDesc& s, int subdivisions) {
    const float t = (1.f + std::sqrt(5.f)) / 2.f;
    std::vector<glm::vec3> p = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                                {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
    for (auto& v : p) v = glm::normalize(v);
    std::vector<uint32_t> f = {0, 11, 5, 0, 5, 1, 0, 1, 7, 0, 7, 10, 0, 10, 11, 1, 5, 9, 5, 11, 4, 11, 10, 2, 10, 7, 6, 7, 1, 8,
                               3, 9, 4, 3, 4, 2, 3, 2, 6, 3, 6, 8, 3, 8, 9, 4, 9, 5, 2, 4, 11, 6, 2, 10, 8, 6, 7, 9, 8, 1};
    for (int l = 0; l < subdivisions; ++l) {
        std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
        auto m = [&](uint32_t a, uint32_t b) {
            const auto key = a < b ? std::pair{a, b} : std::pair{b, a};
            if (auto it = mid.find(key); it != mid.end()) return it->second;
            p.push_back(glm::normalize(p[a] + p[b]));
            return mid[key] = uint32_t(p.size() - 1);
        };
        std::vector<uint32_t> g;
        for (size_t i = 0; i < f.size(); i += 3) {
            const uint32_t a = f[i], b = f[i + 1], c = f[i + 2], ab = m(a, b), bc = m(b, c), ca = m(c, a);
            g.insert(g.end(), {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca});
        }
        f.swap(g);
    }
    MeshDesc mesh;
    mesh.name = "sphere";
    for (const auto& v : p) {
        mesh.positions.push_back(s.center + s.radius * v);
        mesh.normals.push_back(v);
    }
    mesh.indices = std::move(f);
    mesh.material = s.material;
    return mesh;
}

}  // namespace

std::string to_gltf(const SceneDescription& scene, int sphere_subdivisions) {
    std::vector<MeshDesc> meshes = scene.meshes;
    for (const InstanceDesc& in : scene.instances) meshes.push_back(placed_mesh(scene.prototypes[in.prototype], in.to_world));
    for (const SphereDesc& s : scene.spheres) meshes.push_back(icosphere(s, sphere_subdivisions));
    std::vector<unsigned char> buf;
    auto append = [&](const void* data, size_t n) {
        while (buf.size() % 4) buf.push_back(0);
        const size_t off = buf.size();
        buf.resize(off + n);
        std::memcpy(buf.data() + off, data, n);
        return off;
    };
    json j;
    j["asset"] = {{"version", "2.0"}, {"generator", "tessera generate"}};
    j["extensionsUsed"] = json::array();
    json materials = json::array(), gmeshes = json::array(), nodes = json::array(), views = json::array(), accessors = json::array();
    bool emissive_strength = false, lights_used = false;
    for (const MaterialDesc& m : scene.materials) {
        json jm = {{"name", m.name},
                   {"pbrMetallicRoughness", {{"baseColorFactor", {m.albedo.x, m.albedo.y, m.albedo.z, 1.0}},
                                             {"metallicFactor", 0.0}, {"roughnessFactor", 1.0}}},
                   {"doubleSided", m.double_sided}};
        if (m.kind == MaterialKind::metallic_roughness) {
            jm["pbrMetallicRoughness"]["metallicFactor"] = m.metallic;
            jm["pbrMetallicRoughness"]["roughnessFactor"] = m.roughness;
            if (m.ior != 1.5f) jm["extensions"]["KHR_materials_ior"] = {{"ior", m.ior}};
            if (m.specular != 1.f) jm["extensions"]["KHR_materials_specular"] = {{"specularFactor", m.specular}};
        } else {
            // Lambertian: glTF's default dielectric layer is turned off.
            jm["extensions"]["KHR_materials_specular"] = {{"specularFactor", 0.0}};
        }
        const float peak = std::max(m.emission.x, std::max(m.emission.y, m.emission.z));
        if (peak > 0.f) {
            jm["emissiveFactor"] = {m.emission.x / peak, m.emission.y / peak, m.emission.z / peak};
            if (peak != 1.f) {
                jm["extensions"]["KHR_materials_emissive_strength"] = {{"emissiveStrength", peak}};
                emissive_strength = true;
            }
        }
        materials.push_back(jm);
    }
    for (const MeshDesc& m : meshes) {
        json attrs;
        glm::vec3 lo(INFINITY), hi(-INFINITY);
        for (const auto& p : m.positions) { lo = glm::min(lo, p); hi = glm::max(hi, p); }
        size_t off = append(m.positions.data(), m.positions.size() * sizeof(glm::vec3));
        views.push_back({{"buffer", 0}, {"byteOffset", off}, {"byteLength", m.positions.size() * sizeof(glm::vec3)}});
        accessors.push_back({{"bufferView", views.size() - 1}, {"componentType", 5126}, {"count", m.positions.size()},
                             {"type", "VEC3"}, {"min", {lo.x, lo.y, lo.z}}, {"max", {hi.x, hi.y, hi.z}}});
        attrs["POSITION"] = accessors.size() - 1;
        if (!m.normals.empty()) {
            off = append(m.normals.data(), m.normals.size() * sizeof(glm::vec3));
            views.push_back({{"buffer", 0}, {"byteOffset", off}, {"byteLength", m.normals.size() * sizeof(glm::vec3)}});
            accessors.push_back({{"bufferView", views.size() - 1}, {"componentType", 5126}, {"count", m.normals.size()}, {"type", "VEC3"}});
            attrs["NORMAL"] = accessors.size() - 1;
        }
        off = append(m.indices.data(), m.indices.size() * sizeof(uint32_t));
        views.push_back({{"buffer", 0}, {"byteOffset", off}, {"byteLength", m.indices.size() * sizeof(uint32_t)}});
        accessors.push_back({{"bufferView", views.size() - 1}, {"componentType", 5125}, {"count", m.indices.size()}, {"type", "SCALAR"}});
        json prim = {{"attributes", attrs}, {"indices", accessors.size() - 1}, {"mode", 4}};
        if (m.material >= 0) prim["material"] = m.material;
        gmeshes.push_back({{"name", m.name}, {"primitives", {prim}}});
        nodes.push_back({{"name", m.name}, {"mesh", gmeshes.size() - 1}});
    }
    json lights = json::array();
    for (const LightDesc& l : scene.lights) {
        if (l.kind != LightKind::point && l.kind != LightKind::directional) continue;  // glTF has no area or sky light
        const float peak = std::max(l.radiance.x, std::max(l.radiance.y, l.radiance.z));
        if (!(peak > 0.f)) continue;
        lights.push_back({{"type", l.kind == LightKind::point ? "point" : "directional"},
                          {"color", {l.radiance.x / peak, l.radiance.y / peak, l.radiance.z / peak}}, {"intensity", peak}});
        json node = {{"extensions", {{"KHR_lights_punctual", {{"light", lights.size() - 1}}}}}};
        if (l.kind == LightKind::point) node["translation"] = {l.position.x, l.position.y, l.position.z};
        else {
            // Rotate −Z onto the light's direction.
            const glm::vec3 from(0, 0, -1), to = glm::normalize(l.direction);
            const glm::vec3 axis = glm::cross(from, to);
            const float w = 1.f + glm::dot(from, to);
            glm::vec4 q = w > 1e-6f ? glm::vec4(axis, w) : glm::vec4(1, 0, 0, 0);
            q /= glm::length(q);
            node["rotation"] = {q.x, q.y, q.z, q.w};
        }
        nodes.push_back(node);
        lights_used = true;
    }
    if (scene.camera) {
        const CameraDesc& c = *scene.camera;
        const float aspect = std::tan(glm::radians(c.hfov_deg) / 2) / std::tan(glm::radians(c.vfov_deg) / 2);
        j["cameras"] = {{{"type", "perspective"},
                         {"perspective", {{"yfov", glm::radians(c.vfov_deg)}, {"aspectRatio", aspect}, {"znear", std::max(c.znear, 1e-6f)}, {"zfar", c.zfar}}}}};
        const glm::vec3 f = glm::normalize(c.look_at - c.position), r = glm::normalize(glm::cross(f, c.up)), u = glm::cross(r, f);
        nodes.push_back({{"name", "camera"}, {"camera", 0},
                         {"matrix", {r.x, r.y, r.z, 0, u.x, u.y, u.z, 0, -f.x, -f.y, -f.z, 0, c.position.x, c.position.y, c.position.z, 1}}});
    }
    if (emissive_strength) j["extensionsUsed"].push_back("KHR_materials_emissive_strength");
    for (const char* ext : {"KHR_materials_specular", "KHR_materials_ior"})
        if (std::any_of(materials.begin(), materials.end(), [&](const json& jm) { return jm.contains("extensions") && jm["extensions"].contains(ext); }))
            j["extensionsUsed"].push_back(ext);
    if (lights_used) {
        j["extensionsUsed"].push_back("KHR_lights_punctual");
        j["extensions"]["KHR_lights_punctual"]["lights"] = lights;
    }
    if (j["extensionsUsed"].empty()) j.erase("extensionsUsed");
    json scene_nodes = json::array();
    for (size_t i = 0; i < nodes.size(); ++i) scene_nodes.push_back(i);
    j["scene"] = 0;
    j["scenes"] = {{{"nodes", scene_nodes}}};
    j["nodes"] = nodes;
    j["meshes"] = gmeshes;
    j["materials"] = materials;
    j["accessors"] = accessors;
    j["bufferViews"] = views;
    j["buffers"] = {{{"byteLength", buf.size()}, {"uri", gltf_data_uri(buf)}}};
    return j.dump(1);
}

void write_gltf(const std::string& path, const SceneDescription& scene, int sphere_subdivisions) {
    std::ofstream out(path, std::ios::binary);
    if (!out) throw std::runtime_error(path + ": cannot open for writing");
    out << to_gltf(scene, sphere_subdivisions);
    if (!out) throw std::runtime_error(path + ": write failed");
}

std::string gltf_data_uri(const std::vector<unsigned char>& bytes) {
    return "data:application/octet-stream;base64," + base64(bytes);
}

}  // namespace tessera
