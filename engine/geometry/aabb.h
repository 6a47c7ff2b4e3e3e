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

// A zero component (of either sign) becomes +∞, so that near/far can be chosen by the sign of
// inv_d alone (see intersect_aabb).
inline RayInv make_ray_inv(const glm::vec3& o, const glm::vec3& d) {
    glm::vec3 inv;
    for (int a = 0; a < 3; ++a) inv[a] = d[a] == 0.f ? INFINITY : 1.0f / d[a];
    return {o, inv};
}

// Slab test; returns the entry distance or INFINITY on a miss. tfar is widened by 2·gamma(3)
// so that rounding never culls a box a ray really touches (pbrt-v4 Bounds3::IntersectP).
// A ray lying in a slab's plane gives 0·∞ = NaN there; the comparisons are ordered so that a
// NaN always loses to the finite operand, which treats that slab as containing the ray (the
// bounds are closed). std::max would return the NaN and miss the box: a leak.
inline float max_nan_loses(float a, float b) { return a > b ? a : b; }
inline float min_nan_loses(float a, float b) { return a < b ? a : b; }

inline float intersect_aabb(const glm::vec3& lo, const glm::vec3& hi, const RayInv& r, float tmin, float tmax) {
    const glm::vec3 t0 = (lo - r.o) * r.inv_d;
    const glm::vec3 t1 = (hi - r.o) * r.inv_d;
    float enter = tmin, leave = tmax;
    for (int a = 0; a < 3; ++a) {
        const bool forward = r.inv_d[a] >= 0.f;  // never compare t0, t1: either may be NaN
        const float n = forward ? t0[a] : t1[a];
        const float f = forward ? t1[a] : t0[a];
        enter = max_nan_loses(n, enter);
        leave = min_nan_loses(f, leave);
    }
    return enter <= leave * (1.f + 2.f * gamma(3)) ? enter : INFINITY;
}

}  // namespace tessera
