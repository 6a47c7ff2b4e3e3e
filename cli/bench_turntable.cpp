#include "cli/bench_turntable.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/io/gltf_writer.h"
#include "engine/scene/procedural.h"

namespace tessera::cli {

std::string write_turntable(const std::filesystem::path& dir, uint64_t triangles, double seconds) {
    using nlohmann::json;
    SceneDescription s = displaced_sphere(triangles);
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
    for (int k = 0; k <= 4; ++k) keys.push_back(float(seconds * k / 4));
    for (int k = 0; k <= 4; ++k) {
        const double half = 0.5 * (3.14159265358979 / 2) * k;  // a quarter turn per key
        keys.insert(keys.end(), {0.f, float(std::sin(half)), 0.f, float(std::cos(half))});
    }
    // Embedded like the geometry, so the file is the whole scene (a farm publishes one file).
    std::vector<unsigned char> bytes(keys.size() * 4);
    std::memcpy(bytes.data(), keys.data(), bytes.size());
    const size_t buffer = gltf["buffers"].size(), view = gltf["bufferViews"].size(), accessor = gltf["accessors"].size();
    gltf["buffers"].push_back({{"byteLength", bytes.size()}, {"uri", gltf_data_uri(bytes)}});
    gltf["bufferViews"].push_back({{"buffer", buffer}, {"byteOffset", 0}, {"byteLength", 5 * 4}});
    gltf["bufferViews"].push_back({{"buffer", buffer}, {"byteOffset", 5 * 4}, {"byteLength", 5 * 16}});
    gltf["accessors"].push_back({{"bufferView", view}, {"componentType", 5126}, {"count", 5}, {"type", "SCALAR"},
                                 {"min", {0.0}}, {"max", {seconds}}});
    gltf["accessors"].push_back({{"bufferView", view + 1}, {"componentType", 5126}, {"count", 5}, {"type", "VEC4"}});
    gltf["animations"] = {{{"name", "turntable"},
                           {"channels", {{{"sampler", 0}, {"target", {{"node", 0}, {"path", "rotation"}}}}}},
                           {"samplers", {{{"input", accessor}, {"output", accessor + 1}, {"interpolation", "LINEAR"}}}}}};
    const std::filesystem::path file = dir / "turntable.gltf";
    std::ofstream(file) << gltf.dump();
    return file.string();
}

}  // namespace tessera::cli
