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
    float lens_radius = 0.f;      // thin lens; 0: a pinhole
    float focal_distance = 1.f;   // of the plane in focus, along `forward`
};

// The camera for an output of width × height pixels. With desc.focal_px > 0 (CS184 scenes)
// the focal length in pixels is kept, so another size crops or extends the view as the CS184
// app does; otherwise the vertical field of view is kept and the horizontal one follows the
// output's aspect ratio.
Camera make_camera(const CameraDesc& desc, int width, int height);
// A thin lens of `radius` focused at `distance` along the view (0: at desc.look_at).
void set_thin_lens(Camera& c, const CameraDesc& desc, float radius, float distance);

// The camera a scene is seen through: the file's, placed by CS184's orbit rule when it asks for
// it, or, when the file has none, a default that frames `bounds`. Returns true for the default.
bool frame_camera(const std::optional<CameraDesc>& from_file, const Aabb& bounds, CameraDesc& out);

// (u, v) in [0,1]², v = 0 at the bottom of the image. The direction has unit length, so t
// measures distance and the clip planes mean what they say.
inline Ray generate_ray(const Camera& c, float u, float v) {
    const glm::vec3 d = (2.f * u - 1.f) * c.tan_half_w * c.right + (2.f * v - 1.f) * c.tan_half_h * c.up + c.forward;
    return Ray{c.position, c.znear, glm::normalize(d), c.zfar};
}

// Through a thin lens: from `lens` (a point of the unit disk) on the lens toward where the
// pinhole ray meets the plane in focus, so that plane stays sharp. The clip planes are
// distances along the ray, as for the pinhole.
inline Ray generate_ray(const Camera& c, float u, float v, glm::vec2 lens) {
    const glm::vec3 d = (2.f * u - 1.f) * c.tan_half_w * c.right + (2.f * v - 1.f) * c.tan_half_h * c.up + c.forward;
    const glm::vec3 focus = c.position + c.focal_distance * d;  // d's component along forward is 1
    const glm::vec3 origin = c.position + c.lens_radius * (lens.x * c.right + lens.y * c.up);
    return Ray{origin, c.znear, glm::normalize(focus - origin), c.zfar};
}

}  // namespace tessera
