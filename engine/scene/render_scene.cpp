#include "engine/scene/render_scene.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <span>

#include "engine/accel/triangle4_leaves.h"
#include "engine/core/parallel.h"
#include "engine/geometry/triangle.h"
#include "engine/scene/instancing.h"
#include "engine/scene/prototype_cache.h"
#include "engine/core/murmur3.h"
#include "engine/scene/surface_textures.h"

namespace tessera {
namespace {

// Records each stage's time into the report as the preparation passes it.
class StageClock {
public:
    explicit StageClock(BuildReport& report) : report_(report), last_(std::chrono::steady_clock::now()) {}
    void lap(const char* stage) {
        const auto now = std::chrono::steady_clock::now();
        report_.stages.push_back({stage, std::chrono::duration<double>(now - last_).count()});
        last_ = now;
    }

private:
    BuildReport& report_;
    std::chrono::steady_clock::time_point last_;
};

Aabb triangle_bounds(const TriangleVerts& t) {
    Aabb b;
    b.expand(t.p0); b.expand(t.p1); b.expand(t.p2);
    return b;
}

Aabb sphere_bounds(const Sphere& s) { return Aabb{s.center - glm::vec3(s.radius), s.center + glm::vec3(s.radius)}; }

template <class T>
void permute(std::vector<T>& items, std::span<const uint32_t> order) {
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

// A mesh's vertex normals, unnormalised, added into `normals`: the file's, or area-weighted
// face normals where it gave none (as CS184 does), or none (zero: the face normal) for glTF's
// flat shading.
void add_vertex_normals(const MeshDesc& mesh, glm::vec3* normals) {
    // Normals must pair with positions (validate() checks loaded files; a description
    // built in code that breaks it gets computed normals rather than a misaligned copy).
    if (!mesh.normals.empty() && mesh.normals.size() == mesh.positions.size()) {
        std::copy(mesh.normals.begin(), mesh.normals.end(), normals);
    } else if (!mesh.flat_normals) {
        for (size_t i = 0; i + 2 < mesh.indices.size(); i += 3) {
            const glm::vec3 &a = mesh.positions[mesh.indices[i]], &b = mesh.positions[mesh.indices[i + 1]],
                            &c = mesh.positions[mesh.indices[i + 2]];
            const glm::vec3 n = glm::cross(b - a, c - a);  // length = 2 × area: the weight
            for (int j = 0; j < 3; ++j) normals[mesh.indices[i + j]] += n;
        }
    }
}

void normalise(glm::vec3* normals, size_t n, int threads) {
    parallel_ranges(n, pass_threads(n, threads), [&](size_t begin, size_t end, int) {
        for (size_t i = begin; i < end; ++i) {
            const float len = glm::length(normals[i]);
            normals[i] = len > 0.f && std::isfinite(len) ? normals[i] / len : glm::vec3(0.f);  // zero: face normal
        }
    });
}

// Triangles of every mesh in one list, in input order (which the shading records keep), with
// their shading records; area-weighted vertex normals where the file gave none (as CS184 does);
// each emissive mesh becomes an area light. Expands s.bounds by the triangles. The per-triangle
// passes run on `threads` threads over disjoint ranges, so the result is the same for any count.
// Meshes from `world_meshes` on are prototypes, in their own space: they add no bounds and no lights.
LargeVector<TriangleVerts> gather_triangles(const std::vector<const MeshDesc*>& meshes, size_t world_meshes,
                                            uint32_t default_material, int threads, RenderScene& s) {
    auto mat = [&](int m) { return m < 0 ? default_material : uint32_t(m); };
    std::vector<size_t> first_tri(meshes.size() + 1, 0), first_vertex(meshes.size() + 1, 0);
    for (size_t k = 0; k < meshes.size(); ++k) {
        first_tri[k + 1] = first_tri[k] + meshes[k]->indices.size() / 3;
        first_vertex[k + 1] = first_vertex[k] + meshes[k]->positions.size();
    }
    const size_t ntri = first_tri.back();
    s.mesh_first_tri.assign(first_tri.begin(), first_tri.end());

    s.normals.resize(first_vertex.back(), glm::vec3(0.f));  // zero: use the face normal
    for (size_t k = 0; k < meshes.size(); ++k) add_vertex_normals(*meshes[k], s.normals.data() + first_vertex[k]);
    normalise(s.normals.data(), s.normals.size(), threads);

    std::vector<uint32_t> mesh_light(meshes.size(), kNoLight);
    for (size_t k = 0; k < world_meshes; ++k) {
        const uint32_t m = mat(meshes[k]->material);
        if (s.materials[m].emissive()) mesh_light[k] = add_area_light(*meshes[k], s.materials[m], m, s);
    }
    gather_vertex_attributes(meshes, first_vertex, s);

    LargeVector<TriangleVerts> triangles(ntri);
    s.tri_shading.resize(ntri);
    const int parts = pass_threads(ntri, threads);
    std::vector<Aabb> part_bounds(static_cast<size_t>(parts));
    const size_t world_tris = first_tri[world_meshes];
    parallel_ranges(ntri, parts, [&](size_t begin, size_t end, int part) {
        Aabb box;
        size_t k = size_t(std::upper_bound(first_tri.begin(), first_tri.end(), begin) - first_tri.begin()) - 1;
        for (size_t t = begin; t < end; ++t) {
            while (t >= first_tri[k + 1]) ++k;
            const MeshDesc& mesh = *meshes[k];
            const size_t i = 3 * (t - first_tri[k]);
            const uint32_t i0 = mesh.indices[i], i1 = mesh.indices[i + 1], i2 = mesh.indices[i + 2];
            triangles[t] = {mesh.positions[i0], mesh.positions[i1], mesh.positions[i2]};
            if (t < world_tris) { box.expand(triangles[t].p0); box.expand(triangles[t].p1); box.expand(triangles[t].p2); }
            const uint32_t base = uint32_t(first_vertex[k]);
            s.tri_shading[t] = {base + i0, base + i1, base + i2, mat(mesh.material), kNoLight};
        }
        part_bounds[size_t(part)] = box;
    });
    for (const Aabb& b : part_bounds) s.bounds.expand(b);

    // Each emitting triangle's entry in light_triangles: add_area_light skipped the degenerate
    // ones, by the same test.
    for (size_t k = 0; k < meshes.size(); ++k) {
        if (mesh_light[k] == kNoLight) continue;
        uint32_t next = s.area_lights[mesh_light[k]].first;
        for (size_t t = first_tri[k]; t < first_tri[k + 1]; ++t) {
            const TriangleVerts& v = triangles[t];
            if (0.5f * glm::length(glm::cross(v.p1 - v.p0, v.p2 - v.p0)) > 0.f) {
                s.light_triangles[next].prim = uint32_t(t);
                s.tri_shading[t].light = next++;
            }
        }
    }
    return triangles;
}

// Our tree over `tris` (a span of `all`), collapsed wide, its blocks appended to `blocks`
// (leaves name them from the first appended). `first_id`: the id of tris[0] in `all`, which
// lanes name; empty when tris is all of it.
// `close`: the same triangles at the shutter's closing (empty: they do not move): the tree is
// built over boxes holding both, and `close_blocks` receives them packed as the blocks are.
WideBvh build_wide(std::span<const TriangleVerts> tris, std::span<const TriangleVerts> all, std::optional<uint32_t> first_id,
                   BvhBuildOptions bo, int threads, LargeVector<Triangle4>& blocks, BvhBuildStats& stats, StageClock* clock,
                   std::span<const TriangleVerts> close = {}, LargeVector<Triangle4>* close_blocks = nullptr) {
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
    Bvh bvh = close.empty() ? build_bvh(tris.size(), [tris](size_t i) { return triangle_bounds(tris[i]); }, bo)
                            : build_bvh(tris.size(), [tris, close](size_t i) {
                                  return merge(triangle_bounds(tris[i]), triangle_bounds(close[i]));
                              }, bo);
    if (clock) clock->lap("bvh build");
    stats = bvh.stats;
    WideBvh wide = collapse_to_wide(bvh, co);
    if (clock) clock->lap("collapse");
    if (first_id)
        for (uint32_t& i : bvh.prim_index) i += *first_id;
    if (close_blocks) {
        WideBvh again = wide;  // packing rewrites the leaves: the closing's blocks from the same tree
        *close_blocks = pack_triangle4_leaves(again, close, bvh.prim_index, threads);
    }
    LargeVector<Triangle4> packed = pack_triangle4_leaves(wide, all, bvh.prim_index, threads);
    if (blocks.empty()) blocks = std::move(packed);
    else blocks.insert(blocks.end(), packed.begin(), packed.end());
    if (clock) clock->lap("pack blocks");
    return wide;
}

// The triangles' acceleration structure (ours, or Embree's), with the triangles packed in the
// order traversal reads them. Lanes name triangles by input index, as tri_shading is kept.
// `cache` with options.world_tree refit: the last build's world tree, refitted where this
// build's world-space triangles are the same meshes (their topology), moved, and kept for the
// next build either way.
void build_triangle_accel(std::span<const TriangleVerts> all, std::span<const TriangleVerts> close, const RenderSceneOptions& options,
                          RenderScene& s, StageClock& clock, PrototypeCache* cache) {
    const int threads = options.bvh.build_threads;
    const std::span<const TriangleVerts> triangles = all.first(s.flat_triangles);
    if (triangles.empty() && (options.bvh.type != BvhType::embree || s.instances.empty())) {
        options_for(0, options, "triangles", s.report);
    } else if (options.bvh.type == BvhType::embree) {
        // Embree's instancing: a scene per prototype, an instance geometry per placement.
        std::vector<EmbreePrototype> prototypes;
        for (const Prototype& p : s.prototypes) prototypes.push_back({all.subspan(p.first_tri, p.triangles), p.first_tri});
        std::vector<EmbreePlacement> placements;
        for (const Instance& in : s.instances) placements.push_back({in.prototype, in.to_world});
        s.embree = build_embree(triangles, options.embree_quality, s.embree_build_seconds, threads, s.has_alpha, prototypes, placements);
        clock.lap("embree build");
        s.tri_build_seconds = s.embree_build_seconds;
        s.tri_blocks = pack_triangle4_in_order(all, threads);  // where surface_at finds Embree's hits
        clock.lap("pack blocks");
        s.report.built.push_back("triangle BVH (Embree " + std::string(options.embree_quality == EmbreeQuality::low ? "low"
                                 : options.embree_quality == EmbreeQuality::high ? "high" : "medium") +
                                 " quality): " + std::to_string(triangles.size()) + " triangles" +
                                 (s.instances.empty() ? std::string() : ", and its instancing for the placements"));
    } else {
        const auto tb = std::chrono::steady_clock::now();
        const BvhBuildOptions bo = options_for(triangles.size(), options, "triangles", s.report);
        using WorldTree = RenderSceneOptions::WorldTree;
        const bool refit = cache && options.world_tree == WorldTree::refit, keep = cache && options.world_tree == WorldTree::keep;
        static_assert(sizeof(TriangleShading) == 20);
        const PrototypeCache::Key topology =
            refit || keep ? PrototypeCache::key_of_bytes(s.tri_shading.data(), triangles.size() * sizeof(TriangleShading), triangles.size(), bo)
                          : PrototypeCache::Key{};
        std::string refit_refused;
        // Kept for the next frames whether or not this one can use it: what a frame is built
        // from depends on the kept tree's frame alone, not on the frames before it.
        if (refit && cache->world) cache->world->used = true;
        if (refit && cache->world && cache->world->key == topology) {
            // The same meshes as the kept tree's: that tree over their vertices as they are now,
            // unless they have moved so far that its SAH cost has grown past the bound (then a
            // build costs less than the slower rays would).
            PrototypeCache::World& w = *cache->world;
            WideBvh refitted = w.wide;
            LargeVector<Triangle4> blocks = repack_triangle4(w.lanes, triangles, threads);
            LargeVector<Triangle4> close_blocks = close.empty() ? LargeVector<Triangle4>{} : repack_triangle4(w.lanes, close, threads);
            refit_wide(refitted, blocks, close_blocks);
            const double sah = wide_bvh_stats(refitted).sah;
            char costs[128];
            std::snprintf(costs, sizeof costs, "SAH cost %.4f, %.4f as built", sah, w.built_sah);
            if (sah <= w.built_sah * (1.0 + options.refit_max_sah_growth)) {
                ++cache->world_refits;
                s.tri_wide = std::move(refitted);
                s.tri_bvh_stats = w.stats;
                s.tri_blocks = std::move(blocks);
                s.motion.tri_blocks_close = std::move(close_blocks);
                s.tri_build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - tb).count();
                clock.lap("bvh refit");
                s.report.built.push_back("triangle BVH refitted: the kept tree over " + std::to_string(triangles.size()) +
                                         " moved triangles (" + costs + ")");
                return;
            }
            clock.lap("bvh refit tried");
            refit_refused = std::string(", the kept tree's refit refused (") + costs + ", over the bound)";
        }
        BvhBuildStats stats;
        s.tri_wide = build_wide(triangles, triangles, {}, bo, threads, s.tri_blocks, stats, &clock, close,
                                close.empty() ? nullptr : &s.motion.tri_blocks_close);
        s.tri_bvh_stats = stats;
        s.tri_build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - tb).count();
        if (keep) {
            PrototypeCache::World w{topology, s.tri_wide, std::vector<uint32_t>(s.tri_blocks.size() * 4),
                                    wide_bvh_stats(s.tri_wide).sah, stats, true};
            for (size_t b = 0; b < s.tri_blocks.size(); ++b)
                for (int l = 0; l < 4; ++l) w.lanes[4 * b + size_t(l)] = s.tri_blocks[b].prim[l];
            cache->world = std::move(w);
            ++cache->world_builds;
        }
        s.report.built.push_back("triangle BVH (" + std::string(to_string(options.bvh.type)) + "): " +
                                 std::to_string(triangles.size()) + " triangles in " +
                                 std::to_string(s.tri_blocks.size()) + " blocks of four, " +
                                 std::to_string(s.tri_bvh_stats.node_count) + " binary nodes collapsed to " +
                                 std::to_string(s.tri_wide.nodes.size()) + " " + std::to_string(kBvhWidth) + "-wide nodes" +
                                 refit_refused);
    }
}

// The instances' two levels: a tree per prototype over its own triangles, and one over the
// placements' world boxes. A prototype is built once however often it is placed.
void build_instances(std::span<const TriangleVerts> triangles, const std::vector<const InstanceDesc*>& placements,
                     const std::vector<uint32_t>& prototype_first_tri, const std::vector<uint32_t>& prototype_tris,
                     const RenderSceneOptions& options, RenderScene& s, PrototypeCache* cache,
                     const std::vector<glm::mat4>& close) {
    if (placements.empty()) {
        s.report.left_out.push_back("instances: none in the scene (one level of BVH)");
        return;
    }
    const int threads = options.bvh.build_threads;
    const bool embree = options.bvh.type == BvhType::embree;  // Embree builds both levels (build_triangle_accel)
    size_t stored = 0, placed = 0, reused = 0;
    for (size_t k = 0; k < prototype_first_tri.size(); ++k) {
        Prototype p;
        p.first_tri = prototype_first_tri[k];
        p.triangles = prototype_tris[k];
        p.first_block = uint32_t(s.tri_blocks.size());
        const std::span<const TriangleVerts> tris = triangles.subspan(p.first_tri, p.triangles);
        BvhBuildOptions bo = options.bvh;
        if (p.triangles < options.min_prims_for_bvh) bo.type = BvhType::none;
        const PrototypeCache::Key key = cache && !embree ? PrototypeCache::key_of(tris, bo) : PrototypeCache::Key{};
        PrototypeCache::Entry* hit = cache && !embree ? cache->find(key) : nullptr;
        if (hit) p.bounds = hit->bounds;
        else
            for (const TriangleVerts& t : tris) p.bounds.expand(triangle_bounds(t));
        if (!embree) {
            if (PrototypeCache::Entry* e = hit) {
                // The same triangles as in the last build: its tree and blocks, renumbered.
                e->used = true;
                ++cache->hits;
                ++reused;
                p.wide = e->wide;
                s.tri_blocks.insert(s.tri_blocks.end(), e->blocks.begin(), e->blocks.end());
                for (size_t b = p.first_block; b < s.tri_blocks.size(); ++b)
                    for (int l = 0; l < 4; ++l) s.tri_blocks[b].prim[l] += p.first_tri;
            } else {
                BvhBuildStats stats;
                p.wide = build_wide(tris, triangles, p.first_tri, bo, threads, s.tri_blocks, stats, nullptr);
                if (cache) {
                    ++cache->misses;
                    PrototypeCache::Entry entry{key, p.wide, {}, p.bounds, true};
                    entry.blocks.assign(s.tri_blocks.begin() + long(p.first_block), s.tri_blocks.end());
                    for (Triangle4& block : entry.blocks)
                        for (int l = 0; l < 4; ++l) block.prim[l] -= p.first_tri;
                    cache->entries.push_back(std::move(entry));
                }
            }
        }
        stored += p.triangles;
        s.prototypes.push_back(std::move(p));
    }
    std::vector<Aabb> bounds;
    bounds.reserve(placements.size());
    // Placements that move within the shutter (`close`: each one's transform at the closing).
    bool moving = false;
    for (size_t k = 0; k < close.size(); ++k) moving |= close[k] != placements[k]->to_world;
    for (size_t k = 0; k < placements.size(); ++k) {
        const InstanceDesc* in = placements[k];
        const glm::dmat4 m(in->to_world);
        s.instances.push_back({glm::mat4x3(glm::mat4(glm::inverse(m))), glm::mat4x3(in->to_world), in->prototype});
        const Prototype& p = s.prototypes[in->prototype];
        if (moving) {
            const bool moves = close[k] != in->to_world;
            s.motion.instances.push_back(decompose_motion(in->to_world, close[k]));
            s.motion.instance_moves.push_back(moves);
            bounds.push_back(moves ? motion_bounds(s.motion.instances.back(), p.bounds) : transformed_bounds(p.bounds, in->to_world));
        } else {
            bounds.push_back(transformed_bounds(p.bounds, in->to_world));
        }
        s.bounds.expand(bounds.back());
        placed += p.triangles;
    }
    if (!embree) {
        BvhBuildOptions top = options.bvh;
        top.leaf_block = 1;  // instances are entered one at a time
        top.max_leaf_size = 2;
        if (placements.size() < options.min_prims_for_bvh) top.type = BvhType::none;
        s.instance_bvh = build_bvh(bounds, top);
        if (moving) to_leaf_order(s.instance_bvh, s.instances, s.motion.instances, s.motion.instance_moves);
        else to_leaf_order(s.instance_bvh, s.instances);
    }
    s.report.built.push_back("instances: " + std::to_string(s.instances.size()) + " placements of " +
                             std::to_string(s.prototypes.size()) + " prototype mesh(es), " + std::to_string(stored) +
                             " triangles stored for " + std::to_string(placed) +
                             " placed (" + (embree ? "Embree's instancing" : "a BVH per prototype under one over the placements") + ")" +
                             (reused ? ", " + std::to_string(reused) + " prototype tree(s) kept from the previous frame" : ""));
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

// Which BSDFs the scene uses: one with none but Lambertian ones never evaluates anything but
// albedo/π, and one without delta lobes never takes their branches.
void report_materials(const std::vector<Material>& materials, BuildReport& report) {
    static constexpr const char* names[] = {"lambertian", "mirror", "glass", "conductor (Beckmann)", "glossy (Phong)",
                                            "glTF metallic-roughness (GGX)"};
    size_t counts[std::size(names)] = {}, delta = 0;
    for (const Material& m : materials) {
        ++counts[size_t(m.bsdf.kind)];
        if (bsdf_has_delta(m.bsdf)) ++delta;
    }
    std::string used;
    for (size_t k = 0; k < std::size(names); ++k)
        if (counts[k]) used += (used.empty() ? "" : ", ") + std::to_string(counts[k]) + " " + names[k];
    report.built.push_back("materials: " + used);
    if (counts[0] == materials.size())
        report.left_out.push_back("non-Lambertian BSDFs: every material is Lambertian (f = albedo/π, cosine sampling)");
    else if (!delta)
        report.left_out.push_back("delta BSDF paths: no mirror, glass or smooth lobe (α < 0.001) in the scene");
    else
        report.built.push_back("delta lobes (mirror, glass, smooth metal or coat): " + std::to_string(delta) +
                               " material(s), sampled from the BSDF only");
}

// What the materials read per hit (textures, alpha, vertex colours): one MaterialTextures each,
// and the images they use; materials that read none keep the untextured path.
void add_material_textures(const SceneDescription& desc, RenderScene& s) {
    std::vector<char> coloured(desc.materials.size(), 0);
    for (const std::vector<MeshDesc>* list : {&desc.meshes, &desc.prototypes})
        for (const MeshDesc& m : *list)
            if (m.material >= 0 && !m.colors.empty()) coloured[size_t(m.material)] = 1;
    size_t textured = 0;
    for (size_t i = 0; i < desc.materials.size(); ++i) {
        const MaterialDesc& d = desc.materials[i];
        const bool alpha = d.alpha_mode != AlphaMode::opaque;
        if (!d.textured() && !alpha && !coloured[i]) continue;
        MaterialTextures mt{d.base_color_tex, d.metallic_roughness_tex, d.emissive_tex, d.normal_tex, d.alpha, d.alpha_mode,
                            d.alpha_cutoff, coloured[i] != 0};
        s.has_alpha |= alpha;
        s.textured_emission |= d.emissive_tex.used() && d.emits();
        textured += d.textured();
        s.materials[i].textures = uint32_t(s.material_textures.size());
        s.material_textures.push_back(mt);
    }
    if (textured) {
        s.images = desc.images;
        s.textures = desc.textures;
        size_t bytes = 0;
        for (const auto& img : s.images) bytes += img->rgba.size();
        s.report.built.push_back("textures: " + std::to_string(s.textures.size()) + " over " + std::to_string(s.images.size()) +
                                 " image(s), " + std::to_string(bytes >> 10) + " KiB of texels, read by " +
                                 std::to_string(textured) + " material(s) (bilinear, no MIP maps)");
    } else {
        s.report.left_out.push_back("textures: no material reads one (no texture lookups, coordinates or tangent frames)");
    }
    if (!s.has_alpha) s.report.left_out.push_back("alpha tests: every material is opaque");
    else s.report.built.push_back("alpha tests in intersection (alphaMode MASK and BLEND)");
}

// A scene at the shutter's closing must be the opening's, moved: the same meshes with the same
// counts, the same placements of the same prototypes.
void check_motion_shape(const SceneDescription& a, const SceneDescription& b, const RenderSceneOptions& o) {
    const SourceLocation where{a.source, 0, ""};
    if (o.bvh.type == BvhType::embree)
        throw SceneError(where, "motion blur (a shutter) is traced by our BVH only: bvh \"embree\" cannot take it");
    if (a.meshes.size() != b.meshes.size() || a.instances.size() != b.instances.size() || a.prototypes.size() != b.prototypes.size() ||
        a.spheres.size() != b.spheres.size())
        throw SceneError(where, "the scene's meshes or placements change within the shutter (" + std::to_string(a.meshes.size()) +
                                    " meshes and " + std::to_string(a.instances.size()) + " placements at the opening, " +
                                    std::to_string(b.meshes.size()) + " and " + std::to_string(b.instances.size()) +
                                    " at the closing): motion blur needs the same geometry, moved");
    for (size_t k = 0; k < a.meshes.size(); ++k)
        if (a.meshes[k].positions.size() != b.meshes[k].positions.size() || a.meshes[k].indices.size() != b.meshes[k].indices.size())
            throw SceneError(a.meshes[k].origin, "mesh '" + a.meshes[k].name + "' changes its vertices or faces within the shutter");
    for (size_t k = 0; k < a.instances.size(); ++k)
        if (a.instances[k].prototype != b.instances[k].prototype)
            throw SceneError(a.instances[k].origin, "placement " + std::to_string(k) + " places another mesh at the shutter's closing");
}

// The world-space triangles at the shutter's closing, in gather_triangles' order (the meshes,
// `lamps`, then the emitting placements `placed`, indices into the instances), and their vertex
// normals into s.motion.normals_close. The CS184 lamps do not move (their files do not animate).
// Empty when no triangle moves.
LargeVector<TriangleVerts> closing_triangles(const SceneDescription& open, const SceneDescription& close,
                                             const std::vector<MeshDesc>& lamps, const std::vector<size_t>& placed,
                                             std::span<const TriangleVerts> opening, RenderScene& s) {
    LargeVector<TriangleVerts> out(opening.begin(), opening.end());
    LargeVector<glm::vec3> normals = s.normals;
    bool moved = false;
    size_t t = 0, v = 0;
    auto move = [&](const MeshDesc& a, const MeshDesc& b) {
        const size_t tris = a.indices.size() / 3;
        if (a.positions != b.positions) {
            for (size_t i = 0; i < tris; ++i)
                out[t + i] = {b.positions[b.indices[3 * i]], b.positions[b.indices[3 * i + 1]], b.positions[b.indices[3 * i + 2]]};
            std::fill(normals.begin() + long(v), normals.begin() + long(v + a.positions.size()), glm::vec3(0.f));
            add_vertex_normals(b, normals.data() + v);
            normalise(normals.data() + v, a.positions.size(), 1);
            moved = true;
        }
        t += tris;
        v += a.positions.size();
    };
    for (size_t k = 0; k < open.meshes.size(); ++k) move(open.meshes[k], close.meshes[k]);
    for (const MeshDesc& lamp : lamps) move(lamp, lamp);
    for (size_t k : placed) {
        const MeshDesc& proto = open.prototypes[open.instances[k].prototype];
        move(placed_mesh(proto, open.instances[k].to_world), placed_mesh(proto, close.instances[k].to_world));
    }
    if (!moved) return {};
    s.motion.normals_close = std::move(normals);
    return out;
}

// The light triangles where `closing` (closing_triangles) puts them, into s.motion when one moves.
void close_light_triangles(std::span<const TriangleVerts> closing, RenderScene& s) {
    std::vector<LightTriangle> out = s.light_triangles;
    bool moved = false;
    for (LightTriangle& lt : out) {
        const TriangleVerts& c = closing[lt.prim];
        const glm::vec3 e1 = c.p1 - c.p0, e2 = c.p2 - c.p0, n = glm::cross(e1, e2);
        if (c.p0 == lt.p0 && e1 == lt.e1 && e2 == lt.e2) continue;
        const float len = glm::length(n);
        lt.p0 = c.p0;
        lt.e1 = e1;
        lt.e2 = e2;
        lt.area = 0.5f * len;
        if (len > 0.f) lt.n = n / len;  // degenerate at the closing: it cannot be sampled there (light_triangle_at)
        moved = true;
    }
    if (moved) s.motion.light_triangles_close = std::move(out);
}

// The delta lights at the closing, into s.motion when one moves; the same lights must be there.
void close_delta_lights(const SceneDescription& open, const SceneDescription& close, RenderScene& s) {
    RenderScene closing;
    add_delta_lights(close, closing);
    if (closing.delta_lights.size() != s.delta_lights.size())
        throw SceneError(SourceLocation{open.source, 0, ""}, "the scene's lights change within the shutter (" +
                                                                  std::to_string(s.delta_lights.size()) + " at the opening, " +
                                                                  std::to_string(closing.delta_lights.size()) + " at the closing)");
    for (size_t k = 0; k < s.delta_lights.size(); ++k) {
        const DeltaLight &a = s.delta_lights[k], &b = closing.delta_lights[k];
        if (a.kind != b.kind)
            throw SceneError(SourceLocation{open.source, 0, ""}, "light " + std::to_string(k) + " changes its kind within the shutter");
        if (a.position != b.position || a.direction != b.direction) {
            for (size_t j = 0; j < s.delta_lights.size(); ++j) closing.delta_lights[j].intensity = s.delta_lights[j].intensity;
            s.motion.delta_lights_close = std::move(closing.delta_lights);
            return;
        }
    }
}

bool same_camera(const CameraDesc& a, const CameraDesc& b) {
    return a.position == b.position && a.look_at == b.look_at && a.up == b.up && a.vfov_deg == b.vfov_deg &&
           a.hfov_deg == b.hfov_deg && a.focal_px == b.focal_px;
}

// Cryptomatte's names: the file's, or the kind and number where it gave none (a lamp the loader
// made, a sphere). Objects of one name share a matte, as the specification intends.
void name_objects(const SceneDescription& desc, const std::vector<const MeshDesc*>& meshes, uint32_t default_material, RenderScene& s) {
    for (size_t k = 0; k < meshes.size(); ++k)
        s.object_names.push_back(meshes[k]->name.empty() ? "mesh " + std::to_string(k) : meshes[k]->name);
    for (size_t k = 0; k < desc.spheres.size(); ++k) s.object_names.push_back("sphere " + std::to_string(k));
    for (size_t m = 0; m < s.materials.size(); ++m) {
        if (m < desc.materials.size() && !desc.materials[m].name.empty()) s.material_names.push_back(desc.materials[m].name);
        else if (m == default_material) s.material_names.emplace_back("default");
        else s.material_names.push_back((m < desc.materials.size() ? "material " : "light ") + std::to_string(m));
    }
    for (const std::string& n : s.object_names) s.object_hashes.push_back(murmur3_32(n));
    for (const std::string& n : s.material_names) s.material_hashes.push_back(murmur3_32(n));
}

}  // namespace

RenderScene build_render_scene(const SceneDescription& desc, const RenderSceneOptions& options, PrototypeCache* cache,
                               const SceneDescription* close) {
    const auto t0 = std::chrono::steady_clock::now();
    RenderScene s;
    StageClock clock(s.report);
    s.triangle_test = options.triangle_test;
    s.report.warnings = desc.warnings;
    if (close) check_motion_shape(desc, *close, options);

    for (const MaterialDesc& m : desc.materials)
        s.materials.push_back(make_material(m));
    add_material_textures(desc, s);
    const std::vector<MeshDesc> lamps = cs184_lamps_as_meshes(desc, s.materials, s.report);
    add_delta_lights(desc, s);
    const uint32_t default_material = uint32_t(s.materials.size());
    s.materials.push_back(Material{});
    report_materials(s.materials, s.report);

    // Instances stay instances unless their mesh emits (light sampling needs world-space
    // triangles): those are placed as world-space meshes.
    std::vector<MeshDesc> placed;
    std::vector<size_t> placed_from;  // the instances `placed` holds
    std::vector<const InstanceDesc*> placements;
    std::vector<uint32_t> prototype_slot(desc.prototypes.size(), kNoInstance);  // its index among those kept
    std::vector<const MeshDesc*> kept_prototypes;
    for (const InstanceDesc& in : desc.instances) {
        const MeshDesc& proto = desc.prototypes[in.prototype];
        const bool emits = proto.material >= 0 && s.materials[size_t(proto.material)].emissive();
        if (emits) {
            placed.push_back(placed_mesh(proto, in.to_world));
            placed.back().origin = in.origin;
            placed_from.push_back(size_t(&in - desc.instances.data()));
            continue;
        }
        if (prototype_slot[in.prototype] == kNoInstance) {
            prototype_slot[in.prototype] = uint32_t(kept_prototypes.size());
            kept_prototypes.push_back(&proto);
        }
        placements.push_back(&in);
    }
    std::vector<InstanceDesc> renumbered;  // prototype indices among those kept
    renumbered.reserve(placements.size());
    for (const InstanceDesc* in : placements) {
        renumbered.push_back(*in);
        renumbered.back().prototype = prototype_slot[in->prototype];
    }
    std::vector<const InstanceDesc*> kept_instances;
    for (const InstanceDesc& in : renumbered) kept_instances.push_back(&in);

    std::vector<const MeshDesc*> meshes;
    for (const MeshDesc& m : desc.meshes) meshes.push_back(&m);
    for (const MeshDesc& m : lamps) meshes.push_back(&m);
    for (const MeshDesc& m : placed) meshes.push_back(&m);
    const size_t world_meshes = meshes.size();
    for (const MeshDesc* m : kept_prototypes) meshes.push_back(m);
    const LargeVector<TriangleVerts> triangles =
        gather_triangles(meshes, world_meshes, default_material, options.bvh.build_threads, s);
    std::vector<uint32_t> prototype_first_tri, prototype_tris;
    size_t next = 0;
    for (size_t k = 0; k < meshes.size(); ++k) {
        const size_t n = meshes[k]->indices.size() / 3;
        if (k < world_meshes) s.flat_triangles += n;
        else { prototype_first_tri.push_back(uint32_t(next)); prototype_tris.push_back(uint32_t(n)); }
        next += n;
    }
    clock.lap("gather");
    const std::span<const TriangleVerts> all(triangles.data(), triangles.size());
    // Within a shutter: the world-space triangles, the emitters and the placements at its closing.
    const LargeVector<TriangleVerts> closing =
        close ? closing_triangles(desc, *close, lamps, placed_from, all.first(s.flat_triangles), s) : LargeVector<TriangleVerts>{};
    if (!closing.empty()) close_light_triangles(std::span<const TriangleVerts>(closing.data(), closing.size()), s);
    if (close) close_delta_lights(desc, *close, s);
    build_power_table(s.area_lights);
    if (s.light_triangles.size() > 1) {
        s.light_tree = build_light_tree(s);
        s.report.built.push_back("light tree over " + std::to_string(s.light_triangles.size()) +
                                 " emitting triangles (light_selection tree)");
    }
    report_lights(desc, s, s.report);
    clock.lap("lights");
    for (const SphereDesc& sd : desc.spheres)
        s.spheres.push_back({sd.center, sd.radius, sd.material < 0 ? default_material : uint32_t(sd.material)});

    std::vector<glm::mat4> closing_placements;
    if (close)
        for (const InstanceDesc* in : placements) closing_placements.push_back(close->instances[size_t(in - desc.instances.data())].to_world);
    // Ours: the world-space triangles' blocks first, each prototype's appended. Embree: the
    // placements first, which its one build then takes in.
    if (options.bvh.type == BvhType::embree) {
        build_instances(all, kept_instances, prototype_first_tri, prototype_tris, options, s, cache, closing_placements);
        build_triangle_accel(all, {}, options, s, clock, nullptr);
    } else {
        build_triangle_accel(all, std::span<const TriangleVerts>(closing.data(), closing.size()), options, s, clock, cache);
        build_instances(all, kept_instances, prototype_first_tri, prototype_tris, options, s, cache, closing_placements);
        if (!kept_instances.empty()) clock.lap("instances");
    }
    name_objects(desc, meshes, default_material, s);
    std::vector<Aabb> bounds(s.spheres.size());
    for (size_t i = 0; i < s.spheres.size(); ++i) { bounds[i] = sphere_bounds(s.spheres[i]); s.bounds.expand(bounds[i]); }
    build_sphere_accel(bounds, options, s);
    clock.lap("spheres");

    if (frame_camera(desc.camera, s.bounds, s.camera)) {
        // Where it stands, so that another renderer can be given the same view (scripts/bench_cycles.sh).
        char where[256];
        std::snprintf(where, sizeof where, "from (%.6g, %.6g, %.6g) toward (%.6g, %.6g, %.6g), vertical field of view %.6g°",
                      s.camera.position.x, s.camera.position.y, s.camera.position.z, s.camera.look_at.x, s.camera.look_at.y,
                      s.camera.look_at.z, s.camera.vfov_deg);
        s.report.built.push_back(std::string("default camera framing the scene (the scene has none): ") + where);
    }
    if (close && close->camera && desc.camera) {
        CameraDesc c;
        frame_camera(close->camera, s.bounds, c);
        if (!same_camera(c, s.camera)) {
            s.motion.camera = true;
            s.motion.camera_close = c;
        }
    }
    if (close) {
        size_t moving = 0;
        for (uint8_t m : s.motion.instance_moves) moving += m;
        if (s.motion.any())
            s.report.built.push_back(std::string("motion blur within the shutter: ") + (s.motion.camera ? "the camera, " : "") +
                                     std::to_string(s.motion.deforming() ? s.flat_triangles : 0) + " world-space triangles (deforming), " +
                                     std::to_string(moving) + " moving placement(s), " +
                                     std::to_string(s.motion.light_triangles_close.empty() ? 0 : s.light_triangles.size()) +
                                     " light triangles and " + std::to_string(s.motion.delta_lights_close.size()) + " delta lights (moving)");
        else
            s.report.left_out.push_back("motion blur: nothing moves within the shutter (no time per ray)");
    }
    clock.lap("camera");
    if (cache) cache->end_build();
    s.report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return s;
}

size_t RenderScene::triangle_accel_bytes() const {
    size_t instanced = instances.size() * sizeof(Instance) + instance_bvh.nodes.size() * sizeof(BvhNode) +
                       instance_bvh.prim_index.size() * sizeof(uint32_t);
    for (const Prototype& p : prototypes) instanced += p.wide.memory_bytes();
    return tri_blocks.size() * sizeof(Triangle4) + tri_wide.memory_bytes() + instanced +
           (embree ? embree_memory_bytes(*embree) : 0);
}

}  // namespace tessera
