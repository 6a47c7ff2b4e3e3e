#include "engine/scene/surface_textures.h"

#include <algorithm>
#include <bit>
#include <cmath>

namespace tessera {
namespace {

template <class T>
T interpolate(const LargeVector<T>& a, const TriangleShading& sh, float b1, float b2) {
    return (1.f - b1 - b2) * a[sh.n0] + b1 * a[sh.n1] + b2 * a[sh.n2];
}

glm::vec4 lookup(const RenderScene& s, const TextureSlot& slot, const TriangleShading& sh, float b1, float b2, bool srgb) {
    const LargeVector<glm::vec2>& uv = s.uv[slot.texcoord];
    const glm::vec2 st = uv.empty() ? glm::vec2(0.f) : slot.map(interpolate(uv, sh, b1, b2));
    const Texture& t = s.textures[size_t(slot.texture)];
    return texture_lookup(*s.images[t.image], t, st, srgb);
}

uint32_t bits(float f) { return std::bit_cast<uint32_t>(f); }

// A well-mixed 64-bit hash (SplitMix64's finaliser) of the ray and the triangle, as [0, 1).
float hash_float(const Ray& r, uint32_t prim) {
    uint64_t h = 0x9E3779B97F4A7C15ull * (uint64_t(prim) + 1);
    for (float f : {r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z}) {
        h ^= bits(f) + 0x9E3779B97F4A7C15ull + (h << 6) + (h >> 2);
        h = (h ^ (h >> 30)) * 0xBF58476D1CE4E5B9ull;
        h = (h ^ (h >> 27)) * 0x94D049BB133111EBull;
        h ^= h >> 31;
    }
    return float(h >> 40) * 0x1p-24f;
}

// The direction of increasing u and of increasing v on a triangle, from its positions and
// (mapped) texture coordinates; false where the coordinates are degenerate.
bool uv_directions(const glm::vec3 p[3], const glm::vec2 uv[3], glm::vec3& dpdu, glm::vec3& dpdv) {
    const glm::vec3 e1 = p[1] - p[0], e2 = p[2] - p[0];
    const glm::vec2 d1 = uv[1] - uv[0], d2 = uv[2] - uv[0];
    const float det = d1.x * d2.y - d2.x * d1.y;
    if (!(std::abs(det) > 1e-20f) || !std::isfinite(det)) return false;
    dpdu = (e1 * d2.y - e2 * d1.y) / det;
    dpdv = (e2 * d1.x - e1 * d2.x) / det;
    return std::isfinite(glm::dot(dpdu, dpdu)) && std::isfinite(glm::dot(dpdv, dpdv));
}

float corner_angle(const glm::vec3& a, const glm::vec3& b) {
    const float la = glm::length(a), lb = glm::length(b);
    if (!(la > 0.f && lb > 0.f)) return 0.f;
    return std::acos(std::clamp(glm::dot(a, b) / (la * lb), -1.f, 1.f));
}

// Tangents for one mesh that has none, into s.tangents from `base`.
void generate_tangents(const MeshDesc& mesh, const TextureSlot& slot, size_t base, RenderScene& s) {
    const std::vector<glm::vec2>& uv = mesh.uv[slot.texcoord];
    if (uv.empty()) return;  // zero tangents: the normal map is not applied
    const size_t nv = mesh.positions.size();
    std::vector<glm::vec3> tan(nv, glm::vec3(0.f)), up(nv, glm::vec3(0.f)), face_n(nv, glm::vec3(0.f));
    for (size_t i = 0; i + 2 < mesh.indices.size(); i += 3) {
        const uint32_t v[3] = {mesh.indices[i], mesh.indices[i + 1], mesh.indices[i + 2]};
        const glm::vec3 p[3] = {mesh.positions[v[0]], mesh.positions[v[1]], mesh.positions[v[2]]};
        const glm::vec2 t[3] = {slot.map(uv[v[0]]), slot.map(uv[v[1]]), slot.map(uv[v[2]])};
        glm::vec3 dpdu, dpdv;
        if (!uv_directions(p, t, dpdu, dpdv)) continue;
        const glm::vec3 fn = glm::cross(p[1] - p[0], p[2] - p[0]);
        for (int c = 0; c < 3; ++c) {
            const float w = corner_angle(p[(c + 1) % 3] - p[c], p[(c + 2) % 3] - p[c]);
            const glm::vec3 n = s.normals[base + v[c]] != glm::vec3(0.f) ? s.normals[base + v[c]] : glm::normalize(fn);
            glm::vec3 tu = dpdu - n * glm::dot(n, dpdu);
            const float len = glm::length(tu);
            if (!(len > 0.f)) continue;
            tan[v[c]] += tu * (w / len);
            up[v[c]] += -dpdv * (w / std::max(glm::length(dpdv), 1e-30f));
            face_n[v[c]] += fn;
        }
    }
    for (size_t k = 0; k < nv; ++k) {
        glm::vec3 n = s.normals[base + k];
        if (n == glm::vec3(0.f)) {
            const float l = glm::length(face_n[k]);
            if (!(l > 0.f)) continue;
            n = face_n[k] / l;
        }
        glm::vec3 t = tan[k] - n * glm::dot(n, tan[k]);
        const float len = glm::length(t);
        if (!(len > 0.f) || !std::isfinite(len)) continue;
        t /= len;
        s.tangents[base + k] = glm::vec4(t, glm::dot(glm::cross(n, t), up[k]) < 0.f ? -1.f : 1.f);
    }
}

}  // namespace

void gather_vertex_attributes(const std::vector<const MeshDesc*>& meshes, std::span<const size_t> first_vertex,
                              RenderScene& s) {
    if (s.material_textures.empty()) return;
    bool need_uv[2] = {false, false}, need_colors = false, need_tangents = false;
    for (const MaterialTextures& mt : s.material_textures) {
        for (const TextureSlot* t : {&mt.base_color, &mt.metallic_roughness, &mt.emissive, &mt.normal})
            if (t->used()) need_uv[t->texcoord] = true;
        need_colors |= mt.vertex_colors;
        need_tangents |= mt.normal.used();
    }
    const size_t nv = first_vertex[meshes.size()];
    for (int set = 0; set < 2; ++set)
        if (need_uv[set]) s.uv[set].resize(nv, glm::vec2(0.f));
    if (need_colors) s.colors.resize(nv, glm::vec4(1.f));
    if (need_tangents) s.tangents.resize(nv, glm::vec4(0.f));
    size_t generated = 0;
    for (size_t k = 0; k < meshes.size(); ++k) {
        const MeshDesc& mesh = *meshes[k];
        const size_t base = first_vertex[k];
        for (int set = 0; set < 2; ++set)
            if (need_uv[set] && mesh.uv[set].size() == mesh.positions.size())
                std::copy(mesh.uv[set].begin(), mesh.uv[set].end(), s.uv[set].data() + base);
        if (need_colors && mesh.colors.size() == mesh.positions.size())
            std::copy(mesh.colors.begin(), mesh.colors.end(), s.colors.data() + base);
        if (!need_tangents || mesh.material < 0) continue;
        const Material& m = s.materials[size_t(mesh.material)];
        if (m.textures == kNoTextures || !s.material_textures[m.textures].normal.used()) continue;
        if (mesh.tangents.size() == mesh.positions.size()) {
            std::copy(mesh.tangents.begin(), mesh.tangents.end(), s.tangents.data() + base);
        } else {
            generate_tangents(mesh, s.material_textures[m.textures].normal, base, s);
            ++generated;
        }
    }
    std::string arrays;
    if (need_uv[0]) arrays += "texture coordinates 0, ";
    if (need_uv[1]) arrays += "texture coordinates 1, ";
    if (need_colors) arrays += "vertex colours, ";
    if (need_tangents) arrays += "tangents (" + std::to_string(generated) + " mesh(es) generated), ";
    if (!arrays.empty()) s.report.built.push_back("vertex attributes: " + arrays.substr(0, arrays.size() - 2));
}

float surface_alpha(const RenderScene& s, const MaterialTextures& mt, uint32_t prim, float b1, float b2) {
    const TriangleShading& sh = s.tri_shading[prim];
    float a = mt.alpha;
    if (mt.base_color.used()) a *= lookup(s, mt.base_color, sh, b1, b2, true).w;
    if (mt.vertex_colors) a *= interpolate(s.colors, sh, b1, b2).w;
    return a;
}

bool alpha_passes(const RenderScene& s, const Ray& ray, uint32_t prim, float b1, float b2) {
    const Material& m = s.materials[s.tri_shading[prim].material];
    if (m.textures == kNoTextures) return true;
    const MaterialTextures& mt = s.material_textures[m.textures];
    if (mt.alpha_mode == AlphaMode::opaque) return true;
    const float a = surface_alpha(s, mt, prim, b1, b2);
    if (mt.alpha_mode == AlphaMode::mask) return a >= mt.alpha_cutoff;
    if (a >= 1.f) return true;
    if (a <= 0.f) return false;
    return hash_float(ray, prim) < a;
}

void apply_textures(const RenderScene& s, const MaterialTextures& mt, uint32_t prim, float b1, float b2, Bsdf& bsdf,
                    glm::vec3& ns, const glm::vec3& ng, uint32_t instance) {
    const TriangleShading& sh = s.tri_shading[prim];
    if (mt.base_color.used()) bsdf.albedo *= glm::vec3(lookup(s, mt.base_color, sh, b1, b2, true));
    if (mt.vertex_colors) bsdf.albedo *= glm::vec3(interpolate(s.colors, sh, b1, b2));
    if (mt.metallic_roughness.used() && bsdf.kind == BsdfKind::metallic_roughness) {
        // glTF: roughness in green, metallic in blue; the factors (already in bsdf) multiply them.
        const glm::vec4 t = lookup(s, mt.metallic_roughness, sh, b1, b2, false);
        const float roughness = std::sqrt(bsdf.alpha) * t.y;
        bsdf.alpha = roughness * roughness;  // below kSmoothAlpha: a delta lobe
        bsdf.metallic = std::clamp(bsdf.metallic * t.z, 0.f, 1.f);
    }
    if (mt.normal.used() && !s.tangents.empty()) {
        glm::vec4 t4 = interpolate(s.tangents, sh, b1, b2);
        if (instance != kNoInstance) {
            // A prototype's tangent, placed as placed_mesh places it (a mirror flips the side).
            const glm::mat3 l(s.instances[instance].to_world);
            t4 = glm::vec4(l * glm::vec3(t4), glm::determinant(l) < 0.f ? -t4.w : t4.w);
        }
        glm::vec3 t(t4);
        t -= ns * glm::dot(ns, t);
        const float tl = glm::length(t);
        if (!(tl > 1e-6f)) return;  // no tangent here (degenerate coordinates): the map is not applied
        t /= tl;
        const glm::vec3 b = glm::cross(ns, t) * (t4.w < 0.f ? -1.f : 1.f);
        const glm::vec4 c = lookup(s, mt.normal, sh, b1, b2, false);
        const glm::vec3 m((2.f * c.x - 1.f) * mt.normal.scale, (2.f * c.y - 1.f) * mt.normal.scale, 2.f * c.z - 1.f);
        glm::vec3 n = m.x * t + m.y * b + m.z * ns;
        const float nl = glm::length(n);
        if (!(nl > 1e-6f) || !std::isfinite(nl)) return;
        n /= nl;
        ns = glm::dot(n, ng) < 0.f ? -n : n;
    }
}

glm::vec3 emission_at(const RenderScene& s, const Material& m, uint32_t prim, float b1, float b2) {
    if (m.textures == kNoTextures) return m.emission;
    const MaterialTextures& mt = s.material_textures[m.textures];
    if (!mt.emissive.used()) return m.emission;
    return m.emission * glm::vec3(lookup(s, mt.emissive, s.tri_shading[prim], b1, b2, true));
}

}  // namespace tessera
