#pragma once
#include <memory>
#include <optional>
#include <string>

#include "engine/scene/scene_description.h"

namespace tessera {

class GltfDocument;

// Loads a scene by path (.dae, .gltf, .glb) or built-in name ("builtin:..."); throws
// SceneError naming the file and position. An animated glTF comes at rest. `name` is what
// errors, warnings and origins call the file (a server's catalog name for it, so that nothing
// it reports shows its folders); empty: the path.
SceneDescription load_scene(const std::string& path, const LoadLimits& limits = {}, const std::string& name = {});

// A scene opened once and flattened at any moment: a glTF file is parsed and its textures
// decoded once and then posed per frame; any other scene is the same at every time.
class SceneFile {
public:
    explicit SceneFile(const std::string& path, const LoadLimits& limits = {}, const std::string& name = {});
    ~SceneFile();
    // What the file animates (empty for a still scene or another format).
    const std::vector<AnimationSummary>& animations() const { return animations_; }
    // At rest (nullopt), or posed. Throws SceneError for an animation the file cannot play.
    SceneDescription at(const std::optional<ScenePose>& pose) const;

private:
    std::shared_ptr<const GltfDocument> gltf_;
    std::optional<SceneDescription> still_;
    std::vector<AnimationSummary> animations_;
};

}  // namespace tessera
