#include "engine/scene/render_scene.h"

#include <chrono>
#include <cmath>

#include "engine/accel/wide_bvh_traverse.h"
#include "engine/accel/triangle4_leaves.h"
#include "engine/core/float_util.h"
#include "engine/geometry/sphere.h"
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

}  // namespace

RenderScene build_render_scene(const SceneDescription& desc, const RenderSceneOptions& options) {
    const auto t0 = std::chrono::steady_clock::now();
    RenderScene s;
    s.triangle_test = options.triangle_test;
    s.report.warnings = desc.warnings;

    for (const MaterialDesc& m : desc.materials)
        s.materials.push_back(Material{m.kind, m.albedo, m.emission, m.double_sided});
    // CS184 parallelogram lights become emissive meshes, unless an emissive mesh already
    // stands where they are (the Cornell boxes carry the lamp twice: one lamp, one integral).
    std::vector<MeshDesc> extra;
    for (const LightDesc& l : desc.lights) {
        if (l.kind != LightKind::area) continue;
        bool duplicate = false;
        for (const MeshDesc& m : desc.meshes) {
            if (m.material < 0 || !s.materials[size_t(m.material)].emissive()) continue;
            Aabb mb;
            for (const glm::vec3& p : m.positions) mb.expand(p);
            const glm::vec3 pad = 0.05f * glm::vec3(glm::length(mb.extent())) + 1e-6f;
            if (glm::all(glm::greaterThanEqual(l.position, mb.lo - pad)) && glm::all(glm::lessThanEqual(l.position, mb.hi + pad)))
                duplicate = true;
        }
        if (duplicate) {
            s.report.left_out.push_back("area light at " + l.origin.str() +
                                        ": it duplicates an emissive mesh, which is used as the light");
            continue;
        }
        MeshDesc q;
        q.name = "area light";
        q.origin = l.origin;
        const glm::vec3 hx = 0.5f * l.dim_x, hy = 0.5f * l.dim_y;
        q.positions = {l.position - hx - hy, l.position + hx - hy, l.position + hx + hy, l.position - hx + hy};
        q.indices = {0, 1, 2, 0, 2, 3};
        if (glm::dot(glm::cross(q.positions[1] - q.positions[0], q.positions[2] - q.positions[0]), l.direction) < 0.f)
            q.indices = {0, 2, 1, 0, 3, 2};  // emit toward the light's direction
        q.material = int(s.materials.size());
        s.materials.push_back(Material{MaterialKind::emission, glm::vec3(0.f), l.radiance, false});
        extra.push_back(std::move(q));
    }
    for (const LightDesc& l : desc.lights) {
        switch (l.kind) {
            case LightKind::point:
            case LightKind::spot:
                s.delta_lights.push_back({DeltaKind::point, l.position, glm::vec3(0.f), l.radiance});
                break;
            case LightKind::directional: {
                const float len = glm::length(l.direction);
                if (len > 0.f) s.delta_lights.push_back({DeltaKind::directional, glm::vec3(0.f), l.direction / len, l.radiance});
                break;
            }
            case LightKind::ambient: s.sky += l.radiance; s.has_sky = true; break;
            case LightKind::area: break;
        }
    }
    const uint32_t default_material = uint32_t(s.materials.size());
    s.materials.push_back(Material{});
    auto mat = [&](int m) { return m < 0 ? default_material : uint32_t(m); };

    std::vector<const MeshDesc*> meshes;
    for (const MeshDesc& m : desc.meshes) meshes.push_back(&m);
    for (const MeshDesc& m : extra) meshes.push_back(&m);

    // Triangles, with area-weighted vertex normals where the file gave none (as CS184 does).
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
        uint32_t light = kNoLight;
        if (s.materials[m].emissive()) {
            AreaLight al{uint32_t(s.light_triangles.size()), 0, 0.f, s.materials[m].emission, s.materials[m].double_sided, 0.f, 0.f};
            for (size_t i = 0; i + 2 < mesh.indices.size(); i += 3) {
                const glm::vec3& p0 = mesh.positions[mesh.indices[i]];
                const glm::vec3 e1 = mesh.positions[mesh.indices[i + 1]] - p0, e2 = mesh.positions[mesh.indices[i + 2]] - p0;
                const float a = 0.5f * glm::length(glm::cross(e1, e2));
                if (!(a > 0.f)) continue;  // degenerate triangles cannot be sampled
                al.area += a;
                s.light_triangles.push_back({p0, e1, e2, glm::normalize(glm::cross(e1, e2)), al.area});
            }
            al.count = uint32_t(s.light_triangles.size()) - al.first;
            if (al.count > 0) {
                for (uint32_t i = al.first; i < al.first + al.count; ++i) s.light_triangles[i].cdf /= al.area;
                s.light_triangles[al.first + al.count - 1].cdf = 1.f;
                light = uint32_t(s.area_lights.size());
                s.area_lights.push_back(al);
            }
        }
        for (size_t i = 0; i + 2 < mesh.indices.size(); i += 3) {
            const uint32_t i0 = mesh.indices[i], i1 = mesh.indices[i + 1], i2 = mesh.indices[i + 2];
            triangles.push_back({mesh.positions[i0], mesh.positions[i1], mesh.positions[i2]});
            s.tri_shading.push_back({base + i0, base + i1, base + i2, m, light});
        }
    }
    // Power of each area light (luminance × area × π, doubled for two-sided emitters), for
    // selection by power.
    double total_power = 0.0;
    for (const AreaLight& l : s.area_lights)
        total_power += double(0.2126f * l.radiance.x + 0.7152f * l.radiance.y + 0.0722f * l.radiance.z) * l.area *
                       (l.double_sided ? 2.0 : 1.0);
    double running = 0.0;
    for (AreaLight& l : s.area_lights) {
        const double p = double(0.2126f * l.radiance.x + 0.7152f * l.radiance.y + 0.0722f * l.radiance.z) * l.area *
                         (l.double_sided ? 2.0 : 1.0);
        const double share = total_power > 0.0 ? p / total_power : 1.0 / double(s.area_lights.size());
        running += share;
        l.power_pmf = float(share);
        l.power_cdf = float(running);
    }
    if (!s.area_lights.empty()) s.area_lights.back().power_cdf = 1.f;
    for (const SphereDesc& sd : desc.spheres)
        if (sd.material >= 0 && s.materials[size_t(sd.material)].emissive())
            s.report.warnings.push_back("emissive sphere at " + sd.origin.str() + " is not a light yet; its emission is ignored");
    if (!s.has_lights()) {
        s.report.left_out.push_back("light sampling and shadow rays: the scene has no lights or emitters");
        s.report.warnings.push_back("the scene has no lights or emitters: a path-traced render shows only emitters, "
                                    "so it will be black");
    }
    else
        s.report.built.push_back("lights: " + std::to_string(s.area_lights.size()) + " area, " +
                                 std::to_string(s.delta_lights.size()) + " delta" + (s.has_sky ? ", sky" : ""));
    for (const SphereDesc& sd : desc.spheres) s.spheres.push_back({sd.center, sd.radius, mat(sd.material)});

    std::vector<Aabb> bounds(triangles.size());
    for (size_t i = 0; i < triangles.size(); ++i) { bounds[i] = triangle_bounds(triangles[i]); s.bounds.expand(bounds[i]); }
    if (!triangles.empty() && options.bvh.type == BvhType::embree) {
        s.embree = build_embree(triangles, options.embree_quality, s.embree_build_seconds);
        s.tri_build_seconds = s.embree_build_seconds;
        s.tri_blocks = pack_triangle4_in_order(triangles);  // where surface_at finds Embree's hits
        s.report.built.push_back("triangle BVH (Embree " + std::string(options.embree_quality == EmbreeQuality::low ? "low"
                                 : options.embree_quality == EmbreeQuality::high ? "high" : "medium") +
                                 " quality): " + std::to_string(triangles.size()) + " triangles");
    } else if (!triangles.empty()) {
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
    } else {
        options_for(0, options, "triangles", s.report);
    }
    bounds.resize(s.spheres.size());
    for (size_t i = 0; i < s.spheres.size(); ++i) { bounds[i] = sphere_bounds(s.spheres[i]); s.bounds.expand(bounds[i]); }
    if (!s.spheres.empty()) {
        // Spheres always take our own path (with Embree too): a list or our BVH beside its triangles.
        RenderSceneOptions sphere_options = options;
        if (sphere_options.bvh.type == BvhType::embree) sphere_options.bvh.type = BvhType::sah;
        sphere_options.bvh.leaf_block = 1;  // spheres are tested one at a time
        s.sphere_bvh = build_bvh(bounds, options_for(s.spheres.size(), sphere_options, "spheres", s.report));
        to_leaf_order(s.sphere_bvh, s.spheres);
        s.report.built.push_back("sphere list: " + std::to_string(s.spheres.size()) + " spheres");
    } else {
        options_for(0, options, "spheres", s.report);
    }

    // The camera: the file's, placed by CS184's orbit rule when it asks for it, or a default
    // that frames the scene.
    const glm::vec3 center = s.bounds.empty() ? glm::vec3(0.f) : s.bounds.centroid();
    const float diag = s.bounds.empty() ? 1.f : std::max(glm::length(s.bounds.extent()), 1e-30f);
    if (desc.camera) {
        s.camera = *desc.camera;
        if (s.camera.cs184_orbit_dir) {
            s.camera.look_at = center;
            s.camera.position = center + 1.5f * diag * *s.camera.cs184_orbit_dir;
            s.camera.up = {0, 1, 0};
        }
    } else {
        CameraDesc c;
        const float tan_v = std::tan(glm::radians(c.vfov_deg) * 0.5f);
        c.focal_px = 300.f / tan_v;  // the CS184 default fitted to 800x600
        c.look_at = center;
        c.position = center + 1.5f * diag * glm::normalize(glm::vec3(0.35f, 0.3f, 1.f));
        c.znear = 1e-4f * diag;
        c.zfar = 10.f * diag;
        s.camera = c;
        s.report.built.push_back("default camera framing the scene (the scene has none)");
    }
    s.report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return s;
}

size_t RenderScene::triangle_accel_bytes() const {
    return tri_blocks.size() * sizeof(Triangle4) + tri_wide.memory_bytes() + (embree ? embree_memory_bytes(*embree) : 0);
}

namespace {

template <bool kAnyHit, class R, class OnHit>
bool test_blocks(const RenderScene& scene, const Triangle4Ray& r4, uint32_t first, uint32_t count, R& ray, OnHit&& on_hit) {
    bool found = false;
    for (uint32_t b = first; b < first + count; ++b) {
        const Triangle4& block = scene.tri_blocks[b];
        Triangle4Hits h;
        if (scene.triangle_test == TriangleTest::watertight) {
            intersect_triangle4(ray, r4, block, h);
        } else {
            h.mask = 0;
            for (int l = 0; l < 4; ++l) {
                if (block.prim[l] == ray.origin_tri) continue;
                const TriangleVerts v = triangle4_verts(block, l);
                TriangleHit th;
                if (!intersect_triangle_moller_trumbore(ray, v.p0, v.p1, v.p2, th)) continue;
                h.mask |= 1 << l;
                h.t[l] = th.t; h.b1[l] = th.b1; h.b2[l] = th.b2;
            }
        }
        if (!h.mask) continue;
        if constexpr (kAnyHit) return true;
        else {
            const int l = nearest_lane(h);
            ray.tmax = h.t[l];
            on_hit(block.prim[l], b * 4 + uint32_t(l), h.t[l], h.b1[l], h.b2[l]);
            found = true;
        }
    }
    return found;
}

}  // namespace

bool intersect(const RenderScene& scene, Ray& ray, Hit& hit, TraversalCounters& counters) {
    bool found = false;
    if (scene.embree) {
        uint32_t prim;
        float b1, b2;
        if (embree_intersect(*scene.embree, ray, prim, b1, b2)) {
            hit = Hit{ray.tmax, prim, b1, b2, false, prim};
            found = true;
        }
    } else if (scene.triangle_count()) {
        const Triangle4Ray r4 = make_triangle4_ray(ray);
        found = wide_closest_hit(scene.tri_wide, ray, [&](uint32_t first, uint32_t count, Ray& r) {
            return test_blocks<false>(scene, r4, first, count, r, [&](uint32_t prim, uint32_t slot, float t, float b1, float b2) {
                hit = Hit{t, prim, b1, b2, false, slot};
            });
        }, counters);
    }
    if (!scene.spheres.empty()) {
        const Sphere* sph = scene.spheres.data();
        found |= bvh_closest_hit(scene.sphere_bvh, ray, [&](uint32_t i, Ray& r) {
            float t;
            if (!intersect_sphere(r, sph[i].center, sph[i].radius, t)) return false;
            r.tmax = t;
            hit = Hit{t, i, 0.f, 0.f, true, 0};
            return true;
        }, counters);
    }
    return found;
}

bool occluded(const RenderScene& scene, const Ray& ray, TraversalCounters& counters) {
    // Spheres first: there are few of them and, where there are any, they are the likely
    // occluders; an early hit skips the triangle BVH altogether.
    if (!scene.spheres.empty()) {
        const Sphere* sph = scene.spheres.data();
        if (bvh_any_hit(scene.sphere_bvh, ray, [&](uint32_t i, const Ray& r) {
                float t;
                return intersect_sphere(r, sph[i].center, sph[i].radius, t);
            }, counters))
            return true;
    }
    if (!scene.triangle_count()) return false;
    if (scene.embree) return embree_occluded(*scene.embree, ray);
    const Triangle4Ray r4 = make_triangle4_ray(ray);
    return wide_any_hit(scene.tri_wide, ray, [&](uint32_t first, uint32_t count, const Ray& r) {
        return test_blocks<true>(scene, r4, first, count, r, [](uint32_t, uint32_t, float, float, float) {});
    }, counters);
}

SurfaceInteraction surface_at(const RenderScene& scene, const Ray& ray, const Hit& hit) {
    SurfaceInteraction si;
    si.t = hit.t;
    if (hit.sphere) {
        const Sphere& s = scene.spheres[hit.prim];
        glm::vec3 rel = ray.o + hit.t * ray.d - s.center;
        const float len = glm::length(rel);
        // Re-project onto the surface; the error bound then scales with the sphere, not with t.
        rel = len > 0.f ? rel * (s.radius / len) : glm::vec3(0, s.radius, 0);
        si.p = s.center + rel;
        si.p_err = gamma(5) * glm::abs(rel) + gamma(2) * glm::abs(si.p);
        si.ng = glm::normalize(rel);
        si.ns = si.ng;
        si.material = s.material;
        return si;
    }
    const TriangleVerts t = triangle4_verts(scene.tri_blocks[hit.slot / 4], int(hit.slot % 4));
    const TriangleShading& sh = scene.tri_shading[hit.prim];
    const float b0 = 1.f - hit.b1 - hit.b2;
    // Relative to p0: edges of nearby vertices subtract exactly, so far from the origin p is
    // within half an ulp of the true point and cannot fall outside a neighbouring face.
    si.p = t.p0 + (hit.b1 * (t.p1 - t.p0) + hit.b2 * (t.p2 - t.p0));
    si.p_err = gamma(7) * (glm::abs(b0 * t.p0) + glm::abs(hit.b1 * t.p1) + glm::abs(hit.b2 * t.p2));
    // A hit on a shared edge may round onto the plane of the neighbouring face; a ray spawned
    // there and leaving through that face meets it at t ≈ 0 with either sign. Pulling the
    // point toward its triangle's interior by the error bound moves it off that plane.
    const glm::vec3 to_centroid = t.p0 + ((t.p1 - t.p0) + (t.p2 - t.p0)) * (1.f / 3.f) - si.p;
    const float dist = glm::length(to_centroid);
    const float need = 2.f * std::max(si.p_err.x, std::max(si.p_err.y, si.p_err.z));
    if (dist > 0.f) {
        si.p += to_centroid * std::min(0.5f, need / dist);
        si.p_err += gamma(2) * glm::abs(si.p);
    }
    glm::vec3 ng = glm::cross(t.p1 - t.p0, t.p2 - t.p0);
    const float len = glm::length(ng);
    si.ng = len > 0.f ? ng / len : glm::vec3(0, 1, 0);
    glm::vec3 ns = b0 * scene.normals[sh.n0] + hit.b1 * scene.normals[sh.n1] + hit.b2 * scene.normals[sh.n2];
    const float nlen = glm::length(ns);
    ns = nlen > 1e-6f ? ns / nlen : si.ng;
    si.ns = glm::dot(ns, si.ng) < 0.f ? -ns : ns;
    si.material = sh.material;
    si.tri = hit.prim;
    return si;
}

}  // namespace tessera
