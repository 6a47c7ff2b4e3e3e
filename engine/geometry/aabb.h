#pragma once
#include <algorithm>
#include <cmath>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

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

// Per-ray data for slab tests, computed once per ray. A zero direction component (of either
// sign) becomes +∞, so that near/far planes are chosen by the sign of inv_d alone; comparing
// the two slab distances instead would go wrong when one of them is NaN.
struct RayInv {
    glm::vec3 o;
    glm::vec3 inv_d;
    bool near_x, near_y, near_z;  // false: the near plane is lo, true: hi
};

inline RayInv make_ray_inv(const glm::vec3& o, const glm::vec3& d) {
    RayInv r;
    r.o = o;
#if defined(__SSE2__)
    // One packed division instead of three scalar ones (this runs once per ray).
    const __m128 dv = _mm_set_ps(1.f, d.z, d.y, d.x);
    const __m128 q = _mm_div_ps(_mm_set1_ps(1.f), dv);
    const __m128 zero = _mm_cmpeq_ps(dv, _mm_setzero_ps());
    alignas(16) float inv[4];
    _mm_store_ps(inv, _mm_or_ps(_mm_and_ps(zero, _mm_set1_ps(INFINITY)), _mm_andnot_ps(zero, q)));
    r.inv_d = glm::vec3(inv[0], inv[1], inv[2]);
#else
    for (int a = 0; a < 3; ++a) r.inv_d[a] = d[a] == 0.f ? INFINITY : 1.0f / d[a];
#endif
    r.near_x = r.inv_d.x < 0.f;
    r.near_y = r.inv_d.y < 0.f;
    r.near_z = r.inv_d.z < 0.f;
    return r;
}

// Slab test on bounds given as {lo, hi}; returns the entry distance or INFINITY on a miss.
// tfar is widened by 2·gamma(3) so that rounding never culls a box a ray really touches
// (pbrt-v4 Bounds3::IntersectP). A ray lying in a slab's plane gives 0·∞ = NaN there; the
// comparisons are ordered so that a NaN always loses to the finite operand, which treats that
// slab as containing the ray (the bounds are closed); std::max would keep the NaN and miss.
inline float max_nan_loses(float a, float b) { return a > b ? a : b; }
inline float min_nan_loses(float a, float b) { return a < b ? a : b; }

inline float intersect_aabb(const glm::vec3& lo, const glm::vec3& hi, const RayInv& r, float tmin, float tmax) {
    const float nx = ((r.near_x ? hi.x : lo.x) - r.o.x) * r.inv_d.x;
    const float fx = ((r.near_x ? lo.x : hi.x) - r.o.x) * r.inv_d.x;
    const float ny = ((r.near_y ? hi.y : lo.y) - r.o.y) * r.inv_d.y;
    const float fy = ((r.near_y ? lo.y : hi.y) - r.o.y) * r.inv_d.y;
    const float nz = ((r.near_z ? hi.z : lo.z) - r.o.z) * r.inv_d.z;
    const float fz = ((r.near_z ? lo.z : hi.z) - r.o.z) * r.inv_d.z;
    const float enter = max_nan_loses(nz, max_nan_loses(ny, max_nan_loses(nx, tmin)));
    const float leave = min_nan_loses(fz, min_nan_loses(fy, min_nan_loses(fx, tmax)));
    return enter <= leave * (1.f + 2.f * gamma(3)) ? enter : INFINITY;
}

}  // namespace tessera
