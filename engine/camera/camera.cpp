#include "engine/camera/camera.h"

#include <algorithm>
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

void set_thin_lens(Camera& c, const CameraDesc& desc, float radius, float distance) {
    c.lens_radius = std::max(0.f, radius);
    if (distance > 0.f) {
        c.focal_distance = distance;
    } else {
        // The look-at point's depth along the view, or 1 where the two coincide.
        const float depth = glm::dot(desc.look_at - desc.position, c.forward);
        c.focal_distance = depth > 0.f ? depth : 1.f;
    }
}

bool frame_camera(const std::optional<CameraDesc>& from_file, const Aabb& bounds, CameraDesc& out) {
    const glm::vec3 center = bounds.empty() ? glm::vec3(0.f) : bounds.centroid();
    const float diag = bounds.empty() ? 1.f : std::max(glm::length(bounds.extent()), 1e-30f);
    if (from_file) {
        out = *from_file;
        if (out.cs184_orbit_dir) {
            out.look_at = center;
            out.position = center + 1.5f * diag * *out.cs184_orbit_dir;
            out.up = {0, 1, 0};
        }
        return false;
    }
    CameraDesc c;
    c.focal_px = 0.f;  // the field of view fits any output size (a fixed focal length crops small images)
    c.look_at = center;
    c.position = center + 1.5f * diag * glm::normalize(glm::vec3(0.35f, 0.3f, 1.f));
    c.znear = 1e-4f * diag;
    c.zfar = 10.f * diag;
    out = c;
    return true;
}

}  // namespace tessera
