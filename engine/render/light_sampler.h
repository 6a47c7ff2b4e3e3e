#pragma once
// Sampling points on area lights: a triangle of the light by area, then a uniform point on
// it. Densities are per solid angle as seen from the shading point.
#include <algorithm>
#include <cmath>
#include <type_traits>

#include "engine/core/float_util.h"
#include "engine/render/render_settings.h"
#include "engine/sampling/sampler.h"
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
    glm::vec3 Le;    // the light's constant; a textured emitter's is read at (prim, b1, b2)
    uint32_t prim = ~0u;
    float b1 = 0.f, b2 = 0.f;
};

// The direction and distance from a shading point (anchor + local, see SurfaceInteraction) to a
// point q given the same way: anchors of nearby triangles subtract exactly (Sterbenz), so the
// difference keeps its digits at any distance from the origin.
inline glm::vec3 anchored_difference(const glm::vec3& q_anchor, const glm::vec3& q_local, const glm::vec3& p_anchor,
                                     const glm::vec3& p_local) {
    return (q_anchor - p_anchor) + (q_local - p_local);
}

// Light triangle `index` at `time` within a shutter (itself when no emitter moves): its vertices
// linear between the opening and the closing, as the intersector moves them, its normal and
// area those of the triangle there (area 0 where it degenerates).
inline LightTriangle light_triangle_at(const RenderScene& s, uint32_t index, float time) {
    const LightTriangle& a = s.light_triangles[index];
    if (s.motion.light_triangles_close.empty()) return a;
    const LightTriangle& c = s.motion.light_triangles_close[index];
    // Vertex by vertex as triangle4_at moves the intersector's, so a sample lies on the triangle
    // a ray meets at that time (up to the edges' rounding, moved_light_err).
    auto at = [time](const glm::vec3& x, const glm::vec3& y) { return x + time * (y - x); };
    LightTriangle t = a;
    t.p0 = at(a.p0, c.p0);
    t.e1 = at(a.p0 + a.e1, c.p0 + c.e1) - t.p0;
    t.e2 = at(a.p0 + a.e2, c.p0 + c.e2) - t.p0;
    const glm::vec3 n = glm::cross(t.e1, t.e2);
    const float len = glm::length(n);
    t.area = 0.5f * len;
    if (len > 0.f) t.n = n / len;
    return t;
}

// What a moving light triangle's sample may miss the intersector's triangle by, beyond
// sample_on_triangle's bound: the stored edges' rounding carried through the interpolation.
inline glm::vec3 moved_light_err(const RenderScene& s, uint32_t index) {
    const LightTriangle &a = s.light_triangles[index], &c = s.motion.light_triangles_close[index];
    return gamma(4) * (glm::abs(a.p0) + glm::abs(a.p0 + a.e1) + glm::abs(a.p0 + a.e2) + glm::abs(c.p0) + glm::abs(c.p0 + c.e1) +
                       glm::abs(c.p0 + c.e2));
}

// Delta light `k` at `time` within a shutter: a point light's position linear between the
// opening and the closing, a directional light's direction too (renormalised).
inline DeltaLight delta_light_at(const RenderScene& s, size_t k, float time) {
    const DeltaLight& a = s.delta_lights[k];
    if (s.motion.delta_lights_close.empty()) return a;
    const DeltaLight& c = s.motion.delta_lights_close[k];
    DeltaLight d = a;
    d.position = a.position + time * (c.position - a.position);
    const glm::vec3 dir = a.direction + time * (c.direction - a.direction);
    const float len = glm::length(dir);
    if (len > 0.f) d.direction = dir / len;
    return d;
}

// The sample at uv on `tri`: its point, error bound, direction and density per solid angle for
// a point chosen uniformly over `area` (its light's, or the triangle's own).
inline bool sample_on_triangle(const LightTriangle& tri, glm::vec2 uv, float area, const glm::vec3& radiance, bool double_sided,
                               const glm::vec3& p_anchor, const glm::vec3& p_local, LightSample& out) {
    const glm::vec2 b = sample_triangle(uv.x, uv.y);
    const float b1 = b.y, b2 = 1.f - b.x - b.y;
    const glm::vec3 local = b1 * tri.e1 + b2 * tri.e2;
    out.point = tri.p0 + local;
    // As the intersector bounds a hit point's error (γ7 over the weighted vertices), with one
    // more rounding for the stored edges.
    out.point_err = gamma(8) * (glm::abs(b.x * tri.p0) + glm::abs(b1 * (tri.p0 + tri.e1)) + glm::abs(b2 * (tri.p0 + tri.e2)));
    out.n = tri.n;
    const glm::vec3 d = anchored_difference(tri.p0, local, p_anchor, p_local);
    out.dist2 = glm::dot(d, d);
    if (!(out.dist2 > 0.f)) return false;
    out.wi = d * (1.f / std::sqrt(out.dist2));
    const float cos_l = -glm::dot(tri.n, out.wi);
    if (cos_l == 0.f || (!double_sided && cos_l < 0.f)) return false;
    out.pdf_w = out.dist2 / (std::abs(cos_l) * area);
    out.Le = radiance;
    out.prim = tri.prim;
    out.b1 = b1;
    out.b2 = b2;
    return true;
}

// Rng: Sampler, or Pcg32 (tests).
// `time`: the path's within a shutter. A moving light's triangle is still picked by its area at
// the opening, then a point uniformly on it where it is at `time`: the density over the light is
// the pick's probability over the triangle's area then (its light's area when nothing moves).
template <class Rng>
bool sample_area_light(const RenderScene& s, const AreaLight& light, const glm::vec3& p_anchor, const glm::vec3& p_local, Rng& rng,
                       LightSample& out, float time = 0.f) {
    const LightTriangle* first = &s.light_triangles[light.first];
    const LightTriangle* last = first + light.count;
    auto pick = [&](float u) {
        const LightTriangle* t = std::lower_bound(first, last, u, [](const LightTriangle& lt, float v) { return lt.cdf <= v; });
        return t == last ? last - 1 : t;
    };
    const LightTriangle* tri = nullptr;
    glm::vec2 uv;
    if constexpr (std::is_same_v<Rng, Sampler>) {
        if (rng.kind() == SamplerKind::sobol) {
            // One 2-D point picks the triangle (by its first coordinate) and the point on it
            // (that coordinate stretched back over [0, 1) within the triangle's share):
            // stratified points then cover the whole light, not each triangle on its own.
            uv = rng.next_2d();
            tri = pick(uv.x);
            const float lo = tri == first ? 0.f : (tri - 1)->cdf;
            const float width = tri->cdf - lo;
            uv.x = width > 0.f ? std::clamp((uv.x - lo) / width, 0.f, 0x1.fffffep-1f) : 0.f;
        }
    }
    if (!tri) {
        tri = pick(rng.next_float());
        if constexpr (std::is_same_v<Rng, Pcg32>) uv = independent_2d(rng);
        else uv = rng.next_2d();
    }
    if (s.motion.light_triangles_close.empty())
        return sample_on_triangle(*tri, uv, light.area, light.radiance, light.double_sided, p_anchor, p_local, out);
    const uint32_t index = uint32_t(tri - s.light_triangles.data());
    const LightTriangle moved = light_triangle_at(s, index, time);
    if (!(moved.area > 0.f) ||
        !sample_on_triangle(moved, uv, light.area * (moved.area / tri->area), light.radiance, light.double_sided, p_anchor, p_local, out))
        return false;
    out.point_err += moved_light_err(s, index);
    return true;
}

template <class Rng>
bool sample_area_light(const RenderScene& s, const AreaLight& light, const glm::vec3& p, Rng& rng, LightSample& out) {
    return sample_area_light(s, light, p, glm::vec3(0.f), rng, out);
}

// A point on light triangle `index` (picked by the light tree) from the 2-D point uv, with its
// density per solid angle given the triangle was picked.
inline bool sample_light_triangle(const RenderScene& s, uint32_t index, glm::vec2 uv, const glm::vec3& p_anchor,
                                  const glm::vec3& p_local, LightSample& out, float time = 0.f) {
    const LightTriangle tri = light_triangle_at(s, index, time);
    if (!(tri.area > 0.f)) return false;
    const AreaLight& light = s.area_lights[tri.light];
    if (!sample_on_triangle(tri, uv, tri.area, light.radiance, light.double_sided, p_anchor, p_local, out)) return false;
    if (!s.motion.light_triangles_close.empty()) out.point_err += moved_light_err(s, index);
    return true;
}

// What `automatic` light selection picks: the light tree above kTreeAboveLights area lights,
// every light (each `light_rays` times) up to it. Measured at equal time with `tessera bench
// lights` (docs/benchmarks.md, "Automatic selection"): the tree wins below 64 lamps spread over
// a field among blocks, between 128 and 256 scattered through a room, and never on a ceiling
// grid of up to 1,024 (sampling each lamp once there is stratified over lamps that all matter);
// every light costs one shadow ray per light per sample, so past a few hundred it is the tree.
inline constexpr size_t kTreeAboveLights = 256;
inline LightSelection chosen_light_selection(const RenderScene& s, LightSelection selection) {
    if (selection != LightSelection::automatic) return selection;
    return s.area_lights.size() > kTreeAboveLights && !s.light_tree.empty() ? LightSelection::tree : LightSelection::all;
}

// The density sample_area_light gives direction wi that reaches the light at distance `dist`
// on a triangle with unit normal ng_light.
inline float area_light_pdf(const AreaLight& light, const glm::vec3& ng_light, const glm::vec3& wi, float dist) {
    const float cos_l = std::abs(glm::dot(ng_light, wi));
    return cos_l > 0.f ? dist * dist / (cos_l * light.area) : 0.f;
}
// The same on light triangle `index` at `time` within a shutter (sample_area_light's density
// for a moving light).
inline float area_light_pdf(const RenderScene& s, uint32_t index, const glm::vec3& ng_light, const glm::vec3& wi, float dist,
                            float time) {
    const LightTriangle& tri = s.light_triangles[index];
    const AreaLight& light = s.area_lights[tri.light];
    if (s.motion.light_triangles_close.empty()) return area_light_pdf(light, ng_light, wi, dist);
    const float moved = light_triangle_at(s, index, time).area;
    const float cos_l = std::abs(glm::dot(ng_light, wi));
    return cos_l > 0.f && moved > 0.f ? dist * dist / (cos_l * light.area * (moved / tri.area)) : 0.f;
}

}  // namespace tessera
