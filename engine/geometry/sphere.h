#pragma once
// Ray–sphere test with the numerically stable quadratic of Haines et al., "Precision
// Improvements for Ray/Sphere Intersection", Ray Tracing Gems, ch. 7: the discriminant is
// formed from the distance of the centre to the ray's line, not from b² − 4ac, and the
// second root comes from Vieta's formula, so neither root suffers cancellation.
#include <cmath>
#include <utility>

#include <glm/glm.hpp>

#include "engine/geometry/ray.h"

namespace tessera {

inline bool intersect_sphere(const Ray& ray, const glm::vec3& center, float radius, float& t_hit) {
    const glm::vec3 f = ray.o - center;
    const float a = glm::dot(ray.d, ray.d);
    const float b = -glm::dot(f, ray.d);
    const glm::vec3 l = f + (b / a) * ray.d;  // centre-to-line vector
    const float r2 = radius * radius;
    const float disc = a * (r2 - glm::dot(l, l));
    if (disc < 0.f) return false;
    const float c = glm::dot(f, f) - r2;
    const float q = b + std::copysign(std::sqrt(disc), b);
    float t0, t1;
    if (q == 0.f) {  // ray origin at the centre with b == 0 only when disc == 0 too
        t0 = t1 = 0.f;
    } else {
        t0 = c / q;
        t1 = q / a;
    }
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > ray.tmin && t0 < ray.tmax) { t_hit = t0; return true; }
    if (t1 > ray.tmin && t1 < ray.tmax) { t_hit = t1; return true; }
    return false;
}

}  // namespace tessera
