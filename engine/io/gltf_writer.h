#pragma once
// Writes a SceneDescription as glTF 2.0 with an embedded buffer: how our own scenes in
// scenes/ are made (`tessera generate`). Spheres have no glTF form and become icospheres.
#include <string>
#include <vector>

#include "engine/scene/scene_description.h"

namespace tessera {

// Returns the glTF JSON text. `sphere_subdivisions` sets the icosphere resolution (20·4^n faces).
std::string to_gltf(const SceneDescription& scene, int sphere_subdivisions = 3);
void write_gltf(const std::string& path, const SceneDescription& scene, int sphere_subdivisions = 3);
// Bytes as a buffer's embedded `data:` URI (base64), as to_gltf embeds its own.
std::string gltf_data_uri(const std::vector<unsigned char>& bytes);

}  // namespace tessera
