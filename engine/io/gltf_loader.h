#pragma once
// glTF 2.0 input (.gltf with embedded or external buffers, .glb): geometry, materials and
// textures, KHR_lights_punctual lights and the first perspective camera, flattened to world space
// at rest or at any moment of the file's animations (node transforms, skins, morph targets).
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "engine/scene/animation.h"
#include "engine/scene/scene_description.h"

namespace tessera {

// A glTF file parsed once (JSON, buffers, decoded textures, animations), flattened as often as
// asked: a shot poses it once per frame without reading or decoding anything again.
class GltfDocument {
public:
    // Throws SceneError with the file and a JSON pointer (e.g. "/accessors/3") on anything
    // malformed. External buffers must lie inside the file's folder. `name` names the file in
    // errors and SourceLocations (empty: its path).
    static std::shared_ptr<const GltfDocument> load(const std::string& path, const LoadLimits& limits = {},
                                                    const std::string& name = {});
    // From memory (fuzzers, uploads). `base_dir` resolves external URIs ("" forbids external
    // files); `source_name` names the input in errors and SourceLocations.
    static std::shared_ptr<const GltfDocument> parse(std::string_view bytes, bool binary, const std::string& base_dir,
                                                     const std::string& source_name, const LoadLimits& limits = {});
    ~GltfDocument();

    // Nodes as authored, skins in their rest pose and morph weights at their defaults.
    SceneDescription rest() const;
    // The scene at `pose.time_s` with the chosen animations applied. Throws SceneError for an
    // animation the file does not have, or one that animates what Tessera cannot (naming it).
    SceneDescription pose(const ScenePose& pose) const;
    const std::vector<Animation>& animations() const;

    struct Impl;

private:
    explicit GltfDocument(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
};

// The document at rest, in one call.
SceneDescription load_gltf(const std::string& path, const LoadLimits& limits = {}, const std::string& name = {});
SceneDescription parse_gltf(std::string_view bytes, bool binary, const std::string& base_dir,
                            const std::string& source_name, const LoadLimits& limits = {});

}  // namespace tessera
