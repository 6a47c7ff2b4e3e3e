#pragma once
// Reader for the COLLADA 1.4.1 files of the CS184 PathTracer (see ../shared/scenes/cs184/README.md):
// Blender exports plus the CGL extras for spheres, materials and lights. It reproduces the CS184
// loader's reading (axis fix, light geometry, camera fit to 800x600) and rejects anything
// malformed with a SceneError naming file:line.
#include <string>
#include <string_view>

#include "engine/scene/scene_description.h"

namespace tessera {

// Reads a CS184-style COLLADA 1.4.1 file. Throws SceneError (file + line) on anything malformed;
// `name` names the file there and in origins (empty: its path).
SceneDescription load_collada(const std::string& path, const LoadLimits& limits = {}, const std::string& name = {});

// Same, from memory (fuzzers and tests); `source_name` is used in error locations.
SceneDescription parse_collada(std::string_view xml, const std::string& source_name, const LoadLimits& limits = {});

}  // namespace tessera
