#pragma once
// Sampling points on area lights: a triangle of the light by area, then a uniform point on
// it. Densities are per solid angle as seen from the shading point.
#include <algorithm>
#include <cmath>

#include "engine/core/float_util.h"
#include "engine/sampling/rng.h"
#include "engine/sampling/warp.h"
#include "engine/scene/intersect.h"

namespace tessera {

struct LightSample {
    glm::vec3 point;
    glm::vec3 point_err;  // bound on point's rounding error (spawn_ray_between)
    glm::vec3 n;          // the light triangle's unit normal
    glm::vec3 wi;    // unit, from the shading point to `point`
    float dist2;
    float pdf_w;     // solid-angle density
    glm::vec3 Le;
};

inline bool sample_area_light(const RenderScene& s, const AreaLight& light, const glm::vec3& p, Pcg32& rng, LightSample& out) {
    const float u = rng.next_float();
    const LightTriangle* first = &s.light_triangles[light.first];
    const LightTriangle* last = first + light.count;
    const LightTriangle* tri = std::lower_bound(first, last, u, [](const LightTriangle& t, float v) { return t.cdf <= v; });
    if (tri == last) tri = last - 1;
    const glm::vec2 b = sample_triangle(rng.next_float(), rng.next_float());
    const float b1 = b.y, b2 = 1.f - b.x - b.y;
    out.point = tri->p0 + b1 * tri->e1 + b2 * tri->e2;
    // As the intersector bounds a hit point's error (γ7 over the weighted vertices), with one
    // more rounding for the stored edges.
    out.point_err = gamma(8) * (glm::abs(b.x * tri->p0) + glm::abs(b1 * (tri->p0 + tri->e1)) + glm::abs(b2 * (tri->p0 + tri->e2)));
    out.n = tri->n;
    const glm::vec3 d = out.point - p;
    out.dist2 = glm::dot(d, d);
    if (!(out.dist2 > 0.f)) return false;
    out.wi = d * (1.f / std::sqrt(out.dist2));
    const float cos_l = -glm::dot(tri->n, out.wi);
    if (cos_l == 0.f || (!light.double_sided && cos_l < 0.f)) return false;
    out.pdf_w = out.dist2 / (std::abs(cos_l) * light.area);
    out.Le = light.radiance;
    return true;
}

// The density sample_area_light gives direction wi that reaches the light at distance `dist`
// on a triangle with unit normal ng_light.
inline float area_light_pdf(const AreaLight& light, const glm::vec3& ng_light, const glm::vec3& wi, float dist) {
    const float cos_l = std::abs(glm::dot(ng_light, wi));
    return cos_l > 0.f ? dist * dist / (cos_l * light.area) : 0.f;
}

}  // namespace tessera
