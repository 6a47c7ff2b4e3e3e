#include "engine/scene/render_scene.h"

#include <chrono>
#include <cmath>

#include "engine/accel/triangle4_leaves.h"
#include "engine/geometry/triangle.h"

namespace tessera {
namespace {

Aabb triangle_bounds(const TriangleVerts& t) {
    Aabb b;
    b.expand(t.p0); b.expand(t.p1); b.expand(t.p2);
    return b;
}

Aabb sphere_bounds(const Sphere& s) { return Aabb{s.center - glm::vec3(s.radius), s.center + glm::vec3(s.radius)}; }

template <class T>
void permute(std::vector<T>& items, const std::vector<uint32_t>& order) {
    std::vector<T> ordered(items.size());
    for (size_t i = 0; i < items.size(); ++i) ordered[i] = items[order[i]];
    items.swap(ordered);
}

// Permutes primitives (and their parallel arrays) into leaf order so that a leaf's primitives
// are adjacent in memory; the BVH's indirection then becomes the identity.
template <class... Arrays>
void to_leaf_order(Bvh& bvh, Arrays&... arrays) {
    (permute(arrays, bvh.prim_index), ...);
    for (size_t i = 0; i < bvh.prim_index.size(); ++i) bvh.prim_index[i] = uint32_t(i);
}

BvhBuildOptions options_for(size_t n, const RenderSceneOptions& o, const char* what, BuildReport& report) {
    BvhBuildOptions b = o.bvh;
    if (n == 0) {
        report.left_out.push_back(std::string(what) + ": none in the scene, no BVH and no intersection path");
    } else if (n < o.min_prims_for_bvh && b.type != BvhType::none) {
        b.type = BvhType::none;
        report.left_out.push_back(std::string(what) + " BVH: " + std::to_string(n) +
                                  " primitives are tested directly (one leaf)");
    }
    return b;
}

// Triangles of every mesh in one list, with their shading records; area-weighted vertex
// normals where the file gave none (as CS184 does); each emissive mesh becomes an area light.
std::vector<TriangleVerts> gather_triangles(const std::vector<const MeshDesc*>& meshes, uint32_t default_material,
                                            RenderScene& s) {
    auto mat = [&](int m) { return m < 0 ? default_material : uint32_t(m); };
    size_t ntri = 0;
    for (const MeshDesc* m : meshes) ntri += m->indices.size() / 3;
    std::vector<TriangleVerts> triangles;
    triangles.reserve(ntri);
    s.tri_shading.reserve(ntri);
    for (const MeshDesc* mp : meshes) {
        const MeshDesc& mesh = *mp;
        const uint32_t base = uint32_t(s.normals.size());
        if (!mesh.normals.empty()) {
            s.normals.insert(s.normals.end(), mesh.normals.begin(), mesh.normals.end());
        } else if (mesh.flat_normals) {
            s.normals.resize(base + mesh.positions.size(), glm::vec3(0.f));  // zero: use the face normal
        } else {
            s.normals.resize(base + mesh.positions.size(), glm::vec3(0.f));
            for (size_t i = 0; i + 2 < mesh.indices.size(); i += 3) {
                const glm::vec3 &a = mesh.positions[mesh.indices[i]], &b = mesh.positions[mesh.indices[i + 1]],
                                &c = mesh.positions[mesh.indices[i + 2]];
                const glm::vec3 n = glm::cross(b - a, c - a);  // length = 2 × area: the weight
                for (int k = 0; k < 3; ++k) s.normals[base + mesh.indices[i + k]] += n;
            }
        }
        for (size_t i = base; i < s.normals.size(); ++i) {
            const float len = glm::length(s.normals[i]);
            s.normals[i] = len > 0.f && std::isfinite(len) ? s.normals[i] / len : glm::vec3(0.f);  // zero: face normal
        }
        const uint32_t m = mat(mesh.material);
        const uint32_t light = s.materials[m].emissive() ? add_area_light(mesh, s.materials[m], s) : kNoLight;
        uint32_t next_light_tri = light == kNoLight ? 0 : s.area_lights[light].first;
        for (size_t i = 0; i + 2 < mesh.indices.size(); i += 3) {
            const uint32_t i0 = mesh.indices[i], i1 = mesh.indices[i + 1], i2 = mesh.indices[i + 2];
            uint32_t light_tri = kNoLight;
            if (light != kNoLight) {
                // The same test add_area_light skips degenerate triangles by.
                const glm::vec3& p0 = mesh.positions[i0];
                const glm::vec3 e1 = mesh.positions[i1] - p0, e2 = mesh.positions[i2] - p0;
                if (0.5f * glm::length(glm::cross(e1, e2)) > 0.f) light_tri = next_light_tri++;
            }
            triangles.push_back({mesh.positions[i0], mesh.positions[i1], mesh.positions[i2]});
            s.tri_shading.push_back({base + i0, base + i1, base + i2, m, light_tri});
        }
    }
    return triangles;
}

// The triangles' acceleration structure (ours, or Embree's), with the triangles packed in the
// order traversal reads them.
void build_triangle_accel(std::vector<TriangleVerts>& triangles, const std::vector<Aabb>& bounds,
                          const RenderSceneOptions& options, RenderScene& s) {
    if (triangles.empty()) {
        options_for(0, options, "triangles", s.report);
    } else if (options.bvh.type == BvhType::embree) {
        s.embree = build_embree(triangles, options.embree_quality, s.embree_build_seconds);
        s.tri_build_seconds = s.embree_build_seconds;
        s.tri_blocks = pack_triangle4_in_order(triangles);  // where surface_at finds Embree's hits
        s.report.built.push_back("triangle BVH (Embree " + std::string(options.embree_quality == EmbreeQuality::low ? "low"
                                 : options.embree_quality == EmbreeQuality::high ? "high" : "medium") +
                                 " quality): " + std::to_string(triangles.size()) + " triangles");
    } else {
        const auto tb = std::chrono::steady_clock::now();
        BvhBuildOptions bo = options_for(triangles.size(), options, "triangles", s.report);
        // SAH: Embree's division of labour. The binary builder splits down to one block, and
        // the collapse merges a subtree back into one leaf (up to max_leaf_size) only where
        // the SAH says a leaf beats one more wide node, so wide nodes fill up with small leaves
        // rather than keep the binary tree's larger ones (maxplanck: 61% of slots filled
        // against 50%, SAH cost 12.3 against 13.2; `tessera bench rays`).
        WideCollapseOptions co;
        if (bo.type == BvhType::sah) {
            co = {bo.max_leaf_size, bo.traversal_cost, bo.intersection_cost, bo.leaf_block};
            bo.max_leaf_size = std::min(bo.max_leaf_size, std::max(1, bo.leaf_block));
        }
        Bvh bvh = build_bvh(bounds, bo);
        to_leaf_order(bvh, triangles, s.tri_shading);
        s.tri_bvh_stats = bvh.stats;
        s.tri_wide = collapse_to_wide(bvh, co);
        s.tri_blocks = pack_triangle4_leaves(s.tri_wide, triangles);
        s.tri_build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - tb).count();
        s.report.built.push_back("triangle BVH (" + std::string(to_string(options.bvh.type)) + "): " +
                                 std::to_string(triangles.size()) + " triangles in " +
                                 std::to_string(s.tri_blocks.size()) + " blocks of four, " +
                                 std::to_string(s.tri_bvh_stats.node_count) + " binary nodes collapsed to " +
                                 std::to_string(s.tri_wide.nodes.size()) + " " + std::to_string(kBvhWidth) + "-wide nodes");
    }
}

// Spheres always take our own path (with Embree too): a list or our BVH beside its triangles.
void build_sphere_accel(const std::vector<Aabb>& bounds, const RenderSceneOptions& options, RenderScene& s) {
    if (s.spheres.empty()) {
        options_for(0, options, "spheres", s.report);
        return;
    }
    RenderSceneOptions sphere_options = options;
    if (sphere_options.bvh.type == BvhType::embree) sphere_options.bvh.type = BvhType::sah;
    sphere_options.bvh.leaf_block = 1;  // spheres are tested one at a time
    s.sphere_bvh = build_bvh(bounds, options_for(s.spheres.size(), sphere_options, "spheres", s.report));
    to_leaf_order(s.sphere_bvh, s.spheres);
    s.report.built.push_back("sphere list: " + std::to_string(s.spheres.size()) + " spheres");
}

}  // namespace

RenderScene build_render_scene(const SceneDescription& desc, const RenderSceneOptions& options) {
    const auto t0 = std::chrono::steady_clock::now();
    RenderScene s;
    s.triangle_test = options.triangle_test;
    s.report.warnings = desc.warnings;

    for (const MaterialDesc& m : desc.materials)
        s.materials.push_back(Material{m.kind, m.albedo, m.emission, m.double_sided});
    const std::vector<MeshDesc> lamps = cs184_lamps_as_meshes(desc, s.materials, s.report);
    add_delta_lights(desc, s);
    const uint32_t default_material = uint32_t(s.materials.size());
    s.materials.push_back(Material{});

    std::vector<const MeshDesc*> meshes;
    for (const MeshDesc& m : desc.meshes) meshes.push_back(&m);
    for (const MeshDesc& m : lamps) meshes.push_back(&m);
    std::vector<TriangleVerts> triangles = gather_triangles(meshes, default_material, s);
    build_power_table(s.area_lights);
    if (s.light_triangles.size() > 1) {
        s.light_tree = build_light_tree(s);
        s.report.built.push_back("light tree over " + std::to_string(s.light_triangles.size()) +
                                 " emitting triangles (light_selection tree)");
    }
    report_lights(desc, s, s.report);
    for (const SphereDesc& sd : desc.spheres)
        s.spheres.push_back({sd.center, sd.radius, sd.material < 0 ? default_material : uint32_t(sd.material)});

    std::vector<Aabb> bounds(triangles.size());
    for (size_t i = 0; i < triangles.size(); ++i) { bounds[i] = triangle_bounds(triangles[i]); s.bounds.expand(bounds[i]); }
    build_triangle_accel(triangles, bounds, options, s);
    bounds.resize(s.spheres.size());
    for (size_t i = 0; i < s.spheres.size(); ++i) { bounds[i] = sphere_bounds(s.spheres[i]); s.bounds.expand(bounds[i]); }
    build_sphere_accel(bounds, options, s);

    if (frame_camera(desc.camera, s.bounds, s.camera))
        s.report.built.push_back("default camera framing the scene (the scene has none)");
    s.report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return s;
}

size_t RenderScene::triangle_accel_bytes() const {
    return tri_blocks.size() * sizeof(Triangle4) + tri_wide.memory_bytes() + (embree ? embree_memory_bytes(*embree) : 0);
}

}  // namespace tessera
