#pragma once
#include <string>

#include "engine/scene/scene_description.h"

namespace tessera {

// Loads a scene by path (.dae, .gltf, .glb) or built-in name ("builtin:..."); throws
// SceneError naming the file and position.
SceneDescription load_scene(const std::string& path, const LoadLimits& limits = {});

}  // namespace tessera
