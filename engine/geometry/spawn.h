#pragma once
// Secondary-ray origins that cannot re-hit the surface they leave, at any scene scale:
// the hit point carries a conservative bound on its rounding error, and the origin is pushed
// out of that error box along the geometric normal and rounded away (pbrt-v4, section 6.8.6).
// A fixed epsilon would be too large for a scene at 1e-4 and too small at 1e4.
#include <glm/glm.hpp>

#include "engine/core/float_util.h"
#include "engine/geometry/ray.h"

namespace tessera {

inline glm::vec3 offset_ray_origin(const glm::vec3& p, const glm::vec3& p_err, const glm::vec3& ng,
                                   const glm::vec3& w) {
    const float d = glm::dot(glm::abs(ng), p_err);
    glm::vec3 offset = d * ng;
    if (glm::dot(w, ng) < 0.f) offset = -offset;
    glm::vec3 po = p + offset;
    for (int i = 0; i < 3; ++i) {
        if (offset[i] > 0.f) po[i] = next_float_up(po[i]);
        else if (offset[i] < 0.f) po[i] = next_float_down(po[i]);
    }
    return po;
}

// `tri`: the triangle p lies on (SurfaceInteraction::tri), which the ray then never tests;
// `instance`: the placement it lies in, for a prototype's triangle.
inline Ray spawn_ray(const glm::vec3& p, const glm::vec3& p_err, const glm::vec3& ng, const glm::vec3& dir,
                     uint32_t tri = kNoTriangle, uint32_t instance = ~0u, float time = 0.f) {
    return Ray{offset_ray_origin(p, p_err, ng, dir), 0.f, dir, INFINITY, tri, instance, time};
}

// A ray from a surface point toward a target point (shadow rays); it stops just short of the
// target so that the target's own surface is not reported as an occluder.
inline constexpr float shadow_epsilon = 1e-4f;

inline Ray spawn_ray_to(const glm::vec3& p, const glm::vec3& p_err, const glm::vec3& ng, const glm::vec3& target,
                         uint32_t tri = kNoTriangle, uint32_t instance = ~0u, float time = 0.f) {
    const glm::vec3 o = offset_ray_origin(p, p_err, ng, target - p);
    return Ray{o, 0.f, target - o, 1.f - shadow_epsilon, tri, instance, time};
}

// A ray between two surface points (a shadow ray to a point sampled on a light): both ends are
// pushed off their surfaces by their own error bounds (pbrt-v4's SpawnRayTo of two
// interactions). Far from the origin a sampled point is off its face by up to an ulp of its
// coordinates, which a fixed fraction of the segment does not cover: the light's own face would
// then occlude the ray (measured: 10% of the light lost at 10⁴ radii from the origin).
inline Ray spawn_ray_between(const glm::vec3& p, const glm::vec3& p_err, const glm::vec3& ng, const glm::vec3& q,
                             const glm::vec3& q_err, const glm::vec3& nq, uint32_t tri = kNoTriangle,
                             uint32_t instance = ~0u, float time = 0.f) {
    const glm::vec3 o = offset_ray_origin(p, p_err, ng, q - p);
    const glm::vec3 t = offset_ray_origin(q, q_err, nq, o - q);
    return Ray{o, 0.f, t - o, 1.f - shadow_epsilon, tri, instance, time};
}

}  // namespace tessera
