#include "engine/io/scene_loader.h"

#include <algorithm>
#include <filesystem>

#include "engine/io/collada_loader.h"
#include "engine/io/gltf_loader.h"
#include "engine/scene/procedural.h"

namespace tessera {

namespace {

bool is_gltf(const std::string& path) {
    if (path.rfind("builtin:", 0) == 0) return false;
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return ext == ".gltf" || ext == ".glb";
}

}  // namespace

SceneFile::SceneFile(const std::string& path, const LoadLimits& limits, const std::string& name) {
    if (!is_gltf(path)) {
        still_ = load_scene(path, limits, name);
        return;
    }
    gltf_ = GltfDocument::load(path, limits, name);
    for (const Animation& a : gltf_->animations())
        animations_.push_back({a.name, a.start_s, a.end_s, static_cast<int>(a.channels.size())});
}

SceneFile::~SceneFile() = default;

SceneDescription SceneFile::at(const std::optional<ScenePose>& pose) const {
    if (!gltf_) return *still_;
    return pose ? gltf_->pose(*pose) : gltf_->rest();
}

SceneDescription load_scene(const std::string& path, const LoadLimits& limits, const std::string& name) {
    if (path.rfind("builtin:", 0) == 0) {
        check_builtin_name(path, limits.max_triangles);  // before a triangle is made
        return builtin_scene(path);
    }
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    const SourceLocation where{name.empty() ? path : name, 0, ""};
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) throw SceneError(where, "no such scene file");
    const auto size = std::filesystem::file_size(path, ec);
    if (ec) throw SceneError(where, "cannot read the file size: " + ec.message());
    if (size > limits.max_file_bytes)
        throw SceneError(where, "file is " + std::to_string(size) + " bytes, over the limit of " +
                                    std::to_string(limits.max_file_bytes));
    // COLLADA emitters stay one-sided (toward their winding normal), as the CS184 area light
    // that light sampling uses in the CS184 app: the Cornell lamp faces down. Emitting from the
    // back too would light the ceiling 1 cm above the lamp with huge 1/d² contributions.
    if (ext == ".dae") return load_collada(path, limits, name);
    if (ext == ".gltf" || ext == ".glb") return load_gltf(path, limits, name);
    throw SceneError(where, "unknown scene format '" + ext + "' (expected .dae, .gltf or .glb)");
}

}  // namespace tessera
