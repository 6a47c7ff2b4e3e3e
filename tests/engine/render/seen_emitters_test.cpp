// The lamps' exact pixel coverage (engine/render/seen_emitters.h): each pixel's coverage is the
// share of its camera rays that meet the lamp; the control variate leaves the image unbiased
// where something hides part of a lamp, and lowers the noise of the pixels on a lamp's rim; it is
// left out where a single projection does not hold.
#include "engine/render/seen_emitters.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "engine/render/passes.h"
#include "engine/render/renderer.h"
#include "engine/render/tile_context.h"
#include "engine/sampling/rng.h"
#include "engine/scene/procedural.h"

namespace tessera {
namespace {

// The Cornell box seen whole (its focal length is for 800×600), its 0.8 × 0.6 lamp in view.
SceneDescription box_in_view() {
    SceneDescription d = cornell_box();
    d.camera->focal_px = 0.f;
    return d;
}

// ... with an opaque plate under the lamp that hides part of it from the camera.
SceneDescription box_with_lamp_partly_hidden() {
    SceneDescription d = box_in_view();
    MeshDesc m;
    m.name = "plate";
    const float y = 1.3f;
    m.positions = {{-0.1f, y, 0.1f}, {0.35f, y, 0.1f}, {0.35f, y, -0.15f}, {-0.1f, y, -0.15f}};  // faces down, toward the camera
    m.indices = {0, 1, 2, 0, 2, 3};
    m.flat_normals = true;
    m.material = 0;  // the box's white
    d.meshes.push_back(std::move(m));
    return d;
}

RenderSettings small(int spp, uint64_t seed) {
    RenderSettings s;
    s.width = 160;
    s.height = 120;
    s.spp = spp;
    s.max_depth = 2;
    s.seed = seed;
    s.threads = 1;
    return s;
}

// One whole-image tile through the sample loop, with the control variate or without it.
Image render_with(const RenderScene& scene, const RenderSettings& s, bool with_cv) {
    const Camera camera = camera_for(scene, s);
    const SeenEmitters seen = seen_emitters(scene, s, camera, 0, 0, s.width, s.height);
    EXPECT_FALSE(seen.empty());
    Film film(s.width, s.height, false, false);
    TileContext ctx(scene, s, camera, with_cv ? &seen : nullptr);
    EXPECT_TRUE(render_tile(ctx, TileRect{0, 0, s.width, s.height}, film, s.spp));
    return film.resolve();
}

std::vector<size_t> pixels_with_lamps(const SeenEmitters& seen) {
    std::vector<size_t> out;
    for (size_t q = 0; q + 1 < seen.first.size(); ++q)
        if (seen.first[q + 1] > seen.first[q]) out.push_back(q);
    return out;
}

TEST(SeenEmitters, CoverageIsTheShareOfThePixelsRaysThatMeetTheLamp) {
    const RenderScene scene = build_render_scene(box_in_view(), {});
    const RenderSettings s = small(1, 1);
    const Camera camera = camera_for(scene, s);
    const SeenEmitters seen = seen_emitters(scene, s, camera, 0, 0, s.width, s.height);
    const std::vector<size_t> px = pixels_with_lamps(seen);
    ASSERT_GT(px.size(), 200u);
    // Interior pixels are wholly covered, rim pixels in part: both kinds must be there.
    size_t full = 0, part = 0;
    for (size_t q : px) (seen.mean[q].x > 9.999f ? full : part) += 1;
    EXPECT_GT(full, 50u);
    EXPECT_GT(part, 40u);
    // Rays uniform over each pixel (the box filter the sample loop draws), met lamps counted by
    // the lamps' own test: binomial per pixel, summed as a chi-square over the rim pixels.
    Pcg32 rng(7, 9);
    const int n = 4096;
    double chi2 = 0;
    int dof = 0;
    for (size_t q : px) {
        const int x = int(q % size_t(s.width)), y = int(q / size_t(s.width));
        int met = 0;
        for (int i = 0; i < n; ++i) {
            const float u = (float(x) + rng.next_float()) / float(s.width), v = 1.f - (float(y) + rng.next_float()) / float(s.height);
            const Ray ray = generate_ray(camera, u, v);
            for (uint32_t k = seen.first[q]; k < seen.first[q + 1]; ++k)
                if (SeenEmitters::hits(seen.lamps[seen.lamp_of[k]], ray)) { ++met; break; }
        }
        const double c = seen.mean[q].x / 10.0;  // the lamp's radiance is 10
        ASSERT_LE(c, 1.0 + 1e-5);
        if (c > 0.02 && c < 0.98) {
            chi2 += (met - n * c) * (met - n * c) / (n * c * (1 - c));
            ++dof;
        } else {
            EXPECT_NEAR(double(met) / n, c, 0.02) << "pixel " << x << "," << y;
        }
    }
    ASSERT_GT(dof, 30);
    EXPECT_LT(chi2, dof + 5 * std::sqrt(2.0 * dof)) << dof << " rim pixels";
}

// The same samples with and without it: per pixel the difference is the mean of that pixel's
// corrections, zero in expectation, and independent between pixels. Where the plate hides the
// lamp the samples see the plate, and the correction keeps the hidden part out.
TEST(SeenEmitters, ImageIsUnbiasedWithALampPartlyHidden) {
    const RenderScene scene = build_render_scene(box_with_lamp_partly_hidden(), {});
    const RenderSettings s = small(16, 3);
    const Image with = render_with(scene, s, true), without = render_with(scene, s, false);
    const SeenEmitters seen = seen_emitters(scene, s, camera_for(scene, s), 0, 0, s.width, s.height);
    double sum = 0, sum2 = 0, covered = 0;
    size_t n = 0;
    for (size_t q : pixels_with_lamps(seen)) {
        const double d = double(with.rgb[q * 3]) - double(without.rgb[q * 3]);
        sum += d;
        sum2 += d * d;
        covered += seen.mean[q].x;
        ++n;
    }
    ASSERT_GT(n, 200u);
    const double mean = sum / double(n), se = std::sqrt((sum2 / double(n) - mean * mean) / double(n - 1));
    EXPECT_GT(se, 0.0) << "the plate must hide part of the lamp, or every correction is zero";
    EXPECT_NEAR(mean, 0.0, 5 * se);
    // Power: coverage 2 % too high would move the mean by 0.02 of the covered radiance.
    EXPECT_LT(5 * se, 0.02 * covered / double(n));
}

// Two seeds' images differ by their noise alone: on the pixels under a lamp that nothing hides,
// with it that noise is what the ceiling and the box add, without it the lamp's coverage too.
TEST(SeenEmitters, LowersTheNoiseOfPixelsOnALampsRim) {
    const RenderScene scene = build_render_scene(box_in_view(), {});
    const RenderSettings a = small(16, 1), b = small(16, 2);
    const SeenEmitters seen = seen_emitters(scene, a, camera_for(scene, a), 0, 0, a.width, a.height);
    auto spread = [&](bool cv) {
        const Image ia = render_with(scene, a, cv), ib = render_with(scene, b, cv);
        double e = 0;
        for (size_t q : pixels_with_lamps(seen)) {
            if (seen.mean[q].x > 9.999f) continue;  // the rims
            for (int k = 0; k < 3; ++k) {
                const double m = 0.5 * (double(ia.rgb[q * 3 + k]) + ib.rgb[q * 3 + k]), d = double(ia.rgb[q * 3 + k]) - ib.rgb[q * 3 + k];
                e += d * d / (m * m + 0.01);
            }
        }
        return e;
    };
    const double with = spread(true), without = spread(false);
    EXPECT_LT(with, 0.1 * without) << with << " against " << without;
}

TEST(SeenEmitters, LeftOutWhereOneProjectionDoesNotHold) {
    const RenderScene scene = build_render_scene(box_in_view(), {});
    RenderSettings s = small(1, 1);
    auto built = [&](const RenderSettings& st) { return !seen_emitters(scene, st, camera_for(scene, st), 0, 0, st.width, st.height).empty(); };
    EXPECT_TRUE(built(s));
    RenderSettings lens = s;
    lens.lens_radius = 0.05f;
    EXPECT_FALSE(built(lens)) << "a thin lens";
    RenderSettings indirect = s;
    indirect.output = LightingOutput::indirect;
    EXPECT_FALSE(built(indirect)) << "emitters seen directly are not in the output";
    RenderSettings nth = s;
    nth.bounces = BounceMode::nth;
    nth.max_depth = 2;
    EXPECT_FALSE(built(nth)) << "only the second bounce is in the output";
    RenderSettings normals = s;
    normals.integrator = Integrator::normals;
    EXPECT_FALSE(built(normals));
    // A one-sided lamp seen from behind gives the camera nothing.
    SceneDescription above = box_in_view();
    above.camera->position = {0.f, 2.5f, 0.f};
    above.camera->look_at = {0.f, 0.f, 0.f};
    above.camera->up = {0.f, 0.f, -1.f};
    const RenderScene from_above = build_render_scene(above, {});
    EXPECT_TRUE(seen_emitters(from_above, s, camera_for(from_above, s), 0, 0, s.width, s.height).empty());
    // A tile holds its own pixels' lamps, the same as the whole image's there: a tile over the
    // lamp's lower left part, cut through it.
    const SeenEmitters whole = seen_emitters(scene, s, camera_for(scene, s), 0, 0, s.width, s.height);
    int x0 = s.width, y0 = s.height, x1 = 0, y1 = 0;
    for (size_t q : pixels_with_lamps(whole)) {
        const int x = int(q % size_t(s.width)), y = int(q / size_t(s.width));
        x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
    }
    const int tx = x0 - 2, ty = (y0 + y1) / 2, tw = (x1 - x0) / 2 + 2, th = y1 + 3 - ty;
    ASSERT_GT(tw, 4);
    ASSERT_GT(th, 2);
    const SeenEmitters tile = seen_emitters(scene, s, camera_for(scene, s), tx, ty, tw, th);
    ASSERT_FALSE(tile.empty());
    for (int y = ty; y < ty + th; ++y)
        for (int x = tx; x < tx + tw; ++x) {
            const size_t qw = size_t(y) * size_t(s.width) + size_t(x), qt = size_t(y - ty) * size_t(tw) + size_t(x - tx);
            EXPECT_EQ(whole.mean[qw], tile.mean[qt]) << x << "," << y;
            EXPECT_EQ(whole.first[qw + 1] - whole.first[qw], tile.first[qt + 1] - tile.first[qt]) << x << "," << y;
        }
}

// Hostile and extreme cases: emitters all round the camera (the furnace: walls behind it cross
// the camera's plane and are left to the samples, the pixels' coverages still at most one), and
// thousands of lamps each filling the image, which stop at the work bound.
TEST(SeenEmitters, ExtremeScenesStayBounded) {
    RenderSettings s = small(1, 1);
    const RenderScene glow = build_render_scene(furnace_box(0.5f, 1.f), {});
    const SeenEmitters inside = seen_emitters(glow, s, camera_for(glow, s), 0, 0, s.width, s.height);
    ASSERT_FALSE(inside.empty());
    for (const glm::vec3& m : inside.mean) EXPECT_LE(m.x, 1.f + 1e-5f);
    SceneDescription wall = box_in_view();
    const int lamp = int(wall.materials.size());
    MaterialDesc md = wall.materials.back();
    md.name = "wall lamp";
    md.emission = glm::vec3(1.f);
    md.kind = MaterialKind::emission;
    wall.materials.push_back(md);
    for (int i = 0; i < 3000; ++i) {
        MeshDesc m;
        m.name = "panel " + std::to_string(i);
        const float z = 2.f - 0.0005f * float(i);  // in front of the box, facing the camera, each one nearer
        m.positions = {{-20.f, -20.f, z}, {20.f, -20.f, z}, {20.f, 20.f, z}, {-20.f, 20.f, z}};
        m.indices = {0, 1, 2, 0, 2, 3};
        m.flat_normals = true;
        m.material = lamp;
        wall.meshes.push_back(std::move(m));
    }
    const RenderScene panels = build_render_scene(wall, {});
    ASSERT_GT(panels.light_triangles.size(), 6000u);
    const SeenEmitters bounded = seen_emitters(panels, s, camera_for(panels, s), 0, 0, s.width, s.height);
    EXPECT_FALSE(bounded.empty());
    EXPECT_LE(bounded.lamps_considered, 70u) << "each triangle's box is the whole image: about 64 of them at most";
    EXPECT_LE(bounded.lamps.size(), 64u);
    EXPECT_LE(bounded.lamp_of.size(), 4u * size_t(s.width) * size_t(s.height));
}

}  // namespace
}  // namespace tessera
