#pragma once
// What a textured material reads at a triangle hit: texture coordinates, vertex colour and
// tangent interpolated over the triangle, its textures looked up there, and the result folded
// into a copy of its BSDF, its emission and the shading normal. Materials without textures,
// alpha or vertex colours never come here (Material::textures is kNoTextures), and a scene
// without any has none of the per-vertex arrays.
#include <span>

#include "engine/geometry/ray.h"
#include "engine/scene/render_scene.h"

namespace tessera {

// The per-vertex arrays the scene's materials read (RenderScene::uv, colors, tangents), for
// meshes whose vertices start at first_vertex[k], after the vertex normals are in place.
// Tangents a file lacks are generated from the normal map's coordinates: per triangle the
// direction of increasing u, projected onto the vertex normal's plane and weighted by the corner
// angle (MikkTSpace's basis, without its splitting of vertices, which glTF files already split
// at seams); the handedness says on which side the direction of decreasing v (the image's up,
// glTF's "+Y up" normal maps) lies.
void gather_vertex_attributes(const std::vector<const MeshDesc*>& meshes, std::span<const size_t> first_vertex,
                              RenderScene& s);

// Alpha at a hit on triangle `prim` of a material with textures: baseColorFactor's alpha ×
// the base colour texture's × the vertex colour's.
float surface_alpha(const RenderScene& s, const MaterialTextures& mt, uint32_t prim, float b1, float b2);

// Whether a ray stops at a hit on triangle `prim`: always for opaque materials; MASK: where alpha
// reaches the cutoff; BLEND: with probability alpha, decided by a hash of the ray and the
// triangle (pbrt-v4's stochastic alpha), so a ray decides the same way however often it is
// traced and for any thread count.
bool alpha_passes(const RenderScene& s, const Ray& ray, uint32_t prim, float b1, float b2);

// The material's inputs at a hit: base colour (× vertex colour), metallic and roughness into
// `bsdf`, and the normal map applied to `ns` (unit, on ng's side). Emission: emission_at.
void apply_textures(const RenderScene& s, const MaterialTextures& mt, uint32_t prim, float b1, float b2, Bsdf& bsdf,
                    glm::vec3& ns, const glm::vec3& ng,
                    uint32_t instance = kNoInstance);

// Emission of material m at a hit on triangle `prim` (its constant where it has no texture).
glm::vec3 emission_at(const RenderScene& s, const Material& m, uint32_t prim, float b1, float b2);

}  // namespace tessera
