#pragma once
// Instances in the scene description: a prototype mesh in its own space and the transforms that
// place it. What the render scene does not instance (emitters, Embree without instancing) and
// what needs world-space geometry (bounds, tests comparing against a flat scene) goes through here.
#include <functional>

#include "engine/geometry/aabb.h"
#include "engine/scene/scene_description.h"

namespace tessera {

// The prototype placed by `to_world` as a world-space mesh: positions transformed, normals by
// the inverse transpose, tangents by the linear part, and faces re-wound where the transform
// mirrors (as the glTF loader places a mesh it does not instance).
MeshDesc placed_mesh(const MeshDesc& prototype, const glm::mat4& to_world);

// Moves the instances `which` accepts (all when empty) into `meshes`, in instance order; a
// prototype no instance places any more is kept (prototype indices stay valid).
void flatten_instances(SceneDescription& scene, const std::function<bool(const InstanceDesc&)>& which = {});

// The box of `box` after an affine transform (of its eight corners).
Aabb transformed_bounds(const Aabb& box, const glm::mat4& to_world);

// Everything the scene places, in world space: meshes, instances and spheres.
Aabb scene_bounds(const SceneDescription& scene);

}  // namespace tessera
