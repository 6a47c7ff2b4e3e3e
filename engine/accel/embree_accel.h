#pragma once
// Intel Embree 3 as one more BVH for triangles (`bvh: "embree"`), so that our own BVH can be
// measured against it on the same scene, rays, integrator and film. Spheres keep our own path
// (a sphere list or BVH next to Embree's triangles). Optional: without Embree at build time,
// embree_available() is false and asking for it is an error.
#include <memory>
#include <vector>

#include "engine/geometry/ray.h"

namespace tessera {

struct TriangleVerts;
struct EmbreeAccel;

enum class EmbreeQuality { low, medium, high };

bool embree_available();

// Builds Embree's BVH over `tris` (primitive ids are indices into `tris`); throws
// std::runtime_error when Embree is missing or fails. `build_seconds` receives the build time.
std::shared_ptr<EmbreeAccel> build_embree(const std::vector<TriangleVerts>& tris, EmbreeQuality quality,
                                          double& build_seconds);

// What Embree holds for this scene (its memory monitor's count: BVH, primitive blocks and the
// geometry buffers it was given).
size_t embree_memory_bytes(const EmbreeAccel& accel);

// rtcIntersect1: lowers ray.tmax on a hit and returns the triangle and barycentrics of p1, p2.
bool embree_intersect(const EmbreeAccel& accel, Ray& ray, uint32_t& prim, float& b1, float& b2);
// rtcOccluded1.
bool embree_occluded(const EmbreeAccel& accel, const Ray& ray);

}  // namespace tessera
