#pragma once
// glTF 2.0 input (.gltf with embedded or external buffers, .glb): geometry, material factors,
// KHR_lights_punctual lights and the first perspective camera, flattened to world space.
// Textures, skins, morph targets and animations are not rendered; the loader says so in
// SceneDescription::warnings instead of failing.
#include <string>
#include <string_view>

#include "engine/scene/scene_description.h"

namespace tessera {

// Reads a .gltf (embedded or external buffers) or .glb file (recognised by its magic, not its
// extension). Throws SceneError with the file and a JSON pointer (e.g. "/accessors/3") on
// anything malformed. External buffers must lie inside the file's folder.
SceneDescription load_gltf(const std::string& path, const LoadLimits& limits = {});

// From memory (fuzzers, uploads). `base_dir` resolves external URIs ("" forbids external files).
// `source_name` names the input in errors and SourceLocations.
SceneDescription parse_gltf(std::string_view bytes, bool binary, const std::string& base_dir,
                            const std::string& source_name, const LoadLimits& limits = {});

}  // namespace tessera
