#include "engine/camera/camera.h"

#include <cmath>

namespace tessera {

Camera make_camera(const CameraDesc& desc, int width, int height) {
    Camera c;
    c.position = desc.position;
    glm::vec3 fwd = desc.look_at - desc.position;
    if (glm::dot(fwd, fwd) == 0.f) fwd = {0, 0, -1};
    c.forward = glm::normalize(fwd);
    glm::vec3 up = desc.up;
    if (glm::length(glm::cross(c.forward, up)) < 1e-6f) up = std::abs(c.forward.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
    c.right = glm::normalize(glm::cross(c.forward, up));
    c.up = glm::cross(c.right, c.forward);
    if (desc.focal_px > 0.f) {
        c.tan_half_w = 0.5f * float(width) / desc.focal_px;
        c.tan_half_h = 0.5f * float(height) / desc.focal_px;
    } else {
        c.tan_half_h = std::tan(glm::radians(desc.vfov_deg) * 0.5f);
        c.tan_half_w = c.tan_half_h * float(width) / float(height);
    }
    c.znear = desc.znear;
    c.zfar = desc.zfar;
    return c;
}

}  // namespace tessera
