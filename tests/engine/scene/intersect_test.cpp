// Holds engine/scene/intersect.cpp to intersect.h on small scenes, against brute force over the
// description's own triangles and the scene's spheres: intersect() finds the closest hit in
// (tmin, tmax), names the triangle by its input index (the one tri_shading keeps) or the sphere,
// and lowers tmax to it; occluded() agrees with it on every ray and on segments cut just short of
// and just past the hit; surface_at() puts the point on that surface, with unit normals, the
// shading normal interpolated from the vertex normals and turned to the geometric normal's side,
// the geometric one never flipped toward the ray, and the material of the primitive hit. For
// every BVH builder, the single-leaf tree, and the Möller–Trumbore test. (bvh_test.cpp compares
// builders through intersect() on large meshes; spawn_test.cpp and surface_textures_test.cpp
// cover spawned rays and alpha.)
#include "engine/scene/intersect.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "engine/geometry/sphere.h"
#include "engine/geometry/triangle.h"
#include "engine/sampling/rng.h"
#include "engine/scene/procedural.h"
#include "tests/test_scale.h"

namespace tessera {
namespace {

struct InputTriangle {
    TriangleVerts v;
    uint32_t material;
};

// The description's triangles in input order (meshes in order, then their index triples):
// the order tri_shading and Hit::prim use.
std::vector<InputTriangle> input_triangles(const SceneDescription& d, uint32_t default_material) {
    std::vector<InputTriangle> out;
    for (const MeshDesc& m : d.meshes)
        for (size_t i = 0; i + 2 < m.indices.size(); i += 3)
            out.push_back({{m.positions[m.indices[i]], m.positions[m.indices[i + 1]], m.positions[m.indices[i + 2]]},
                           m.material < 0 ? default_material : uint32_t(m.material)});
    return out;
}

struct Expected {
    bool hit = false;
    float t = 0.f;
    bool sphere = false;
    uint32_t prim = 0;
};

bool triangle_hit(const RenderScene& s, const Ray& r, const TriangleVerts& v, TriangleHit& h) {
    if (s.triangle_test == TriangleTest::moller_trumbore) return intersect_triangle_moller_trumbore(r, v.p0, v.p1, v.p2, h);
    return intersect_triangle_watertight(r, make_watertight_ray(r.d), v.p0, v.p1, v.p2, h);
}

Expected brute_force(const RenderScene& s, const std::vector<InputTriangle>& tris, Ray r) {
    Expected e;
    for (size_t i = 0; i < tris.size(); ++i) {
        TriangleHit h;
        if (triangle_hit(s, r, tris[i].v, h)) {
            r.tmax = h.t;
            e = {true, h.t, false, uint32_t(i)};
        }
    }
    for (size_t i = 0; i < s.spheres.size(); ++i) {
        float t;
        if (intersect_sphere(r, s.spheres[i].center, s.spheres[i].radius, t)) {
            r.tmax = t;
            e = {true, t, true, uint32_t(i)};
        }
    }
    return e;
}

// Origins in a box 1.5 times the scene's (inside and outside it), directions uniform on the
// sphere; some segments cut short at either end.
std::vector<Ray> random_rays(const Aabb& bounds, int n, uint64_t seed) {
    Pcg32 rng(seed, 17);
    std::vector<Ray> rays;
    const glm::vec3 c = bounds.centroid(), e = 0.75f * bounds.extent();
    while (int(rays.size()) < n) {
        Ray r;
        const float x = rng.next_float(), y = rng.next_float(), z = rng.next_float();
        r.o = c + e * glm::vec3(2.f * x - 1.f, 2.f * y - 1.f, 2.f * z - 1.f);
        const float dx = rng.next_float(), dy = rng.next_float(), dz = rng.next_float();
        const glm::vec3 d(2.f * dx - 1.f, 2.f * dy - 1.f, 2.f * dz - 1.f);
        const float len2 = glm::dot(d, d);
        if (len2 > 1.f || len2 < 1e-4f) continue;
        r.d = d / std::sqrt(len2);
        const uint32_t cut = rng.next_u32() % 8;
        if (cut == 0) r.tmax = 3.f * rng.next_float();
        if (cut == 1) r.tmin = 1.5f * rng.next_float();
        rays.push_back(r);
    }
    return rays;
}

struct Config {
    BvhType bvh;
    TriangleTest test;
};

std::string name(const Config& c) {
    return std::string(to_string(c.bvh)) + (c.test == TriangleTest::watertight ? ", watertight" : ", Möller–Trumbore");
}

RenderScene build(const SceneDescription& d, const Config& c) {
    RenderSceneOptions o;
    o.bvh.type = c.bvh;
    o.triangle_test = c.test;
    o.bvh.build_threads = 1;
    return build_render_scene(d, o);
}

constexpr Config kConfigs[] = {{BvhType::sah, TriangleTest::watertight},
                               {BvhType::median, TriangleTest::watertight},
                               {BvhType::midpoint, TriangleTest::moller_trumbore},
                               {BvhType::none, TriangleTest::watertight}};

// Every query on one ray: intersect against brute force, occluded against intersect (on the
// ray, and on the segment cut just short of and just past its closest hit), surface_at on the
// hit. Returns whether the ray hit.
bool check_ray(const RenderScene& s, const std::vector<InputTriangle>& tris, const Ray& ray, const std::string& where) {
    const Expected want = brute_force(s, tris, ray);
    TraversalCounters tc;
    Ray r = ray;
    Hit h;
    const bool hit = intersect(s, r, h, tc);
    EXPECT_EQ(hit, want.hit) << where;
    EXPECT_EQ(occluded(s, ray, tc), want.hit) << where << ": occluded disagrees";
    if (!hit || !want.hit) {
        EXPECT_EQ(r.tmax, ray.tmax) << where << ": a miss must leave tmax alone";
        return false;
    }
    EXPECT_EQ(h.t, want.t) << where;
    EXPECT_EQ(r.tmax, h.t) << where << ": tmax is lowered to the hit";
    EXPECT_GT(h.t, ray.tmin) << where;
    EXPECT_LT(h.t, ray.tmax) << where;
    EXPECT_EQ(h.sphere, want.sphere) << where;
    if (h.sphere == want.sphere && h.prim != want.prim) {
        // Two primitives at exactly the same distance (a shared edge) may come in either order:
        // then the one reported must itself be hit at that distance.
        if (h.sphere) {
            float t = 0.f;
            EXPECT_TRUE(h.prim < s.spheres.size() && intersect_sphere(ray, s.spheres[h.prim].center, s.spheres[h.prim].radius, t) &&
                        t == h.t) << where << ": sphere " << h.prim;
        } else {
            TriangleHit th;
            EXPECT_TRUE(h.prim < tris.size() && triangle_hit(s, ray, tris[h.prim].v, th) && th.t == h.t)
                << where << ": triangle " << h.prim << " is not hit at the reported distance";
        }
    }

    // Segments: nothing lies before the closest hit, and the hit itself is found.
    Ray before = ray, past = ray;
    before.tmax = h.t * (1.f - 1e-3f);
    past.tmax = h.t * (1.f + 1e-3f);
    Hit ignored;
    Ray b = before;
    EXPECT_FALSE(occluded(s, before, tc)) << where << ": occluded before the closest hit";
    EXPECT_FALSE(intersect(s, b, ignored, tc)) << where << ": a hit before the closest hit";
    EXPECT_TRUE(occluded(s, past, tc)) << where << ": the closest hit is not an occluder";

    const SurfaceInteraction si = surface_at(s, ray, h);
    EXPECT_EQ(si.t, h.t) << where;
    const glm::vec3 on_ray = ray.o + h.t * ray.d;
    EXPECT_LT(glm::length(si.p - on_ray), 1e-4f * (1.f + glm::length(on_ray))) << where << ": the point is off the ray";
    EXPECT_EQ(si.anchor + si.local, si.p) << where << ": p is anchor + local";
    EXPECT_GE(std::min(si.p_err.x, std::min(si.p_err.y, si.p_err.z)), 0.f) << where;
    EXPECT_LT(std::max(si.p_err.x, std::max(si.p_err.y, si.p_err.z)), 1e-4f) << where;
    EXPECT_NEAR(glm::length(si.ng), 1.f, 1e-5f) << where;
    EXPECT_NEAR(glm::length(si.ns), 1.f, 1e-5f) << where;
    EXPECT_GE(glm::dot(si.ns, si.ng), 0.f) << where << ": the shading normal is on the geometric normal's side";
    if (h.sphere) {
        const Sphere& sp = s.spheres[h.prim];
        EXPECT_NEAR(glm::length(si.p - sp.center), sp.radius, 1e-5f * sp.radius) << where;
        EXPECT_LT(glm::length(si.ng - (si.p - sp.center) / sp.radius), 1e-5f) << where << ": the outward normal";
        EXPECT_EQ(si.material, sp.material) << where;
        EXPECT_EQ(si.tri, kNoTriangle) << where << ": a sphere is no triangle to skip";
    } else {
        const InputTriangle& t = tris[h.prim];
        const glm::vec3 n = glm::normalize(glm::cross(t.v.p1 - t.v.p0, t.v.p2 - t.v.p0));
        EXPECT_LT(glm::length(si.ng - n), 1e-5f) << where << ": ng follows the winding, whichever side the ray comes from";
        EXPECT_LT(std::abs(glm::dot(si.p - t.v.p0, n)), 1e-5f) << where << ": the point is off its triangle's plane";
        EXPECT_EQ(si.material, t.material) << where;
        EXPECT_EQ(si.material, s.tri_shading[h.prim].material) << where;
        EXPECT_EQ(si.tri, h.prim) << where;
    }
    return true;
}

TEST(Intersect, QueriesAgreeWithBruteForceOnTheCornellSpheres) {
    const SceneDescription d = cornell_spheres();
    const int n = 20000 / test::kWorkScale;
    for (const Config& c : kConfigs) {
        const RenderScene s = build(d, c);
        const std::vector<InputTriangle> tris = input_triangles(d, uint32_t(s.materials.size() - 1));
        ASSERT_EQ(s.triangle_count(), tris.size());
        ASSERT_EQ(s.spheres.size(), d.spheres.size());
        const std::vector<Ray> rays = random_rays(s.bounds, n, 1);
        int hits = 0, sphere_hits = 0;
        for (size_t i = 0; i < rays.size(); ++i) {
            Ray r = rays[i];
            Hit h;
            TraversalCounters tc;
            sphere_hits += intersect(s, r, h, tc) && h.sphere;
            hits += check_ray(s, tris, rays[i], name(c) + ", ray " + std::to_string(i));
            if (HasFailure()) return;  // one ray's report is enough
        }
        EXPECT_GT(hits, n / 4) << name(c);
        EXPECT_LT(hits, n) << name(c) << ": the box is open at the front, some rays leave it";
        EXPECT_GT(sphere_hits, n / 200) << name(c) << ": the spheres should be hit often enough to test them";
    }
}

// Only spheres (no triangle structure) and only triangles (no sphere structure): each query
// takes the one path there is.
TEST(Intersect, QueriesAgreeWithBruteForceOnOneKindOfPrimitive) {
    SceneDescription spheres;
    Pcg32 rng(4, 4);
    for (int i = 0; i < 24; ++i) {
        const float x = rng.next_float(), y = rng.next_float(), z = rng.next_float(), r = rng.next_float();
        spheres.spheres.push_back({glm::vec3(4.f * x - 2.f, 4.f * y - 2.f, 4.f * z - 2.f), 0.2f + 0.6f * r, -1, {}});
    }
    const SceneDescription box = cornell_box();
    const int n = 5000 / test::kWorkScale;
    const SceneDescription* scenes[] = {&spheres, &box};
    for (const SceneDescription* d : scenes)
        for (const Config& c : kConfigs) {
            const RenderScene s = build(*d, c);
            const std::vector<InputTriangle> tris = input_triangles(*d, uint32_t(s.materials.size() - 1));
            const std::vector<Ray> rays = random_rays(s.bounds, n, 2);
            int hits = 0;
            for (size_t i = 0; i < rays.size(); ++i) {
                hits += check_ray(s, tris, rays[i], name(c) + (d == &box ? ", box" : ", spheres") + ", ray " + std::to_string(i));
                if (HasFailure()) return;
            }
            EXPECT_GT(hits, n / 50) << name(c);
        }
}

// A further stretch of the ray: with tmin past the closest hit, intersect finds the next
// surface along it, as brute force does (what a ray continuing through a surface relies on).
TEST(Intersect, TminPastAHitFindsTheNextSurface) {
    const SceneDescription d = cornell_spheres();
    for (const Config& c : kConfigs) {
        const RenderScene s = build(d, c);
        const std::vector<InputTriangle> tris = input_triangles(d, uint32_t(s.materials.size() - 1));
        const std::vector<Ray> rays = random_rays(s.bounds, 3000 / test::kWorkScale, 3);
        int second_hits = 0;
        for (size_t i = 0; i < rays.size(); ++i) {
            Ray r = rays[i];
            Hit h;
            TraversalCounters tc;
            if (!intersect(s, r, h, tc)) continue;
            Ray next = rays[i];
            next.tmin = h.t * (1.f + 1e-3f);
            next.tmax = rays[i].tmax;
            second_hits += check_ray(s, tris, next, name(c) + ", ray " + std::to_string(i) + " past its first hit");
            if (HasFailure()) return;
        }
        EXPECT_GT(second_hits, 100 / test::kWorkScale) << name(c);
    }
}

// Vertex normals: the shading normal is their barycentric blend at the hit, turned to the
// geometric normal's side when the file's normals point against the winding; the geometric
// normal follows the winding whichever side the ray comes from; a mesh without a material gets
// the default grey (the last material).
TEST(Intersect, ShadingNormalsBlendTheVertexNormalsOnTheGeometricSide) {
    SceneDescription d;
    MaterialDesc red;
    red.albedo = {0.8f, 0.1f, 0.1f};
    d.materials.push_back(red);
    const glm::vec3 tri[3] = {{-1.f, -1.f, 0.f}, {1.f, -1.f, 0.f}, {0.f, 1.f, 0.f}};  // winding normal +z
    const glm::vec3 tilt[3] = {{0.3f, 0.f, 0.f}, {0.f, 0.3f, 0.f}, {-0.2f, -0.2f, 0.f}};
    for (int k = 0; k < 2; ++k) {
        MeshDesc m;
        const glm::vec3 offset(4.f * float(k), 0.f, 0.f);
        const float side = k == 0 ? -1.f : 1.f;  // the first mesh's normals point against its winding
        for (int v = 0; v < 3; ++v) {
            m.positions.push_back(tri[v] + offset);
            m.normals.push_back(glm::normalize(tilt[v] + glm::vec3(0.f, 0.f, side)));
        }
        m.indices = {0, 1, 2};
        m.material = k == 0 ? 0 : -1;
        d.meshes.push_back(m);
    }
    for (const Config& c : kConfigs) {
        const RenderScene s = build(d, c);
        ASSERT_EQ(s.triangle_count(), 2u);
        Pcg32 rng(9, 9);
        for (int i = 0; i < 400; ++i) {
            const int k = i % 2;
            float u = rng.next_float(), v = rng.next_float();
            if (u + v > 1.f) { u = 1.f - u; v = 1.f - v; }
            // Kept off the edges, so that every ray must hit.
            u = 0.01f + 0.96f * u;
            v = 0.01f + 0.96f * v;
            const glm::vec3 offset(4.f * float(k), 0.f, 0.f);
            const glm::vec3 target = tri[0] + u * (tri[1] - tri[0]) + v * (tri[2] - tri[0]) + offset;
            const float from = (i / 2) % 2 ? 3.f : -3.f;  // from the front (+z) or from behind
            Ray ray;
            ray.o = target + glm::vec3(0.f, 0.f, from);
            ray.d = glm::vec3(0.f, 0.f, -from / 3.f);
            Ray r = ray;
            Hit h;
            TraversalCounters tc;
            const std::string where = name(c) + ", mesh " + std::to_string(k) + ", ray " + std::to_string(i);
            ASSERT_TRUE(intersect(s, r, h, tc)) << where;
            ASSERT_FALSE(h.sphere);
            EXPECT_EQ(h.prim, uint32_t(k)) << where;
            EXPECT_NEAR(h.t, 3.f, 1e-5f) << where;
            const SurfaceInteraction si = surface_at(s, ray, h);
            EXPECT_LT(glm::length(si.ng - glm::vec3(0.f, 0.f, 1.f)), 1e-6f) << where << ": ng is never flipped toward the ray";
            const float b0 = 1.f - h.b1 - h.b2;
            const glm::vec3 blend = glm::normalize(b0 * d.meshes[size_t(k)].normals[0] + h.b1 * d.meshes[size_t(k)].normals[1] +
                                                   h.b2 * d.meshes[size_t(k)].normals[2]);
            const glm::vec3 want = glm::dot(blend, si.ng) < 0.f ? -blend : blend;
            EXPECT_LT(glm::length(si.ns - want), 1e-5f) << where;
            EXPECT_GT(si.ns.z, 0.f) << where;
            EXPECT_LT(glm::length(si.p - target), 1e-5f) << where;
            EXPECT_EQ(si.material, k == 0 ? 0u : uint32_t(s.materials.size() - 1)) << where;
        }
    }
}

}  // namespace
}  // namespace tessera
