#pragma once
// Ray queries against a RenderScene: the closest hit, any hit (shadow rays), and the surface at
// a hit. The hot path of every integrator: plain functions over the scene's flat arrays.
#include "engine/scene/render_scene.h"

namespace tessera {

// Closest hit, as found by traversal; the surface details are computed only for the final hit.
struct Hit {
    float t = INFINITY;
    uint32_t prim = 0;         // triangle (index of tri_shading) or sphere
    float b1 = 0.f, b2 = 0.f;  // barycentrics of p1, p2 (triangles)
    bool sphere = false;
    uint32_t slot = 0;         // triangles: 4 × block + lane, where the vertices are
    uint32_t instance = kNoInstance;  // the placement of a prototype's triangle (prim and slot are the prototype's)
};

struct SurfaceInteraction {
    glm::vec3 p;       // hit point, computed from the surface (barycentrics / sphere), not o + t·d
    glm::vec3 p_err;   // conservative bound on p's rounding error (for spawn.h)
    // p as anchor + local: a vertex of its triangle (a sphere's centre) and the small offset from
    // it. Differences between two nearby points taken anchor to anchor and local to local keep
    // the digits that p's own coordinates lose far from the origin (light_sampler.h).
    glm::vec3 anchor, local;
    glm::vec3 ng;      // unit geometric normal (facing is not flipped)
    glm::vec3 ns;      // unit shading normal, on the same side as ng
    uint32_t material;
    float t;
    uint32_t tri = kNoTriangle;  // the triangle (Hit::prim) p lies on; spawned rays skip it
    uint32_t instance = kNoInstance;  // ... in this placement (a prototype's triangle lies in each)
    float time = 0.f;                 // within the shutter (the ray's): what spawned rays carry
};

// Lowers ray.tmax to the hit distance.
bool intersect(const RenderScene& scene, Ray& ray, Hit& hit, TraversalCounters& counters);
bool occluded(const RenderScene& scene, const Ray& ray, TraversalCounters& counters);
SurfaceInteraction surface_at(const RenderScene& scene, const Ray& ray, const Hit& hit);

}  // namespace tessera
