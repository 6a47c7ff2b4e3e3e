#pragma once
#include <algorithm>
#include <cmath>

#include <glm/glm.hpp>

#include "engine/core/float_util.h"

namespace tessera {

struct Aabb {
    glm::vec3 lo{INFINITY};
    glm::vec3 hi{-INFINITY};

    bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
    void expand(const glm::vec3& p) { lo = glm::min(lo, p); hi = glm::max(hi, p); }
    void expand(const Aabb& b) { lo = glm::min(lo, b.lo); hi = glm::max(hi, b.hi); }
    glm::vec3 extent() const { return hi - lo; }
    glm::vec3 centroid() const { return 0.5f * (lo + hi); }
    float surface_area() const {
        if (empty()) return 0.f;
        const glm::vec3 e = extent();
        return 2.f * (e.x * e.y + e.y * e.z + e.z * e.x);
    }
    int largest_axis() const {
        const glm::vec3 e = extent();
        return (e.x >= e.y && e.x >= e.z) ? 0 : (e.y >= e.z ? 1 : 2);
    }
};

inline Aabb merge(Aabb a, const Aabb& b) { a.expand(b); return a; }

// Per-ray data for slab tests, computed once per ray.
struct RayInv {
    glm::vec3 o;
    glm::vec3 inv_d;
};

inline RayInv make_ray_inv(const glm::vec3& o, const glm::vec3& d) { return {o, 1.0f / d}; }

// Slab test; returns the entry distance or INFINITY on a miss. tfar is widened by 2·gamma(3)
// so that rounding never culls a box a ray really touches (pbrt-v4 Bounds3::IntersectP).
inline float intersect_aabb(const glm::vec3& lo, const glm::vec3& hi, const RayInv& r, float tmin, float tmax) {
    const glm::vec3 t0 = (lo - r.o) * r.inv_d;
    const glm::vec3 t1 = (hi - r.o) * r.inv_d;
    const glm::vec3 tn = glm::min(t0, t1);
    const glm::vec3 tf = glm::max(t0, t1);
    // max/min written so that a NaN (0·inf on a slab boundary) loses to the other operand.
    float enter = std::max(std::max(tn.x, tn.y), std::max(tn.z, tmin));
    float leave = std::min(std::min(tf.x, tf.y), std::min(tf.z, tmax)) * (1.f + 2.f * gamma(3));
    return enter <= leave ? enter : INFINITY;
}

}  // namespace tessera
