#pragma once
// The pinhole camera with CS184's conventions: rays leave the eye through an image plane at
// distance 1, spanning ±tan(hFov/2) × ±tan(vFov/2); near and far clip become the rays' tmin
// and tmax.
#include <glm/glm.hpp>

#include <optional>

#include "engine/geometry/aabb.h"
#include "engine/geometry/ray.h"
#include "engine/scene/scene_description.h"

namespace tessera {

struct Camera {
    glm::vec3 position{0.f};
    glm::vec3 right{1, 0, 0}, up{0, 1, 0}, forward{0, 0, -1};  // orthonormal, world space
    float tan_half_w = 0.5f, tan_half_h = 0.5f;
    float znear = 0.001f, zfar = 1000.f;
};

// The camera for an output of width × height pixels. With desc.focal_px > 0 (CS184 scenes)
// the focal length in pixels is kept, so another size crops or extends the view as the CS184
// app does; otherwise the vertical field of view is kept and the horizontal one follows the
// output's aspect ratio.
Camera make_camera(const CameraDesc& desc, int width, int height);

// The camera a scene is seen through: the file's, placed by CS184's orbit rule when it asks for
// it, or, when the file has none, a default that frames `bounds`. Returns true for the default.
bool frame_camera(const std::optional<CameraDesc>& from_file, const Aabb& bounds, CameraDesc& out);

// (u, v) in [0,1]², v = 0 at the bottom of the image. The direction has unit length, so t
// measures distance and the clip planes mean what they say.
inline Ray generate_ray(const Camera& c, float u, float v) {
    const glm::vec3 d = (2.f * u - 1.f) * c.tan_half_w * c.right + (2.f * v - 1.f) * c.tan_half_h * c.up + c.forward;
    return Ray{c.position, c.znear, glm::normalize(d), c.zfar};
}

}  // namespace tessera
