#pragma once
// The builtin boxes (and the CS184 files) keep CS184's focal length in pixels, as its app does,
// so an image of test size is a crop of the back wall's middle: no edge, sphere or lamp. A test
// that means the scene sees it whole: the vertical field of view kept, whatever the size.
#include "engine/scene/scene_description.h"

namespace tessera::test {

inline SceneDescription seen_whole(SceneDescription d) {
    if (d.camera) d.camera->focal_px = 0.f;
    return d;
}

}  // namespace tessera::test
