#include "engine/scene/procedural.h"

#include "engine/scene/environment.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <unordered_map>
#include <utility>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/sampling/rng.h"

namespace tessera {
namespace {

SourceLocation here(const std::string& what) { return SourceLocation{"builtin:" + what, 0, ""}; }

int add_material(SceneDescription& s, const std::string& name, glm::vec3 albedo, glm::vec3 emission = glm::vec3(0.f)) {
    MaterialDesc m;
    m.name = name;
    m.albedo = albedo;
    m.emission = emission;
    m.kind = emission == glm::vec3(0.f) ? MaterialKind::diffuse : MaterialKind::emission;
    m.origin = here(name);
    s.materials.push_back(m);
    return int(s.materials.size()) - 1;
}

// A quad a, b, c, d (counter-clockwise seen from the side it faces).
void add_quad(SceneDescription& s, const std::string& name, int material, glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 d) {
    MeshDesc m;
    m.name = name;
    m.positions = {a, b, c, d};
    m.indices = {0, 1, 2, 0, 2, 3};
    m.flat_normals = true;
    m.material = material;
    m.origin = here(name);
    s.meshes.push_back(std::move(m));
}

}  // namespace

SceneDescription cornell_box() {
    SceneDescription s;
    s.source = "builtin:cornell_box";
    const int white = add_material(s, "white", glm::vec3(0.725f, 0.71f, 0.68f));
    const int red = add_material(s, "red", glm::vec3(0.63f, 0.065f, 0.05f));
    const int blue = add_material(s, "blue", glm::vec3(0.161f, 0.133f, 0.427f));
    const int lamp = add_material(s, "lamp", glm::vec3(0.f), glm::vec3(10.f));
    const float x0 = -1, x1 = 1, y0 = 0, y1 = 1.5f, z0 = -1, z1 = 1;
    add_quad(s, "floor", white, {x0, y0, z1}, {x1, y0, z1}, {x1, y0, z0}, {x0, y0, z0});
    add_quad(s, "ceiling", white, {x0, y1, z0}, {x1, y1, z0}, {x1, y1, z1}, {x0, y1, z1});
    add_quad(s, "back", white, {x0, y0, z0}, {x1, y0, z0}, {x1, y1, z0}, {x0, y1, z0});
    add_quad(s, "left", red, {x0, y0, z1}, {x0, y0, z0}, {x0, y1, z0}, {x0, y1, z1});
    add_quad(s, "right", blue, {x1, y0, z0}, {x1, y0, z1}, {x1, y1, z1}, {x1, y1, z0});
    const float ly = 1.49f;
    add_quad(s, "lamp", lamp, {-0.4f, ly, -0.3f}, {0.4f, ly, -0.3f}, {0.4f, ly, 0.3f}, {-0.4f, ly, 0.3f});
    CameraDesc c;
    c.position = {0.f, 0.75f, 3.6f};
    c.look_at = {0.f, 0.75f, 0.f};
    c.vfov_deg = 37.8f;
    c.hfov_deg = 49.1f;
    c.focal_px = 875.f;
    c.origin = here("camera");
    s.camera = c;
    return s;
}

SceneDescription cornell_spheres() {
    SceneDescription s = cornell_box();
    s.source = "builtin:cornell_spheres";
    const int white = 0;
    s.spheres.push_back({glm::vec3(-0.45f, 0.3f, -0.35f), 0.3f, white, here("sphere_left")});
    s.spheres.push_back({glm::vec3(0.45f, 0.25f, 0.2f), 0.25f, white, here("sphere_right")});
    return s;
}

SceneDescription cornell_glossy() {
    SceneDescription s = cornell_spheres();
    s.source = "builtin:cornell_glossy";
    MaterialDesc gold;
    gold.name = "rough_gold";
    gold.kind = MaterialKind::metallic_roughness;
    gold.albedo = glm::vec3(1.f, 0.78f, 0.34f);
    gold.metallic = 1.f;
    gold.roughness = 0.3f;
    gold.origin = here("rough_gold");
    s.materials.push_back(gold);
    s.spheres[0].material = int(s.materials.size()) - 1;
    MaterialDesc plastic;
    plastic.name = "glossy_plastic";
    plastic.kind = MaterialKind::metallic_roughness;
    plastic.albedo = glm::vec3(0.2f, 0.4f, 0.8f);
    plastic.roughness = 0.15f;
    plastic.origin = here("glossy_plastic");
    s.materials.push_back(plastic);
    s.spheres[1].material = int(s.materials.size()) - 1;
    return s;
}

SceneDescription lamp_room(int lamps) {
    SceneDescription s = many_lights(lamps);
    s.source = "builtin:lamp_room";
    return s;
}

SceneDescription many_lights(int lamps) {
    SceneDescription s = cornell_spheres();
    s.source = "builtin:many_lights";
    s.meshes.pop_back();  // the big lamp
    Pcg32 rng(11, 3);
    const int side = int(std::ceil(std::sqrt(double(lamps))));
    for (int i = 0; i < lamps; ++i) {
        const float x = -0.9f + 1.8f * (float(i % side) + 0.5f) / float(side);
        const float z = -0.9f + 1.8f * (float(i / side) + 0.5f) / float(side);
        const float radiance = 1.f * std::pow(100.f, rng.next_float());  // 1 to 100
        const int m = add_material(s, "lamp" + std::to_string(i), glm::vec3(0.f), glm::vec3(radiance));
        // Half a lamp's side: 4 cm, less where the grid is dense, so lamps never overlap (two
        // coplanar lamps over the same spot are a different scene to light and BSDF samples).
        const float h = std::min(0.04f, 0.35f * 1.8f / float(side)), y = 1.49f;
        add_quad(s, "lamp" + std::to_string(i), m, {x - h, y, z - h}, {x + h, y, z - h}, {x + h, y, z + h}, {x - h, y, z + h});
    }
    return s;
}

SceneDescription scattered_lights(int lamps) {
    SceneDescription s = cornell_spheres();
    s.source = "builtin:scattered_lights";
    s.meshes.pop_back();  // the big lamp
    Pcg32 rng(17, 5);
    for (int i = 0; i < lamps; ++i) {
        const glm::vec3 c(-0.9f + 1.8f * rng.next_float(), 0.05f + 1.4f * rng.next_float(), -0.9f + 1.8f * rng.next_float());
        const float z = 1.f - 2.f * rng.next_float(), phi = 6.2831853f * rng.next_float(), r = std::sqrt(std::max(0.f, 1.f - z * z));
        const glm::vec3 n(r * std::cos(phi), z, r * std::sin(phi));
        const glm::vec3 t = glm::normalize(std::abs(n.x) > 0.5f ? glm::cross(n, glm::vec3(0, 1, 0)) : glm::cross(n, glm::vec3(1, 0, 0)));
        const glm::vec3 b = glm::cross(n, t);
        const float h = 0.015f, radiance = std::pow(100.f, rng.next_float());  // 1 to 100
        const int m = add_material(s, "lamp" + std::to_string(i), glm::vec3(0.f), glm::vec3(radiance));
        s.materials[size_t(m)].double_sided = true;
        add_quad(s, "lamp" + std::to_string(i), m, c - h * t - h * b, c + h * t - h * b, c + h * t + h * b, c - h * t + h * b);
    }
    return s;
}

SceneDescription lamp_field(int lamps, bool blocks) {
    SceneDescription s;
    s.source = "builtin:lamp_field";
    const int ground = add_material(s, "ground", glm::vec3(0.6f));
    const int block = add_material(s, "block", glm::vec3(0.5f, 0.45f, 0.4f));
    const float half = 20.f;  // a 40 × 40 field
    add_quad(s, "ground", ground, {-half, 0, half}, {half, 0, half}, {half, 0, -half}, {-half, 0, -half});
    Pcg32 rng(23, 7);
    // Blocks on a jittered grid: geometry that hides most lamps from most points.
    for (int i = 0; i < 12; ++i)
        for (int j = 0; j < 12; ++j) {
            const float cx = -half + (i + 0.5f) * (2 * half / 12) + 0.8f * (rng.next_float() - 0.5f);
            const float cz = -half + (j + 0.5f) * (2 * half / 12) + 0.8f * (rng.next_float() - 0.5f);
            const float w = 0.4f + 0.5f * rng.next_float(), h = 0.5f + 2.5f * rng.next_float();
            const glm::vec3 lo(cx - w, 0.f, cz - w), hi(cx + w, h, cz + w);
            if (!blocks) continue;  // the same lamps either way: the rng has moved on alike
            const std::string name = "block" + std::to_string(i * 12 + j);
            add_quad(s, name, block, {lo.x, hi.y, hi.z}, {hi.x, hi.y, hi.z}, {hi.x, hi.y, lo.z}, {lo.x, hi.y, lo.z});  // top
            add_quad(s, name, block, {lo.x, lo.y, hi.z}, {hi.x, lo.y, hi.z}, {hi.x, hi.y, hi.z}, {lo.x, hi.y, hi.z});  // +z
            add_quad(s, name, block, {hi.x, lo.y, lo.z}, {lo.x, lo.y, lo.z}, {lo.x, hi.y, lo.z}, {hi.x, hi.y, lo.z});  // −z
            add_quad(s, name, block, {hi.x, lo.y, hi.z}, {hi.x, lo.y, lo.z}, {hi.x, hi.y, lo.z}, {hi.x, hi.y, hi.z});  // +x
            add_quad(s, name, block, {lo.x, lo.y, lo.z}, {lo.x, lo.y, hi.z}, {lo.x, hi.y, hi.z}, {lo.x, hi.y, lo.z});  // −x
        }
    // Equal lamps: selection by power is then uniform, and what matters is where a lamp is.
    const int m = add_material(s, "lamp", glm::vec3(0.f), glm::vec3(300.f));
    s.materials[size_t(m)].double_sided = true;
    for (int i = 0; i < lamps; ++i) {
        const glm::vec3 c(-half + 2 * half * rng.next_float(), 0.2f + 3.f * rng.next_float(), -half + 2 * half * rng.next_float());
        const float e = 0.05f;
        add_quad(s, "lamp" + std::to_string(i), m, c + glm::vec3(-e, 0, e), c + glm::vec3(-e, 0, -e), c + glm::vec3(e, 0, -e),
                 c + glm::vec3(e, 0, e));
    }
    CameraDesc c;
    c.position = {0.f, 9.f, 24.f};
    c.look_at = {0.f, 0.f, 2.f};
    c.vfov_deg = 50.f;
    c.hfov_deg = 63.f;
    c.origin = here("camera");
    s.camera = c;
    return s;
}

SceneDescription furnace_box(float albedo, float emission, float half, glm::vec3 center) {
    SceneDescription s;
    s.source = "builtin:furnace";
    MaterialDesc m;
    m.name = "furnace";
    m.albedo = glm::vec3(albedo);
    m.emission = glm::vec3(emission);
    m.kind = emission > 0.f ? MaterialKind::emission : MaterialKind::diffuse;
    m.double_sided = true;
    m.origin = here("furnace");
    s.materials.push_back(m);
    MeshDesc cube;
    cube.name = "walls";
    cube.material = 0;
    cube.origin = here("walls");
    cube.flat_normals = true;
    for (int i = 0; i < 8; ++i)
        cube.positions.push_back(center + half * glm::vec3(i & 1 ? 1.f : -1.f, i & 2 ? 1.f : -1.f, i & 4 ? 1.f : -1.f));
    cube.indices = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                    2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
    s.meshes.push_back(std::move(cube));
    CameraDesc c;
    c.position = center;
    c.look_at = center + glm::vec3(0.f, 0.f, -1.f);
    c.vfov_deg = 90.f;
    c.hfov_deg = 90.f;
    c.znear = 0.f;
    c.zfar = 1e30f;
    c.origin = here("camera");
    s.camera = c;
    return s;
}

namespace {

// A unit geodesic octahedron of frequency k (8·k² triangles), wound outward.
void geodesic_sphere(int k, std::vector<glm::vec3>& pos, std::vector<uint32_t>& idx) {
    // A geodesic octahedron of frequency k (8·k² triangles):
    // each octant's face is a triangular lattice whose points (i, j, k−i−j) are keyed by signed
    // integer coordinates, so points on shared edges are one vertex and the mesh is closed.
    idx.reserve(size_t(8) * k * k * 3);
    std::unordered_map<uint64_t, uint32_t> lattice;
    lattice.reserve(size_t(4) * k * k + 2);
    auto vertex = [&](int x, int y, int z) {
        const uint64_t key = (uint64_t(uint32_t(x + k)) << 42) | (uint64_t(uint32_t(y + k)) << 21) | uint64_t(uint32_t(z + k));
        auto [it, inserted] = lattice.try_emplace(key, uint32_t(pos.size()));
        if (inserted) pos.push_back(glm::normalize(glm::vec3(float(x), float(y), float(z))));
        return it->second;
    };
    for (int oct = 0; oct < 8; ++oct) {
        const int sx = oct & 1 ? -1 : 1, sy = oct & 2 ? -1 : 1, sz = oct & 4 ? -1 : 1;
        const bool flip = sx * sy * sz < 0;  // keep every face wound outward
        auto at = [&](int i, int j) { return vertex(sx * i, sy * j, sz * (k - i - j)); };
        auto tri = [&](uint32_t a, uint32_t b, uint32_t c) {
            if (flip) idx.insert(idx.end(), {a, c, b});
            else idx.insert(idx.end(), {a, b, c});
        };
        for (int i = 0; i < k; ++i) {
            for (int j = 0; i + j < k; ++j) {
                tri(at(i, j), at(i + 1, j), at(i, j + 1));
                if (i + j + 1 < k) tri(at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            }
        }
    }
}

}  // namespace

SceneDescription furnace_sphere(float albedo, float emission, float radius, glm::vec3 center, int frequency) {
    SceneDescription s = furnace_box(albedo, emission, radius, center);
    s.source = "builtin:furnace_sphere";
    MeshDesc& m = s.meshes[0];
    m.name = "sphere";
    m.origin = here("sphere");
    m.positions.clear();
    m.indices.clear();
    geodesic_sphere(std::max(1, frequency), m.positions, m.indices);
    // Turned about a generic axis: no face plane is aligned with a coordinate plane, so sampled
    // light points round off their faces as in any real scene.
    const glm::vec3 axis = glm::normalize(glm::vec3(0.3f, 0.8f, 0.52f));
    const float angle = 0.7f, c = std::cos(angle), sn = std::sin(angle);
    for (glm::vec3& p : m.positions) {
        const glm::vec3 r = p * c + glm::cross(axis, p) * sn + axis * glm::dot(axis, p) * (1.f - c);
        p = center + radius * r;
    }
    return s;
}

SceneDescription displaced_sphere(uint64_t min_triangles, uint32_t seed) {
    // Vertices of a geodesic sphere pushed along the normal by a sum of random sinusoids.
    const int k = std::max(1, int(std::ceil(std::sqrt(double(min_triangles) / 8.0))));
    std::vector<glm::vec3> pos;
    std::vector<uint32_t> idx;
    geodesic_sphere(k, pos, idx);
    Pcg32 rng(seed, 7);
    glm::vec3 freq[8];
    float phase[8];
    for (int i = 0; i < 8; ++i) {
        freq[i] = glm::vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f) * float(4 << (i / 2));
        phase[i] = 6.2831853f * rng.next_float();
    }
    for (glm::vec3& p : pos) {
        float h = 0.f;
        for (int i = 0; i < 8; ++i) h += std::sin(glm::dot(freq[i], p) + phase[i]) / float(2 + i);
        p *= 1.f + 0.15f * h;
    }
    SceneDescription s;
    s.source = "builtin:displaced_sphere";
    MeshDesc m;
    m.name = "displaced_sphere";
    m.positions = std::move(pos);
    m.indices = std::move(idx);
    m.material = add_material(s, "clay", glm::vec3(0.7f));
    m.origin = here("displaced_sphere");
    s.meshes.push_back(std::move(m));
    LightDesc sun;
    sun.kind = LightKind::directional;
    sun.direction = glm::normalize(glm::vec3(-0.4f, -1.f, -0.6f));
    sun.radiance = glm::vec3(3.f);
    sun.origin = here("sun");
    s.lights.push_back(sun);
    return s;
}

SceneDescription instanced_field(uint32_t count, uint64_t triangles_each, uint32_t seed) {
    SceneDescription s = displaced_sphere(triangles_each, seed);
    s.source = "builtin:instances";
    s.prototypes.push_back(std::move(s.meshes.back()));
    s.meshes.pop_back();
    // A square grid, 3 units apart (a placed sphere reaches at most 1.15 × 1.3 from its centre),
    // each turned about y, scaled and every fifth mirrored in x, so the placement's inverse,
    // normal matrix and winding are all exercised.
    const uint32_t side = uint32_t(std::ceil(std::sqrt(double(std::max<uint32_t>(count, 1)))));
    const float half = 1.5f * float(side - 1);
    Pcg32 rng(seed, 11);
    for (uint32_t i = 0; i < count; ++i) {
        const float angle = 6.2831853f * rng.next_float();
        const float scale = 0.7f + 0.6f * rng.next_float();
        glm::mat4 m(1.f);
        m = glm::translate(m, glm::vec3(3.f * float(i % side) - half, scale * 1.15f, 3.f * float(i / side) - half));
        m = glm::rotate(m, angle, glm::vec3(0, 1, 0));
        m = glm::scale(m, glm::vec3(i % 5 == 4 ? -scale : scale, scale, scale));
        s.instances.push_back({0, m, here("instance")});
    }
    MeshDesc ground;
    ground.name = "ground";
    const float g = half + 3.f;
    ground.positions = {{-g, 0, -g}, {g, 0, -g}, {g, 0, g}, {-g, 0, g}};
    ground.indices = {0, 2, 1, 0, 3, 2};
    ground.material = add_material(s, "ground", glm::vec3(0.4f));
    ground.origin = here("ground");
    s.meshes.push_back(std::move(ground));
    CameraDesc cam;
    cam.position = glm::vec3(-half - 4.f, 2.f + 0.35f * half, half + 4.f);
    cam.look_at = glm::vec3(0.f, 0.5f, 0.f);
    cam.vfov_deg = 40.f;
    cam.hfov_deg = 60.f;
    cam.origin = here("camera");
    s.camera = cam;
    return s;
}

namespace {

// "builtin:instances[?count=N&triangles=T]": how many placements of a sphere of how many
// triangles; nullopt for another name.
std::optional<std::pair<uint32_t, uint64_t>> instances_params(const std::string& name) {
    const SourceLocation where{name, 0, ""};
    const std::string prefix = "builtin:instances";
    if (name.rfind(prefix, 0) != 0) return std::nullopt;
    std::pair<uint32_t, uint64_t> p{100, 10'000};
    std::string rest = name.substr(prefix.size());
    if (rest.empty()) return p;
    if (rest[0] != '?') throw SceneError(where, "expected '?count=N&triangles=T' after " + prefix);
    rest = rest.substr(1);
    bool seen_count = false, seen_tris = false;
    while (!rest.empty()) {
        const size_t amp = rest.find('&');
        const std::string item = rest.substr(0, amp);
        rest = amp == std::string::npos ? "" : rest.substr(amp + 1);
        const size_t eq = item.find('=');
        const std::string key = item.substr(0, eq), num = eq == std::string::npos ? "" : item.substr(eq + 1);
        if (num.empty() || num.size() > 9 || num.find_first_not_of("0123456789") != std::string::npos)
            throw SceneError(where, "'" + key + "' must be a whole number");
        const uint64_t v = std::stoull(num);
        if (key == "count" && !seen_count) {
            if (v < 1 || v > 1'000'000) throw SceneError(where, "count must lie in [1, 1000000]");
            p.first = uint32_t(v);
            seen_count = true;
        } else if (key == "triangles" && !seen_tris) {
            if (v < 8 || v > 20'000'000) throw SceneError(where, "triangles must lie in [8, 20000000]");
            p.second = v;
            seen_tris = true;
        } else {
            throw SceneError(where, "unknown or repeated parameter '" + key + "' (count, triangles)");
        }
    }
    return p;
}

// The triangle count of "builtin:displaced_sphere[?triangles=N]", or 0 for another name.
uint64_t displaced_sphere_triangles(const std::string& name) {
    const SourceLocation where{name, 0, ""};
    const std::string prefix = "builtin:displaced_sphere";
    if (name.rfind(prefix, 0) != 0) return 0;
    const std::string rest = name.substr(prefix.size());
    if (rest.empty()) return 1'000'000;
    const std::string key = "?triangles=";
    if (rest.rfind(key, 0) != 0) throw SceneError(where, "expected '?triangles=N' after " + prefix);
    const std::string num = rest.substr(key.size());
    if (num.empty() || num.size() > 9 || num.find_first_not_of("0123456789") != std::string::npos)
        throw SceneError(where, "triangles must be a whole number up to 20000000");
    const uint64_t tris = std::stoull(num);
    if (tris < 8 || tris > 20'000'000) throw SceneError(where, "triangles must lie in [8, 20000000]");
    return tris;
}

const char* const kBuiltins[] = {"builtin:cornell_box", "builtin:cornell_spheres", "builtin:cornell_glossy", "builtin:lamp_room", "builtin:furnace", "builtin:many_lights",
                                 "builtin:scattered_lights", "builtin:lamp_field"};

}  // namespace

void check_builtin_name(const std::string& name, uint64_t max_triangles) {
    for (const char* b : kBuiltins) if (name == b) return;
    uint64_t asked = displaced_sphere_triangles(name);
    if (const auto inst = instances_params(name)) asked = inst->second;  // stored once, however often placed
    if (asked) {
        // What it will build (8k² triangles, k = ⌈√(N/8)⌉), held to the server's bound before a
        // triangle is made.
        const uint64_t k = uint64_t(std::max(1, int(std::ceil(std::sqrt(double(asked) / 8.0)))));
        if (8 * k * k > max_triangles)
            throw SceneError(SourceLocation{name, 0, ""}, std::to_string(8 * k * k) + " triangles, over the limit of " +
                                                              std::to_string(max_triangles));
        return;
    }
    throw SceneError(SourceLocation{name, 0, ""}, "unknown built-in scene (builtin:cornell_box, builtin:cornell_spheres, builtin:cornell_glossy, builtin:lamp_room, "
                                                  "builtin:furnace, builtin:many_lights, builtin:scattered_lights, builtin:lamp_field, "
                                                  "builtin:displaced_sphere?triangles=N, builtin:instances?count=N&triangles=T)");
}

SceneDescription builtin_scene(const std::string& name) {
    check_builtin_name(name);
    if (name == "builtin:cornell_box") return cornell_box();
    if (name == "builtin:cornell_spheres") return cornell_spheres();
    if (name == "builtin:cornell_glossy") return cornell_glossy();
    if (name == "builtin:lamp_room") return lamp_room();
    if (name == "builtin:furnace") return furnace_box(0.5f, 1.f);
    if (name == "builtin:many_lights") return many_lights();
    if (name == "builtin:scattered_lights") return scattered_lights();
    if (name == "builtin:lamp_field") return lamp_field();
    if (const auto inst = instances_params(name)) return instanced_field(inst->first, inst->second);
    return displaced_sphere(displaced_sphere_triangles(name));
}

std::vector<float> sky_environment(int width, int height) {
    std::vector<float> rgb(size_t(width) * height * 3);
    const glm::vec2 azimuth = glm::normalize(glm::vec2(0.5f, -0.8f));
    const glm::vec3 sun = glm::normalize(glm::vec3(azimuth.x, std::tan(glm::radians(35.f)), azimuth.y));
    const float sun_cos = std::cos(glm::radians(2.f));
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            const glm::vec3 d = environment_direction((float(x) + 0.5f) / float(width), (float(y) + 0.5f) / float(height));
            glm::vec3 c;
            if (d.y > 0.f) c = glm::mix(glm::vec3(0.75f, 0.85f, 1.f), glm::vec3(0.2f, 0.35f, 0.8f), d.y);
            else c = glm::vec3(0.25f, 0.23f, 0.2f);
            if (glm::dot(d, sun) > sun_cos) c = glm::vec3(10000.f, 9000.f, 7500.f);
            float* px = &rgb[(size_t(y) * width + x) * 3];
            px[0] = c.x;
            px[1] = c.y;
            px[2] = c.z;
        }
    return rgb;
}

}  // namespace tessera
