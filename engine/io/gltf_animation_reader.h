#pragma once
// A glTF file's animations read once into plain keys (engine/scene/animation.h), checked, and
// the node values a pose gives (internal to engine/io).
#include <string>
#include <vector>

#include "engine/io/gltf_context.h"
#include "engine/scene/animation.h"

namespace tessera::gltf {

struct ReadAnimations {
    std::vector<Animation> list;
    std::vector<std::string> refusal;  // per animation: why it cannot be played ("" if it can)
};

// Every animation's channels as plain keys, checked: a malformed channel fails the file; one
// that animates what Tessera cannot render (KHR_animation_pointer's paths, say) makes only its
// animation unplayable, so a still of the file still renders.
ReadAnimations read_animations(Ctx& c);

// The node values that `pose` gives: each chosen animation's channels sampled at its time; where
// two animate the same property, the later one in the file wins. Throws SceneError for an
// animation the file does not have or cannot play.
std::vector<NodeState> pose_nodes(const Ctx& c, const ReadAnimations& anims, const ScenePose& pose);

}  // namespace tessera::gltf
