#pragma once
// Intel Embree 3 as one more BVH for triangles (`bvh: "embree"`), so that our own BVH can be
// measured against it on the same scene, rays, integrator and film. Spheres keep our own path
// (a sphere list or BVH next to Embree's triangles). Optional: without Embree at build time,
// embree_available() is false and asking for it is an error.
#include <memory>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "engine/geometry/ray.h"
#include "engine/geometry/triangle.h"

namespace tessera {

struct EmbreeAccel;

enum class EmbreeQuality { low, medium, high };

bool embree_available();

// Meshes placed by instances, for Embree's instancing: a prototype's triangles (ids from
// first_id on) become a scene of their own, and each placement an instance geometry of it.
struct EmbreePrototype {
    std::span<const TriangleVerts> tris;
    uint32_t first_id = 0;
};
struct EmbreePlacement {
    uint32_t prototype = 0;
    glm::mat4x3 to_world{1.f};  // columns: Embree's RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR
};

// Builds Embree's BVH over `tris` (primitive ids are indices into `tris`) and the placements
// (a hit names the prototype's triangle by first_id + its index, and the placement's index);
// throws std::runtime_error when Embree is missing or fails. `build_seconds` receives the build
// time. `threads`: Embree's thread pool (0: one thread per core).
// `filtered`: queries may pass an EmbreeHitFilter (alpha-tested materials).
std::shared_ptr<EmbreeAccel> build_embree(std::span<const TriangleVerts> tris, EmbreeQuality quality,
                                          double& build_seconds, int threads = 0, bool filtered = false,
                                          std::span<const EmbreePrototype> prototypes = {},
                                          std::span<const EmbreePlacement> placements = {});

// What Embree holds for this scene (its memory monitor's count: BVH, primitive blocks and the
// geometry buffers it was given).
size_t embree_memory_bytes(const EmbreeAccel& accel);

// Decides whether a candidate hit counts (Embree's context filter function; needs `filtered`).
struct EmbreeHitFilter {
    bool (*accept)(const void* user, uint32_t prim, float b1, float b2);
    const void* user;
};

// rtcIntersect1: lowers ray.tmax on a hit and returns the triangle and barycentrics of p1, p2,
// and in `instance` the placement hit (~0u for a triangle of `tris`).
bool embree_intersect(const EmbreeAccel& accel, Ray& ray, uint32_t& prim, float& b1, float& b2,
                      const EmbreeHitFilter* filter = nullptr, uint32_t* instance = nullptr);
// rtcOccluded1.
bool embree_occluded(const EmbreeAccel& accel, const Ray& ray, const EmbreeHitFilter* filter = nullptr);

}  // namespace tessera
