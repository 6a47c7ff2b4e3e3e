#include "cli/bench_turntable.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/io/gltf_writer.h"
#include "engine/scene/procedural.h"

namespace tessera::cli {

std::string write_turntable(const std::filesystem::path& dir, uint64_t triangles, double seconds, bool deform) {
    using nlohmann::json;
    SceneDescription s = displaced_sphere(triangles);
    if (deform) s.meshes[0].normals.clear();  // the loader computes them for each pose
    MeshDesc ground;
    ground.name = "ground";
    ground.positions = {{-4, -1.3f, -4}, {4, -1.3f, -4}, {4, -1.3f, 4}, {-4, -1.3f, 4}};
    ground.indices = {0, 2, 1, 0, 3, 2};
    ground.material = 0;
    s.meshes.push_back(ground);
    CameraDesc cam;
    cam.position = {0, 1.2f, 4.2f};
    cam.look_at = {0, 0, 0};
    cam.vfov_deg = 35;
    s.camera = cam;
    json gltf = json::parse(to_gltf(s));
    std::vector<float> keys;
    const int count = deform ? 3 : 5;
    for (int k = 0; k < count; ++k) keys.push_back(float(seconds * k / (count - 1)));
    if (deform) {
        keys.insert(keys.end(), {0.f, 1.f, 0.f});  // the target's weight
        const std::vector<glm::vec3>& p = s.meshes[0].positions;
        for (const glm::vec3& v : p) {
            const float a = 1.2f * v.y, c = std::cos(a), sn = std::sin(a);
            const glm::vec3 twisted(c * v.x + sn * v.z, v.y, -sn * v.x + c * v.z);
            const glm::vec3 d = twisted - v + glm::vec3(0.f, 0.25f * std::sin(3.f * v.x) * std::cos(2.f * v.z), 0.f);
            keys.insert(keys.end(), {d.x, d.y, d.z});
        }
    } else {
        for (int k = 0; k < count; ++k) {
            const double half = 0.5 * (3.14159265358979 / 2) * k;  // a quarter turn per key
            keys.insert(keys.end(), {0.f, float(std::sin(half)), 0.f, float(std::cos(half))});
        }
    }
    // Embedded like the geometry, so the file is the whole scene (a farm publishes one file).
    std::vector<unsigned char> bytes(keys.size() * 4);
    std::memcpy(bytes.data(), keys.data(), bytes.size());
    const size_t buffer = gltf["buffers"].size(), view = gltf["bufferViews"].size(), accessor = gltf["accessors"].size();
    const size_t out_floats = deform ? 3 : 4 * size_t(count);
    gltf["buffers"].push_back({{"byteLength", bytes.size()}, {"uri", gltf_data_uri(bytes)}});
    gltf["bufferViews"].push_back({{"buffer", buffer}, {"byteOffset", 0}, {"byteLength", count * 4}});
    gltf["bufferViews"].push_back({{"buffer", buffer}, {"byteOffset", count * 4}, {"byteLength", out_floats * 4}});
    gltf["accessors"].push_back({{"bufferView", view}, {"componentType", 5126}, {"count", count}, {"type", "SCALAR"},
                                 {"min", {0.0}}, {"max", {seconds}}});
    gltf["accessors"].push_back({{"bufferView", view + 1}, {"componentType", 5126}, {"count", deform ? 3 : count},
                                 {"type", deform ? "SCALAR" : "VEC4"}});
    if (deform) {
        const size_t n = s.meshes[0].positions.size();
        gltf["bufferViews"].push_back({{"buffer", buffer}, {"byteOffset", (count + 3) * 4}, {"byteLength", n * 12}});
        glm::vec3 lo(1e30f), hi(-1e30f);
        for (size_t i = 0; i < n; ++i) {
            const glm::vec3 d(keys[size_t(count) + 3 + 3 * i], keys[size_t(count) + 4 + 3 * i], keys[size_t(count) + 5 + 3 * i]);
            lo = glm::min(lo, d);
            hi = glm::max(hi, d);
        }
        gltf["accessors"].push_back({{"bufferView", view + 2}, {"componentType", 5126}, {"count", n}, {"type", "VEC3"},
                                     {"min", {lo.x, lo.y, lo.z}}, {"max", {hi.x, hi.y, hi.z}}});
        const size_t mesh = gltf["nodes"][0]["mesh"];
        for (json& prim : gltf["meshes"][mesh]["primitives"]) prim["targets"] = {{{"POSITION", accessor + 2}}};
        gltf["meshes"][mesh]["weights"] = {0.0};
    }
    gltf["animations"] = {{{"name", deform ? "deform" : "turntable"},
                           {"channels", {{{"sampler", 0}, {"target", {{"node", 0}, {"path", deform ? "weights" : "rotation"}}}}}},
                           {"samplers", {{{"input", accessor}, {"output", accessor + 1}, {"interpolation", "LINEAR"}}}}}};
    const std::filesystem::path file = dir / "turntable.gltf";
    std::ofstream(file) << gltf.dump();
    return file.string();
}

}  // namespace tessera::cli
