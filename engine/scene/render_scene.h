#pragma once
// The immutable scene a render reads: primitives laid out for intersection in BVH leaf order,
// their shading data (in input order), runtime materials and the camera. Built once per job from a
// SceneDescription, and only from what that scene and job use (see BuildReport).
#include <cstdint>
#include <string>
#include <vector>

#include "engine/accel/bvh.h"
#include "engine/accel/wide_bvh.h"
#include "engine/accel/bvh_traverse.h"
#include "engine/accel/embree_accel.h"
#include "engine/camera/camera.h"
#include "engine/geometry/ray.h"
#include "engine/geometry/triangle4.h"
#include "engine/material/material.h"
#include "engine/scene/light_tree.h"
#include "engine/scene/lights.h"
#include "engine/scene/motion.h"
#include "engine/scene/scene_description.h"

namespace tessera {

enum class TriangleTest { watertight, moller_trumbore };

// `light`: the triangle's entry in light_triangles (its AreaLight is that entry's `light`), or
// kNoLight. Kept here rather than in a side table because the BVH build reorders triangles.
struct TriangleShading { uint32_t n0, n1, n2; uint32_t material; uint32_t light = kNoLight; };
struct Sphere { glm::vec3 center; float radius; uint32_t material; };

inline constexpr uint32_t kNoInstance = ~0u;

// A mesh placed by instances: its triangles are entries of the scene's arrays like any other's
// (tri_shading, tri_blocks, vertex attributes), in a tree of its own over its own space.
struct Prototype {
    WideBvh wide;              // leaves name blocks relative to first_block
    uint32_t first_block = 0;  // in tri_blocks
    uint32_t first_tri = 0, triangles = 0;
    Aabb bounds;               // in its own space
};

// One placement, as traversal reads it: affine maps both ways (columns; the inverse transpose
// of to_world's linear part is to_object's transposed, so normals need no third matrix).
struct Instance {
    glm::mat4x3 to_object;
    glm::mat4x3 to_world;
    uint32_t prototype;
};

// What building the render scene did and left out, and what it cost (reported per job).
struct BuildStage {
    std::string name;
    double seconds = 0.0;
};
struct BuildReport {
    std::vector<std::string> built;
    std::vector<std::string> left_out;
    std::vector<std::string> warnings;
    double seconds = 0.0;
    std::vector<BuildStage> stages;  // where `seconds` went, in order (tessera bench prepare)
};

struct RenderSceneOptions {
    BvhBuildOptions bvh;
    TriangleTest triangle_test = TriangleTest::watertight;
    // Below this many primitives one leaf holds them all. Measured (`tessera bench leave-out`):
    // over 4–12 triangles in blocks of four, one leaf and the SAH BVH (which itself keeps a
    // handful in one or two leaves) are within ±15% with no consistent winner, so only a lone
    // primitive goes without a BVH.
    size_t min_prims_for_bvh = 2;
    EmbreeQuality embree_quality = EmbreeQuality::medium;  // with bvh.type == embree
    // From frame to frame of a shot (with a PrototypeCache), the world-space triangles' tree:
    // `rebuild` builds it and keeps nothing; `keep` builds it and keeps it in the cache;
    // `refit` refits the kept one where this build's triangles are the same meshes (their
    // topology), moved (a skinned or morphed mesh; refit_wide), and else builds it without
    // keeping it; the kept one stays for the next build either way. `automatic` is `rebuild` here; the shot runner chooses per frame (shot_runner.cpp).
    enum class WorldTree { automatic, rebuild, keep, refit };
    WorldTree world_tree = WorldTree::automatic;
    // A refit is refused (the tree built instead) where its SAH cost exceeds the kept tree's as
    // built by more than this fraction: measured with `tessera bench shot --deform`.
    double refit_max_sah_growth = 0.10;
};

struct RenderScene {
    // Triangles as traversal reads them: four to a block, blocks in BVH leaf order. The binary
    // tree they were built with is not kept (its statistics are).
    LargeVector<Triangle4> tri_blocks;
    size_t triangle_count() const { return tri_shading.size(); }
    LargeVector<TriangleShading> tri_shading;   // input order, indexed by Triangle4::prim
    // Where each mesh's triangles begin in tri_shading (world meshes, then prototypes), and the
    // end: a triangle's mesh is its object in the object_id AOV.
    std::vector<uint32_t> mesh_first_tri;
    // Cryptomatte: each object's name (object_id − 1: the meshes in mesh_first_tri's order, then
    // the spheres) and each material's, and their hashes, which a sample records.
    std::vector<std::string> object_names, material_names;
    std::vector<uint32_t> object_hashes, material_hashes;
    LargeVector<glm::vec3> normals;             // shared vertex normals
    // Per vertex like normals, each filled only when a material reads it (empty otherwise):
    // texture coordinate sets 0 and 1, COLOR_0 (white where a mesh has none), tangents (xyz,
    // handedness in w; from the file or generated, engine/scene/surface_textures.h).
    LargeVector<glm::vec2> uv[2];
    LargeVector<glm::vec4> colors;
    LargeVector<glm::vec4> tangents;
    std::vector<std::shared_ptr<const TextureImage>> images;
    std::vector<Texture> textures;
    std::vector<MaterialTextures> material_textures;
    bool has_alpha = false;                     // some material cuts out (MASK) or lets light through (BLEND)
    bool textured_emission = false;             // some emitter's radiance varies over it (emissiveTexture)
    BvhBuildStats tri_bvh_stats;                // the binary tree as built
    WideBvh tri_wide;                           // that tree collapsed kBvhWidth-wide; leaves name blocks
    double tri_build_seconds = 0;               // build, collapse and packing (or Embree's build)
    std::shared_ptr<EmbreeAccel> embree;        // instead of ours, with bvh "embree"
    double embree_build_seconds = 0;            // Embree's alone (also in tri_build_seconds)
    size_t flat_triangles = 0;                  // tri_shading [0, flat_triangles): world space, in tri_wide
    std::vector<Prototype> prototypes;          // meshes placed by instances, each stored and built once
    std::vector<Instance> instances;            // instance_bvh's leaf order
    Bvh instance_bvh;                           // over the instances' world bounds (the top level)
    SceneMotion motion;                         // within a shutter; none for a still
    std::vector<Sphere> spheres;                // BVH leaf order
    Bvh sphere_bvh;
    std::vector<Material> materials;            // last entry: the default grey
    std::vector<AreaLight> area_lights;
    std::vector<LightTriangle> light_triangles;
    LightTree light_tree;  // over light_triangles, for light_selection tree (engine/scene/light_tree.h)
    std::vector<DeltaLight> delta_lights;
    glm::vec3 sky{0.f};                         // CS184 ambient light: radiance from the upper hemisphere
    bool has_sky = false;
    bool has_lights() const { return !area_lights.empty() || !delta_lights.empty() || has_sky; }
    CameraDesc camera;
    Aabb bounds;
    TriangleTest triangle_test = TriangleTest::watertight;
    BuildReport report;
    // Bytes of what intersecting triangles reads: the blocks and the trees (ours or Embree's),
    // with the instances and the tree over them.
    size_t triangle_accel_bytes() const;
};

struct PrototypeCache;  // engine/scene/prototype_cache.h

// `cache`: prototype trees from the previous build of the same scene (a shot's last frame),
// reused where the prototype's triangles are the same; updated for the next build.
// `close`: the same scene at the shutter's closing (`desc` is it at the opening): what moves
// between the two is blurred (engine/scene/motion.h). It must hold the same meshes with the same
// vertex and index counts, the same placements of the same prototypes and the same lights
// (SceneError if not). Not with Embree.
RenderScene build_render_scene(const SceneDescription& desc, const RenderSceneOptions& options, PrototypeCache* cache = nullptr,
                               const SceneDescription* close = nullptr);

}  // namespace tessera
