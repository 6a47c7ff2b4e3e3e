#pragma once
// A scene's counts and bounds as GET /v1/scenes and an upload's answer report them.
#include <nlohmann/json.hpp>

#include "engine/scene/scene_description.h"

namespace tessera::api {

nlohmann::json describe_scene(const SceneDescription& s);

}  // namespace tessera::api
