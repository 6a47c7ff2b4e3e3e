#include "engine/scene/intersect.h"

#include <type_traits>

#include "engine/accel/wide_bvh_traverse.h"
#include "engine/core/float_util.h"
#include "engine/geometry/sphere.h"
#include "engine/geometry/triangle.h"
#include "engine/scene/surface_textures.h"

namespace tessera {

namespace {

// kAlpha: some material is alpha-tested (RenderScene::has_alpha); a template parameter so that
// the opaque scenes' traversal carries no test for it.
template <bool kAnyHit, bool kAlpha, class R, class OnHit>
bool test_blocks(const RenderScene& scene, const Triangle4Ray& r4, uint32_t first, uint32_t count, R& ray, OnHit&& on_hit) {
    bool found = false;
    const size_t moving_blocks = scene.motion.tri_blocks_close.size();  // 0 without a shutter
    for (uint32_t b = first; b < first + count; ++b) {
        Triangle4 moved;
        const Triangle4* at = &scene.tri_blocks[b];
        if (b < moving_blocks) {  // deforming within the shutter: the block where the ray's time puts it
            moved = triangle4_at(*at, scene.motion.tri_blocks_close[b], ray.time);
            at = &moved;
        }
        const Triangle4& block = *at;
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
        if (kAlpha && h.mask) {
            for (int l = 0; l < 4; ++l)
                if ((h.mask >> l & 1) && !alpha_passes(scene, ray, block.prim[l], h.b1[l], h.b2[l])) h.mask &= ~(1 << l);
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

// Embree's side of alpha_passes: the scene and the ray being traced.
struct AlphaQuery {
    const RenderScene& scene;
    const Ray& ray;
    EmbreeHitFilter filter() const {
        return {[](const void* user, uint32_t prim, float b1, float b2) {
                    const auto* q = static_cast<const AlphaQuery*>(user);
                    return alpha_passes(q->scene, q->ray, prim, b1, b2);
                },
                this};
    }
};

// The ray in a placement's space: the same t along it (the direction keeps its scale), and its
// origin triangle skipped only in the placement it left.
Ray to_object(const RenderScene& scene, const Instance& in, uint32_t index, const Ray& ray) {
    Ray r = ray;
    if (!scene.motion.instances.empty() && scene.motion.instance_moves[index]) {
        glm::mat4x3 to_world, to_object;  // where the ray's time puts the placement
        instance_maps_at(scene.motion.instances[index], ray.time, to_world, to_object);
        r.o = to_object * glm::vec4(ray.o, 1.f);
        r.d = to_object * glm::vec4(ray.d, 0.f);
    } else {
        r.o = in.to_object * glm::vec4(ray.o, 1.f);
        r.d = in.to_object * glm::vec4(ray.d, 0.f);
    }
    if (ray.origin_instance != index) r.origin_tri = kNoTriangle;
    return r;
}

template <bool kAlpha>
bool closest_instance(const RenderScene& scene, Ray& ray, Hit& hit, TraversalCounters& counters) {
    return bvh_closest_hit(scene.instance_bvh, ray, [&](uint32_t i, Ray& r) {
        const Instance& in = scene.instances[i];
        const Prototype& p = scene.prototypes[in.prototype];
        Ray local = to_object(scene, in, i, r);
        const Triangle4Ray r4 = make_triangle4_ray(local);
        const bool found = wide_closest_hit(p.wide, local, [&](uint32_t first, uint32_t count, Ray& lr) {
            return test_blocks<false, kAlpha>(scene, r4, p.first_block + first, count, lr,
                                              [&](uint32_t prim, uint32_t slot, float t, float b1, float b2) {
                                                  hit = Hit{t, prim, b1, b2, false, slot, i};
                                              });
        }, counters);
        if (found) r.tmax = local.tmax;
        return found;
    }, counters);
}

template <bool kAlpha>
bool any_instance(const RenderScene& scene, const Ray& ray, TraversalCounters& counters) {
    return bvh_any_hit(scene.instance_bvh, ray, [&](uint32_t i, const Ray& r) {
        const Instance& in = scene.instances[i];
        const Prototype& p = scene.prototypes[in.prototype];
        const Ray local = to_object(scene, in, i, r);
        const Triangle4Ray r4 = make_triangle4_ray(local);
        return wide_any_hit(p.wide, local, [&](uint32_t first, uint32_t count, const Ray& lr) {
            return test_blocks<true, kAlpha>(scene, r4, p.first_block + first, count, lr,
                                             [](uint32_t, uint32_t, float, float, float) {});
        }, counters);
    }, counters);
}

}  // namespace

bool intersect(const RenderScene& scene, Ray& ray, Hit& hit, TraversalCounters& counters) {
    bool found = false;
    if (scene.embree) {
        uint32_t prim;
        float b1, b2;
        const Ray traced = ray;  // the filter hashes the ray as given, before tmax is lowered
        const AlphaQuery q{scene, traced};
        const EmbreeHitFilter f = q.filter();
        uint32_t instance = kNoInstance;
        if (embree_intersect(*scene.embree, ray, prim, b1, b2, scene.has_alpha ? &f : nullptr, &instance)) {
            hit = Hit{ray.tmax, prim, b1, b2, false, prim, instance};
            found = true;
        }
    } else if (scene.flat_triangles) {
        const Triangle4Ray r4 = make_triangle4_ray(ray);
        auto closest = [&]<bool kAlpha>(std::bool_constant<kAlpha>) {
            return wide_closest_hit(scene.tri_wide, ray, [&](uint32_t first, uint32_t count, Ray& r) {
                return test_blocks<false, kAlpha>(scene, r4, first, count, r, [&](uint32_t prim, uint32_t slot, float t, float b1, float b2) {
                    hit = Hit{t, prim, b1, b2, false, slot};
                });
            }, counters);
        };
        found = scene.has_alpha ? closest(std::true_type{}) : closest(std::false_type{});
    }
    if (!scene.instances.empty() && !scene.embree)
        found |= scene.has_alpha ? closest_instance<true>(scene, ray, hit, counters)
                                 : closest_instance<false>(scene, ray, hit, counters);
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
    if (scene.embree) {
        const AlphaQuery q{scene, ray};
        const EmbreeHitFilter f = q.filter();
        return embree_occluded(*scene.embree, ray, scene.has_alpha ? &f : nullptr);
    }
    if (!scene.instances.empty() &&
        (scene.has_alpha ? any_instance<true>(scene, ray, counters) : any_instance<false>(scene, ray, counters)))
        return true;
    if (!scene.flat_triangles) return false;
    const Triangle4Ray r4 = make_triangle4_ray(ray);
    auto any = [&]<bool kAlpha>(std::bool_constant<kAlpha>) {
        return wide_any_hit(scene.tri_wide, ray, [&](uint32_t first, uint32_t count, const Ray& r) {
            return test_blocks<true, kAlpha>(scene, r4, first, count, r, [](uint32_t, uint32_t, float, float, float) {});
        }, counters);
    };
    return scene.has_alpha ? any(std::true_type{}) : any(std::false_type{});
}

namespace {

// A prototype's surface point, placed: the point as anchor and offset, its error bound grown by
// the transform's own rounding (pbrt-v4's Transform of a Point3fi), normals by the inverse
// transpose (to_object's linear part, transposed).
void to_world(const RenderScene& scene, const Instance& placed, uint32_t index, SurfaceInteraction& si) {
    Instance in = placed;
    if (!scene.motion.instances.empty() && scene.motion.instance_moves[index])
        instance_maps_at(scene.motion.instances[index], si.time, in.to_world, in.to_object);  // at the ray's time
    const glm::mat3 l(in.to_world);
    const glm::vec3 shift = in.to_world[3];
    const glm::mat3 al(glm::abs(l[0]), glm::abs(l[1]), glm::abs(l[2]));
    const glm::vec3 anchor = l * si.anchor + shift;
    const glm::vec3 local = l * si.local;
    si.p_err = al * si.p_err + gamma(3) * (al * glm::abs(si.anchor) + glm::abs(shift)) + gamma(3) * (al * glm::abs(si.local));
    si.anchor = anchor;
    si.local = local;
    si.p = anchor + local;
    si.p_err += gamma(1) * glm::abs(si.p);
    const glm::mat3 nm = glm::transpose(glm::mat3(in.to_object));
    const glm::vec3 ng = nm * si.ng, ns = nm * si.ns;
    const float lg = glm::length(ng), ls = glm::length(ns);
    si.ng = lg > 0.f && std::isfinite(lg) ? ng / lg : glm::vec3(0, 1, 0);
    si.ns = ls > 0.f && std::isfinite(ls) ? ns / ls : si.ng;
    if (glm::dot(si.ns, si.ng) < 0.f) si.ns = -si.ns;
    si.instance = index;
}

}  // namespace

SurfaceInteraction surface_at(const RenderScene& scene, const Ray& ray, const Hit& hit) {
    SurfaceInteraction si;
    si.t = hit.t;
    si.time = ray.time;
    if (hit.sphere) {
        const Sphere& s = scene.spheres[hit.prim];
        glm::vec3 rel = ray.o + hit.t * ray.d - s.center;
        const float len = glm::length(rel);
        // Re-project onto the surface; the error bound then scales with the sphere, not with t.
        rel = len > 0.f ? rel * (s.radius / len) : glm::vec3(0, s.radius, 0);
        si.p = s.center + rel;
        si.anchor = s.center;
        si.local = rel;
        si.p_err = gamma(5) * glm::abs(rel) + gamma(2) * glm::abs(si.p);
        si.ng = glm::normalize(rel);
        si.ns = si.ng;
        si.material = s.material;
        return si;
    }
    const size_t block = hit.slot / 4;
    const bool deforming = block < scene.motion.tri_blocks_close.size();
    const TriangleVerts t = deforming ? triangle4_verts(triangle4_at(scene.tri_blocks[block], scene.motion.tri_blocks_close[block], ray.time),
                                                        int(hit.slot % 4))
                                      : triangle4_verts(scene.tri_blocks[block], int(hit.slot % 4));
    const TriangleShading& sh = scene.tri_shading[hit.prim];
    const float b0 = 1.f - hit.b1 - hit.b2;
    // Relative to p0: edges of nearby vertices subtract exactly, so far from the origin p is
    // within half an ulp of the true point and cannot fall outside a neighbouring face.
    si.anchor = t.p0;
    si.local = hit.b1 * (t.p1 - t.p0) + hit.b2 * (t.p2 - t.p0);
    si.p = t.p0 + si.local;
    si.p_err = gamma(7) * (glm::abs(b0 * t.p0) + glm::abs(hit.b1 * t.p1) + glm::abs(hit.b2 * t.p2));
    // A hit on a shared edge may round onto the plane of the neighbouring face; a ray spawned
    // there and leaving through that face meets it at t ≈ 0 with either sign. Pulling the
    // point toward its triangle's interior by the error bound moves it off that plane.
    const glm::vec3 to_centroid = ((t.p1 - t.p0) + (t.p2 - t.p0)) * (1.f / 3.f) - si.local;
    const float dist = glm::length(to_centroid);
    const float need = 2.f * std::max(si.p_err.x, std::max(si.p_err.y, si.p_err.z));
    if (dist > 0.f) {
        si.local += to_centroid * std::min(0.5f, need / dist);
        si.p = t.p0 + si.local;
        si.p_err += gamma(2) * glm::abs(si.p);
    }
    glm::vec3 ng = glm::cross(t.p1 - t.p0, t.p2 - t.p0);
    const float len = glm::length(ng);
    si.ng = len > 0.f ? ng / len : glm::vec3(0, 1, 0);
    glm::vec3 ns = b0 * scene.normals[sh.n0] + hit.b1 * scene.normals[sh.n1] + hit.b2 * scene.normals[sh.n2];
    if (deforming) {
        const LargeVector<glm::vec3>& nc = scene.motion.normals_close;
        const glm::vec3 closing = b0 * nc[sh.n0] + hit.b1 * nc[sh.n1] + hit.b2 * nc[sh.n2];
        ns += ray.time * (closing - ns);
    }
    const float nlen = glm::length(ns);
    ns = nlen > 1e-6f ? ns / nlen : si.ng;
    si.ns = glm::dot(ns, si.ng) < 0.f ? -ns : ns;
    si.material = sh.material;
    si.tri = hit.prim;
    if (hit.instance != kNoInstance) to_world(scene, scene.instances[hit.instance], hit.instance, si);
    return si;
}

}  // namespace tessera
