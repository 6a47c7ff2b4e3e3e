#pragma once
// Motion within a shutter (a shot's `shutter`): the scene at the shutter's opening and closing,
// and each camera ray's time in [0, 1] between them. The camera and rigid placements move by
// their transforms, interpolated (translation and the symmetric stretch linearly, rotation by
// slerp: a turning placement turns, it does not shrink through the chord); world-space
// vertices (deforming meshes, and emitters, which are all in world space) move linearly from
// their position at the opening to the one at the closing, and light sampling follows the
// emitters (engine/render/light_sampler.h); point lights move linearly, directional lights
// turn. Bounds cover the whole motion.
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "engine/camera/camera.h"
#include "engine/core/large_vector.h"
#include "engine/geometry/aabb.h"
#include "engine/geometry/triangle4.h"
#include "engine/scene/lights.h"

namespace tessera {

// A placement's transform at the opening and the closing, as M = T · R · S (S symmetric: the
// polar decomposition, as pbrt's AnimatedTransform).
struct InstanceMotion {
    glm::vec3 t0{0.f}, t1{0.f};
    glm::quat r0{1, 0, 0, 0}, r1{1, 0, 0, 0};
    glm::mat3 s0{1.f}, s1{1.f};
};

InstanceMotion decompose_motion(const glm::mat4& open, const glm::mat4& close);
// The placement's maps at `time` (0: the opening, 1: the closing).
void instance_maps_at(const InstanceMotion& m, float time, glm::mat4x3& to_world, glm::mat4x3& to_object);
// A box that holds `box` placed at every time in [0, 1] (sampled finely enough that what an arc
// between two samples adds is covered by a pad of half the largest step).
Aabb motion_bounds(const InstanceMotion& m, const Aabb& box);

// The camera at `time`: position, axes (renormalised) and field of view interpolated.
Camera camera_at(const Camera& open, const Camera& close, float time);

// Four triangles at `time`, lane by lane between their opening and closing positions.
inline Triangle4 triangle4_at(const Triangle4& open, const Triangle4& close, float time) {
    Triangle4 b;
    const float* a = &open.p[0][0][0];
    const float* c = &close.p[0][0][0];
    float* o = &b.p[0][0][0];
    for (int i = 0; i < 36; ++i) o[i] = a[i] + time * (c[i] - a[i]);
    for (int l = 0; l < 4; ++l) b.prim[l] = open.prim[l];
    return b;
}

struct SceneMotion {
    bool camera = false;                       // the camera moves (camera_close differs)
    CameraDesc camera_close;
    LargeVector<Triangle4> tri_blocks_close;   // non-empty: the world-space triangles move (tri_blocks' layout)
    LargeVector<glm::vec3> normals_close;      // with them: the vertex normals at the closing
    std::vector<InstanceMotion> instances;     // non-empty: per placement (instance order)
    std::vector<uint8_t> instance_moves;       // per placement: its transform differs at the closing
    // Emitters: the light triangles at the closing (light_triangles' order; their cdf and light
    // as at the opening), non-empty when one moves; the delta lights at the closing, non-empty
    // when one moves.
    std::vector<LightTriangle> light_triangles_close;
    std::vector<DeltaLight> delta_lights_close;
    bool deforming() const { return !tri_blocks_close.empty(); }
    bool emitters() const { return !light_triangles_close.empty() || !delta_lights_close.empty(); }
    bool any() const { return camera || deforming() || !instances.empty() || emitters(); }
};

}  // namespace tessera
