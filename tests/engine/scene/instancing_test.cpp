// Instances (engine/scene/instancing.h, the two-level BVH in render_scene.cpp and intersect.cpp):
// a scene of placements answers every ray as the same scene flattened into world-space meshes
// does (hit, distance, point, normals, material, within float rounding of the transforms), for
// closest and any hit, with turned, scaled and mirrored placements; a ray leaving one placement
// of a triangle still meets the same triangle in another; images agree within noise; the
// prototype is stored once (memory does not grow with the triangles placed); emitters are placed
// flat (light sampling needs them); and what cannot be placed is refused.
#include "engine/scene/instancing.h"

#include <gtest/gtest.h>

#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/accel/embree_accel.h"
#include "engine/geometry/spawn.h"
#include "engine/render/renderer.h"
#include "engine/sampling/rng.h"
#include "engine/scene/intersect.h"
#include "engine/scene/procedural.h"
#include "engine/scene/render_scene.h"

namespace tessera {
namespace {

SceneDescription flattened(SceneDescription d) {
    flatten_instances(d);
    return d;
}

// Random rays from around the field toward it: every placement is met from several sides.
Ray field_ray(Pcg32& rng, float half) {
    const glm::vec3 o(2.f * half * (rng.next_float() - 0.5f) * 1.4f, 0.2f + 4.f * rng.next_float(),
                      2.f * half * (rng.next_float() - 0.5f) * 1.4f);
    const glm::vec3 target(2.f * half * (rng.next_float() - 0.5f), 1.5f * rng.next_float(), 2.f * half * (rng.next_float() - 0.5f));
    return Ray{o, 0.f, glm::normalize(target - o), INFINITY};
}

TEST(Instancing, RaysMeetWhatTheFlattenedSceneMeets) {
    const SceneDescription d = instanced_field(25, 2000);
    ASSERT_EQ(d.instances.size(), 25u);
    const RenderScene inst = build_render_scene(d, {});
    const RenderScene flat = build_render_scene(flattened(d), {});
    ASSERT_EQ(inst.instances.size(), 25u);
    ASSERT_EQ(inst.prototypes.size(), 1u);
    ASSERT_TRUE(flat.instances.empty());
    Pcg32 rng(5, 1);
    TraversalCounters tc;
    int disagree = 0, hits = 0, mirrored_hits = 0;
    const int n = 40000;
    for (int i = 0; i < n; ++i) {
        Ray a = field_ray(rng, 7.5f), b = a;
        Hit ha, hb;
        const bool ea = intersect(inst, a, ha, tc), eb = intersect(flat, b, hb, tc);
        EXPECT_EQ(ea, occluded(inst, Ray{a.o, 0.f, a.d, INFINITY}, tc));
        if (ea != eb) { ++disagree; continue; }
        if (!ea) continue;
        ++hits;
        ASSERT_NEAR(ha.t, hb.t, 1e-4f * std::max(1.f, ha.t)) << i;
        const SurfaceInteraction sa = surface_at(inst, a, ha), sb = surface_at(flat, b, hb);
        if (std::abs(ha.t - hb.t) > 1e-5f * std::max(1.f, ha.t)) continue;  // a neighbouring triangle at an edge
        EXPECT_LT(glm::length(sa.p - sb.p), 1e-4f * std::max(1.f, ha.t)) << i;
        EXPECT_GT(glm::dot(sa.ng, sb.ng), 0.9999f) << i;
        EXPECT_GT(glm::dot(sa.ns, sb.ns), 0.999f) << i;
        EXPECT_EQ(sa.material, sb.material);
        // The error bounds cover the placed point's distance from the flat triangle's plane
        // (the transform's rounding included).
        EXPECT_LE(std::abs(glm::dot(sa.p - sb.p, sb.ng)), glm::length(sa.p_err) + glm::length(sb.p_err)) << i;
        if (ha.instance != kNoInstance) {
            EXPECT_EQ(sa.instance, ha.instance);
            if (glm::determinant(glm::mat3(inst.instances[ha.instance].to_world)) < 0.f) ++mirrored_hits;
            // Occlusion agrees just short of and just past the hit.
            EXPECT_FALSE(occluded(inst, Ray{a.o, 0.f, a.d, ha.t * 0.999f}, tc)) << i;
            EXPECT_TRUE(occluded(inst, Ray{a.o, 0.f, a.d, ha.t * 1.001f}, tc)) << i;
        }
    }
    EXPECT_GT(hits, n / 4);
    EXPECT_GT(mirrored_hits, 100);
    EXPECT_LE(disagree, n / 2000) << disagree << " rays disagree";
}

// Embree's instancing (a scene per prototype, an instance geometry per placement) answers the
// rays our two levels answer: the same placement, triangle and distance.
TEST(Instancing, EmbreeMeetsWhatOurTwoLevelsMeet) {
    if (!embree_available()) GTEST_SKIP() << "this build has no Embree (libembree-dev)";
    const SceneDescription d = instanced_field(25, 2000);
    RenderSceneOptions eo;
    eo.bvh.type = BvhType::embree;
    const RenderScene emb = build_render_scene(d, eo);
    const RenderScene ours = build_render_scene(d, {});
    ASSERT_TRUE(emb.embree);
    ASSERT_EQ(emb.instances.size(), 25u);
    EXPECT_LT(emb.triangle_count(), 2100u);  // stored once
    Pcg32 rng(8, 2);
    TraversalCounters tc;
    int disagree = 0, hits = 0;
    const int n = 20000;
    for (int i = 0; i < n; ++i) {
        Ray a = field_ray(rng, 7.5f), b = a;
        Hit ha, hb;
        const bool ea = intersect(ours, a, ha, tc), eb = intersect(emb, b, hb, tc);
        EXPECT_EQ(eb, occluded(emb, Ray{b.o, 0.f, b.d, INFINITY}, tc));
        if (ea != eb) { ++disagree; continue; }
        if (!ea) continue;
        ++hits;
        ASSERT_NEAR(ha.t, hb.t, 1e-4f * std::max(1.f, ha.t)) << i;
        if (std::abs(ha.t - hb.t) > 1e-6f * std::max(1.f, ha.t)) continue;
        // Instances are numbered in leaf order by ours, in input order by Embree: compare what
        // they place and where.
        const SurfaceInteraction sa = surface_at(ours, a, ha), sb = surface_at(emb, b, hb);
        EXPECT_LT(glm::length(sa.p - sb.p), 1e-4f * std::max(1.f, ha.t)) << i;
        EXPECT_GT(glm::dot(sa.ng, sb.ng), 0.9999f) << i;
        EXPECT_EQ(ha.prim, hb.prim) << i;
        EXPECT_EQ(ha.instance == kNoInstance, hb.instance == kNoInstance) << i;
    }
    EXPECT_GT(hits, n / 4);
    EXPECT_LE(disagree, n / 2000) << disagree << " rays disagree";
}

// A ray leaving a triangle of one placement skips that triangle there only: the same triangle
// placed again further along the ray is still met.
TEST(Instancing, TheOriginTriangleIsSkippedOnlyInItsOwnPlacement) {
    SceneDescription d;
    MeshDesc quad;
    quad.name = "quad";
    quad.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    quad.indices = {0, 1, 2, 0, 2, 3};
    d.prototypes.push_back(quad);
    d.instances.push_back({0, glm::mat4(1.f), {}});
    d.instances.push_back({0, glm::translate(glm::mat4(1.f), glm::vec3(0, 0, -2)), {}});
    const RenderScene s = build_render_scene(d, {});
    TraversalCounters tc;
    Ray first{{0.2f, 0.1f, 1.f}, 0.f, {0, 0, -1}, INFINITY};
    Hit h;
    ASSERT_TRUE(intersect(s, first, h, tc));
    const SurfaceInteraction si = surface_at(s, first, h);
    EXPECT_NEAR(si.p.z, 0.f, 1e-6f);
    Ray on = spawn_ray(si.p, si.p_err, si.ng, glm::vec3(0, 0, -1), si.tri, si.instance);
    Hit h2;
    ASSERT_TRUE(intersect(s, on, h2, tc));
    EXPECT_EQ(h2.prim, h.prim);  // the same prototype triangle...
    EXPECT_NE(h2.instance, h.instance);  // ...in the other placement
    EXPECT_NEAR(surface_at(s, on, h2).p.z, -2.f, 1e-5f);
    EXPECT_TRUE(occluded(s, spawn_ray(si.p, si.p_err, si.ng, glm::vec3(0, 0, -1), si.tri, si.instance), tc));
}

TEST(Instancing, ImagesAgreeWithTheFlattenedScene) {
    const SceneDescription d = instanced_field(16, 1000);
    RenderSettings st;
    st.width = 48;
    st.height = 27;
    st.spp = 16;
    st.max_depth = 3;
    const RenderResult a = render(build_render_scene(d, {}), st);
    const RenderResult b = render(build_render_scene(flattened(d), {}), st);
    // Per pixel, the difference of two independent-looking estimates: its mean is zero (the
    // same expectation) within four standard errors of the mean difference.
    double sum = 0, sum2 = 0;
    const size_t n = a.image.rgb.size();
    for (size_t i = 0; i < n; ++i) {
        const double dlt = double(a.image.rgb[i]) - double(b.image.rgb[i]);
        sum += dlt;
        sum2 += dlt * dlt;
    }
    const double mean = sum / double(n), se = std::sqrt(std::max(0.0, sum2 / double(n) - mean * mean) / double(n));
    EXPECT_LE(std::abs(mean), 4.0 * se + 1e-7) << "mean difference " << mean << ", standard error " << se;
}

TEST(Instancing, ThePrototypeIsStoredOnce) {
    const RenderScene one = build_render_scene(instanced_field(1, 20000), {});
    const RenderScene many = build_render_scene(instanced_field(400, 20000), {});
    EXPECT_EQ(many.triangle_count(), one.triangle_count());
    EXPECT_EQ(many.prototypes.size(), 1u);
    // 400 placements cost their records and the tree over them, not 400 copies.
    const size_t per_instance = (many.triangle_accel_bytes() - one.triangle_accel_bytes()) / 399;
    EXPECT_LT(per_instance, 200u) << many.triangle_accel_bytes() << " against " << one.triangle_accel_bytes();
    const SceneDescription d = instanced_field(400, 20000);
    EXPECT_EQ(d.placed_triangle_count(), d.triangle_count() + 399 * d.prototypes[0].indices.size() / 3);
}

TEST(Instancing, EmittersArePlacedFlatForLightSampling) {
    SceneDescription d = cornell_box();
    MeshDesc lamp;
    lamp.name = "lamp";
    lamp.positions = {{-0.1f, 0, -0.1f}, {0.1f, 0, -0.1f}, {0.1f, 0, 0.1f}, {-0.1f, 0, 0.1f}};
    lamp.indices = {0, 2, 1, 0, 3, 2};
    MaterialDesc glow;
    glow.name = "glow";
    glow.kind = MaterialKind::emission;
    glow.emission = glm::vec3(5.f);
    lamp.material = int(d.materials.size());
    d.materials.push_back(glow);
    d.prototypes.push_back(lamp);
    for (int k = 0; k < 3; ++k) d.instances.push_back({0, glm::translate(glm::mat4(1.f), glm::vec3(-0.5f + 0.5f * k, 1.4f, 0)), {}});
    const size_t lights_before = build_render_scene(cornell_box(), {}).light_triangles.size();
    const RenderScene s = build_render_scene(d, {});
    EXPECT_TRUE(s.instances.empty());
    EXPECT_EQ(s.light_triangles.size(), lights_before + 6);
}

SceneDescription one_instance(const glm::mat4& m) {
    SceneDescription d;
    MeshDesc tri;
    tri.name = "tri";
    tri.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    tri.indices = {0, 1, 2};
    d.prototypes.push_back(tri);
    d.instances.push_back({0, m, {}});
    return d;
}

TEST(Instancing, WhatCannotBePlacedIsRefused) {
    EXPECT_NO_THROW(validate(one_instance(glm::mat4(1.f))));
    EXPECT_THROW(validate(one_instance(glm::scale(glm::mat4(1.f), glm::vec3(1, 0, 1)))), SceneError);  // singular
    glm::mat4 nan(1.f);
    nan[3][0] = NAN;
    EXPECT_THROW(validate(one_instance(nan)), SceneError);
    glm::mat4 projective(1.f);
    projective[0][3] = 0.5f;
    EXPECT_THROW(validate(one_instance(projective)), SceneError);
    EXPECT_THROW(validate(one_instance(glm::scale(glm::mat4(1.f), glm::vec3(1e38f)) * glm::translate(glm::mat4(1.f), glm::vec3(10)))),
                 SceneError);  // places vertices beyond the float range
    SceneDescription bad = one_instance(glm::mat4(1.f));
    bad.instances[0].prototype = 1;
    EXPECT_THROW(validate(bad), SceneError);
}

TEST(Instancing, PlacedMeshesMirrorLikeTheLoader) {
    MeshDesc tri;
    tri.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    tri.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
    tri.indices = {0, 1, 2};
    const MeshDesc m = placed_mesh(tri, glm::scale(glm::mat4(1.f), glm::vec3(-2, 1, 1)));
    // Re-wound, so the face normal of the placed triangle is the transformed normal.
    const glm::vec3 face = glm::cross(m.positions[m.indices[1]] - m.positions[m.indices[0]], m.positions[m.indices[2]] - m.positions[m.indices[0]]);
    EXPECT_GT(glm::dot(glm::normalize(face), m.normals[0]), 0.999f);
    EXPECT_NEAR(m.positions[1].x, -2.f, 0.f);
    const Aabb b = scene_bounds(one_instance(glm::translate(glm::mat4(1.f), glm::vec3(5, 0, 0))));
    EXPECT_EQ(b.lo.x, 5.f);
    EXPECT_EQ(b.hi.x, 6.f);
}

}  // namespace
}  // namespace tessera
