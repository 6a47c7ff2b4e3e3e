// Motion blur (engine/scene/motion.h, build_render_scene's `close`, the per-ray time in
// intersect.cpp and tile_context.h): a placement's decomposed transform gives back its opening
// and closing and turns (not shrinks) in between; motion bounds hold the placed box at every
// time; and the image over a shutter is the mean of stills at uniformly spaced times across it
// (moving placements, deforming meshes, a moving camera, moving and growing emitters and a
// moving point light, by every light selection), block by block and over the whole image within
// the noise. A
// scene that does not move within its shutter renders what the still renders, bit for bit.
#include "engine/scene/motion.h"

#include <gtest/gtest.h>

#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/render/renderer.h"
#include "engine/sampling/rng.h"
#include "engine/scene/instancing.h"
#include "engine/scene/procedural.h"
#include "engine/scene/render_scene.h"
#include "tests/seen_whole.h"

namespace tessera {
namespace {

void expect_maps(const glm::mat4& want, const glm::mat4x3& to_world, const glm::mat4x3& to_object) {
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 3; ++r) EXPECT_NEAR(to_world[c][r], want[c][r], 1e-4f) << c << "," << r;
    const glm::mat4 inv = glm::inverse(want);
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 3; ++r) EXPECT_NEAR(to_object[c][r], inv[c][r], 1e-4f) << c << "," << r;
}

TEST(Motion, ATransformComesBackAtBothEndsAndTurnsBetween) {
    const glm::mat4 open = glm::translate(glm::mat4(1.f), glm::vec3(1, 2, 3)) * glm::scale(glm::mat4(1.f), glm::vec3(2, 1, 0.5f));
    const glm::mat4 close = glm::translate(glm::mat4(1.f), glm::vec3(3, 2, 3)) * glm::rotate(glm::mat4(1.f), glm::radians(90.f), glm::vec3(0, 1, 0)) *
                            glm::scale(glm::mat4(1.f), glm::vec3(2, 1, 0.5f));
    const InstanceMotion m = decompose_motion(open, close);
    glm::mat4x3 w, o;
    instance_maps_at(m, 0.f, w, o);
    expect_maps(open, w, o);
    instance_maps_at(m, 1.f, w, o);
    expect_maps(close, w, o);
    // Halfway: turned 45°, moved halfway, not shrunk (a slerp, not a blend of matrices).
    instance_maps_at(m, 0.5f, w, o);
    const glm::mat4 half = glm::translate(glm::mat4(1.f), glm::vec3(2, 2, 3)) * glm::rotate(glm::mat4(1.f), glm::radians(45.f), glm::vec3(0, 1, 0)) *
                           glm::scale(glm::mat4(1.f), glm::vec3(2, 1, 0.5f));
    expect_maps(half, w, o);
    // A mirror stays a mirror at every time.
    const glm::mat4 mirror = glm::scale(glm::mat4(1.f), glm::vec3(-1, 1, 1));
    const InstanceMotion mm = decompose_motion(mirror, glm::translate(glm::mat4(1.f), glm::vec3(0, 1, 0)) * mirror);
    instance_maps_at(mm, 0.f, w, o);
    expect_maps(mirror, w, o);
    instance_maps_at(mm, 0.5f, w, o);
    EXPECT_LT(glm::determinant(glm::mat3(w)), 0.f);
}

TEST(Motion, BoundsHoldThePlacedBoxAtEveryTime) {
    Pcg32 rng(4, 4);
    for (int trial = 0; trial < 20; ++trial) {
        auto random_map = [&] {
            const glm::vec3 axis = glm::normalize(glm::vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f));
            return glm::translate(glm::mat4(1.f), glm::vec3(4 * rng.next_float(), 4 * rng.next_float(), 4 * rng.next_float())) *
                   glm::rotate(glm::mat4(1.f), 6.f * rng.next_float(), axis) *
                   glm::scale(glm::mat4(1.f), glm::vec3(0.5f + rng.next_float()));
        };
        const InstanceMotion m = decompose_motion(random_map(), random_map());
        const Aabb box{glm::vec3(-1, -0.5f, -2), glm::vec3(1, 0.5f, 2)};
        const Aabb b = motion_bounds(m, box);
        for (int k = 0; k < 2000; ++k) {
            const float time = rng.next_float();
            glm::mat4x3 w, o;
            instance_maps_at(m, time, w, o);
            const glm::vec3 p(box.lo.x + rng.next_float() * 2, box.lo.y + rng.next_float(), box.lo.z + rng.next_float() * 4);
            const glm::vec3 q = w * glm::vec4(p, 1.f);
            ASSERT_TRUE(glm::all(glm::greaterThanEqual(q, b.lo - 1e-4f)) && glm::all(glm::lessThanEqual(q, b.hi + 1e-4f)))
                << trial << " at " << time;
        }
    }
}

RenderSettings small(int spp) {
    RenderSettings st;
    st.width = 48;
    st.height = 27;
    st.spp = spp;
    st.max_depth = 2;
    return st;
}

// The blurred image against the mean of `k` stills at times (i + 0.5) / k, per 6 × 3 block of
// pixels: the difference of the block means within 4.5 of its standard error (both sides' noise).
// The whole image's light too (its energy): the sums differ by less than 4.5 standard errors,
// taken from the blocks' spread.
void expect_blur_is_mean_of_stills(const SceneDescription& open, const SceneDescription& close,
                                   const std::function<SceneDescription(float)>& at, int spp, int k,
                                   LightSelection selection = LightSelection::automatic) {
    const RenderScene moving = build_render_scene(open, {}, nullptr, &close);
    ASSERT_TRUE(moving.motion.any());
    RenderSettings st = small(spp * k);
    st.light_selection = selection;
    const RenderResult blur = render(moving, st);
    std::vector<std::vector<float>> stills;
    for (int i = 0; i < k; ++i) {
        RenderSettings s1 = small(spp);
        s1.light_selection = selection;
        s1.seed = uint64_t(100 + i);
        stills.push_back(render(build_render_scene(at((float(i) + 0.5f) / float(k)), {}), s1).image.rgb);
    }
    const int bw = 8, bh = 9;  // blocks of pixels
    int checked = 0;
    double sum_a = 0, sum_b = 0, var_sum = 0;
    for (int by = 0; by < st.height; by += bh)
        for (int bx = 0; bx < st.width; bx += bw) {
            double a = 0, b = 0, a2 = 0, b2 = 0;
            int n = 0;
            for (int y = by; y < std::min(st.height, by + bh); ++y)
                for (int x = bx; x < std::min(st.width, bx + bw); ++x)
                    for (int c = 0; c < 3; ++c) {
                        const size_t i = (size_t(y) * st.width + x) * 3 + c;
                        double s = 0;
                        for (const auto& still : stills) s += still[i];
                        s /= k;
                        a += blur.image.rgb[i];
                        a2 += double(blur.image.rgb[i]) * blur.image.rgb[i];
                        b += s;
                        b2 += s * s;
                        ++n;
                    }
            // Pixels of a block differ in expectation, so their spread over-estimates the
            // noise: the bound is conservative, yet a blur in the wrong place (or none) moves a
            // block's mean by far more.
            const double va = a2 / n - (a / n) * (a / n), vb = b2 / n - (b / n) * (b / n);
            const double se = std::sqrt((va + vb) / n);
            EXPECT_NEAR(a / n, b / n, 4.5 * se + 1e-4) << "block at " << bx << "," << by;
            ++checked;
            sum_a += a;
            sum_b += b;
            var_sum += (va + vb) * n;
        }
    EXPECT_GT(checked, 10);
    EXPECT_NEAR(sum_a, sum_b, 4.5 * std::sqrt(var_sum) + 1e-3) << "the whole image's light";
}

TEST(Motion, MovingPlacementsBlurToTheMeanOfStills) {
    const SceneDescription open = instanced_field(4, 500);
    auto at = [&](float time) {
        SceneDescription d = open;
        for (InstanceDesc& in : d.instances)
            in.to_world = glm::translate(glm::mat4(1.f), glm::vec3(1.5f * time, 0, 0)) * glm::rotate(glm::mat4(1.f), time, glm::vec3(0, 1, 0)) *
                          in.to_world;
        return d;
    };
    // Translation is linear in time and the turn about y a slerp: the still at time t is the
    // blurred scene at t.
    const SceneDescription close = at(1.f);
    const RenderScene moving = build_render_scene(open, {}, nullptr, &close);
    EXPECT_EQ(moving.motion.instances.size(), 4u);
    EXPECT_FALSE(moving.motion.deforming());
    expect_blur_is_mean_of_stills(open, close, at, 8, 8);
}

TEST(Motion, DeformingMeshesBlurToTheMeanOfStills) {
    SceneDescription open = instanced_field(4, 500);
    flatten_instances(open);
    auto at = [&](float time) {
        SceneDescription d = open;
        for (MeshDesc& m : d.meshes)
            if (m.name == "displaced_sphere")
                for (glm::vec3& p : m.positions) p += time * glm::vec3(0.8f * p.y, 0.3f, 0);  // sheared and lifted
        return d;
    };
    const SceneDescription close = at(1.f);
    const RenderScene moving = build_render_scene(open, {}, nullptr, &close);
    EXPECT_TRUE(moving.motion.deforming());
    expect_blur_is_mean_of_stills(open, close, at, 8, 8);
}

TEST(Motion, AMovingCameraBlursToTheMeanOfStills) {
    const SceneDescription open = test::seen_whole(cornell_spheres());
    auto at = [&](float time) {
        SceneDescription d = open;
        CameraDesc c;
        frame_camera(open.camera, scene_bounds(open), c);
        c.cs184_orbit_dir.reset();  // placed: moved as given
        c.position += glm::vec3(0.4f * time, 0, 0);
        c.look_at += glm::vec3(0.4f * time, 0, 0);
        d.camera = c;
        return d;
    };
    const SceneDescription o = at(0.f), close = at(1.f);
    EXPECT_TRUE(build_render_scene(o, {}, nullptr, &close).motion.camera);
    expect_blur_is_mean_of_stills(o, close, at, 8, 8);
}

TEST(Motion, AShutterOverAStillSceneRendersTheStill) {
    const SceneDescription d = instanced_field(4, 500);
    const RenderScene still = build_render_scene(d, {});
    const RenderScene shut = build_render_scene(d, {}, nullptr, &d);
    EXPECT_FALSE(shut.motion.any());
    EXPECT_EQ(render(still, small(4)).image.rgb, render(shut, small(4)).image.rgb);
}

// The Cornell box's lamp (an emitting mesh) slides and a point light crosses the room: both are
// sampled where the path's time puts them, so the blur is the mean of stills and the light
// they send is the stills' (a lamp sampled where it was at the opening, or with the opening's
// density, would light the wrong wall or lose light), by every way of picking lights.
SceneDescription cornell_with_moving_lights(float time) {
    SceneDescription d = test::seen_whole(cornell_box());
    for (MeshDesc& m : d.meshes)
        if (m.material >= 0 && d.materials[size_t(m.material)].emits())
            for (glm::vec3& p : m.positions) p += time * glm::vec3(0.3f, 0.f, -0.2f);
    LightDesc point;
    point.kind = LightKind::point;
    point.radiance = glm::vec3(0.3f);
    const Aabb box = scene_bounds(d);
    point.position = box.lo + (box.hi - box.lo) * glm::vec3(0.2f + 0.6f * time, 0.7f, 0.5f);
    d.lights.push_back(point);
    return d;
}

TEST(Motion, MovingEmittersAndLightsBlurToTheMeanOfStills) {
    const SceneDescription open = cornell_with_moving_lights(0.f), close = cornell_with_moving_lights(1.f);
    const RenderScene s = build_render_scene(open, {}, nullptr, &close);
    EXPECT_TRUE(s.motion.emitters());
    EXPECT_FALSE(s.motion.light_triangles_close.empty());
    EXPECT_EQ(s.motion.delta_lights_close.size(), 1u);
    for (LightSelection sel : {LightSelection::all, LightSelection::power, LightSelection::tree}) {
        SCOPED_TRACE(int(sel));
        expect_blur_is_mean_of_stills(open, close, cornell_with_moving_lights, 8, 8, sel);
    }
}

// An emitting placement (placed in world space) that moves and grows: its triangles' area
// changes within the shutter, so a sample's density must be the area at the path's time.
TEST(Motion, AGrowingEmittingPlacementBlursToTheMeanOfStills) {
    auto at = [](float time) {
        SceneDescription d = test::seen_whole(cornell_box());
        for (size_t k = 0; k < d.meshes.size(); ++k)
            if (d.meshes[k].material >= 0 && d.materials[size_t(d.meshes[k].material)].emits()) {
                MeshDesc lamp = d.meshes[k];
                glm::vec3 c(0.f);
                for (const glm::vec3& p : lamp.positions) c += p / float(lamp.positions.size());
                for (glm::vec3& p : lamp.positions) p -= c;
                d.prototypes.push_back(lamp);
                InstanceDesc in;
                in.prototype = uint32_t(d.prototypes.size() - 1);
                in.to_world = glm::translate(glm::mat4(1.f), c + time * glm::vec3(-0.25f, 0.f, 0.1f)) *
                              glm::scale(glm::mat4(1.f), glm::vec3(1.f + 0.8f * time, 1.f, 1.f + 0.4f * time));
                d.instances.push_back(in);
                d.meshes.erase(d.meshes.begin() + long(k));
                break;
            }
        return d;
    };
    const SceneDescription open = at(0.f), close = at(1.f);
    ASSERT_EQ(open.instances.size(), 1u);
    const RenderScene s = build_render_scene(open, {}, nullptr, &close);
    ASSERT_FALSE(s.motion.light_triangles_close.empty());
    EXPECT_GT(s.motion.light_triangles_close[0].area, 1.3f * s.light_triangles[0].area);
    for (LightSelection sel : {LightSelection::all, LightSelection::tree}) {
        SCOPED_TRACE(int(sel));
        expect_blur_is_mean_of_stills(open, close, at, 8, 8, sel);
    }
}

TEST(Motion, LightsThatComeOrGoWithinTheShutterAreRefused) {
    const SceneDescription open = cornell_with_moving_lights(0.f);
    SceneDescription close = open;
    close.lights.pop_back();
    EXPECT_THROW(build_render_scene(open, {}, nullptr, &close), SceneError);
}

TEST(Motion, AClosingOfAnotherShapeIsRefused) {
    const SceneDescription open = instanced_field(4, 500);
    SceneDescription fewer = open;
    fewer.instances.pop_back();
    EXPECT_THROW(build_render_scene(open, {}, nullptr, &fewer), SceneError);
    SceneDescription flat = open;
    flatten_instances(flat);
    SceneDescription other = flat;
    other.meshes[1].positions.pop_back();
    EXPECT_THROW(build_render_scene(flat, {}, nullptr, &other), SceneError);
    RenderSceneOptions embree;
    embree.bvh.type = BvhType::embree;
    EXPECT_THROW(build_render_scene(open, embree, nullptr, &open), SceneError);
}

}  // namespace
}  // namespace tessera
