#pragma once
// Intel Embree 3 as one more BVH for triangles (`bvh: "embree"`), so that our own BVH can be
// measured against it on the same scene, rays, integrator and film. Spheres keep our own path
// (a sphere list or BVH next to Embree's triangles). Optional: without Embree at build time,
// embree_available() is false and asking for it is an error.
#include <memory>
#include <span>
#include <vector>

#include "engine/geometry/ray.h"
#include "engine/geometry/triangle.h"

namespace tessera {

struct EmbreeAccel;

enum class EmbreeQuality { low, medium, high };

bool embree_available();

// Builds Embree's BVH over `tris` (primitive ids are indices into `tris`); throws
// std::runtime_error when Embree is missing or fails. `build_seconds` receives the build time.
// `threads`: Embree's thread pool (0: one thread per core).
// `filtered`: queries may pass an EmbreeHitFilter (alpha-tested materials).
std::shared_ptr<EmbreeAccel> build_embree(std::span<const TriangleVerts> tris, EmbreeQuality quality,
                                          double& build_seconds, int threads = 0, bool filtered = false);

// What Embree holds for this scene (its memory monitor's count: BVH, primitive blocks and the
// geometry buffers it was given).
size_t embree_memory_bytes(const EmbreeAccel& accel);

// Decides whether a candidate hit counts (Embree's context filter function; needs `filtered`).
struct EmbreeHitFilter {
    bool (*accept)(const void* user, uint32_t prim, float b1, float b2);
    const void* user;
};

// rtcIntersect1: lowers ray.tmax on a hit and returns the triangle and barycentrics of p1, p2.
bool embree_intersect(const EmbreeAccel& accel, Ray& ray, uint32_t& prim, float& b1, float& b2,
                      const EmbreeHitFilter* filter = nullptr);
// rtcOccluded1.
bool embree_occluded(const EmbreeAccel& accel, const Ray& ray, const EmbreeHitFilter* filter = nullptr);

}  // namespace tessera
