// The pass driver as render nodes use it: tiles rendered one at a time into films of their own,
// carried from pass to pass and assembled, or each through every target at once, give the
// one-process image bit for bit; a tile rendered twice from the same state gives the same film
// (a farm's late duplicate is harmless).
#include "engine/render/passes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "engine/camera/camera.h"
#include "engine/render/renderer.h"
#include "engine/render/tile_context.h"
#include "engine/scene/procedural.h"

namespace tessera {
namespace {

bool same_film(const Film& a, const Film& b) {
    if (a.sum.size() != b.sum.size() || a.sum_half.size() != b.sum_half.size() || a.stats.size() != b.stats.size()) return false;
    if (std::memcmp(a.sum.data(), b.sum.data(), a.sum.size() * sizeof(a.sum[0])) != 0) return false;
    if (!a.sum_half.empty() && (std::memcmp(a.sum_half.data(), b.sum_half.data(), a.sum_half.size() * sizeof(a.sum_half[0])) != 0 ||
                                std::memcmp(a.sum_quarter.data(), b.sum_quarter.data(), a.sum_quarter.size() * sizeof(a.sum_quarter[0])) != 0 ||
                                std::memcmp(a.sum_eighth.data(), b.sum_eighth.data(), a.sum_eighth.size() * sizeof(a.sum_eighth[0])) != 0))
        return false;
    if (a.count != b.count || a.done != b.done) return false;
    for (size_t i = 0; i < a.stats.size(); ++i)
        if (a.stats[i].n != b.stats[i].n || a.stats[i].mean != b.stats[i].mean || a.stats[i].m2 != b.stats[i].m2) return false;
    return true;
}

// Each tile on a context and film of its own, in reverse order, then assembled after every pass
// and ended by end_pass: the pass driver as a render node runs it, without the threads and the
// shared film of renderer.cpp. (The real render nodes against a real Redis:
// tests/server/farm/render_node_test.cpp.)
Image render_tiles_apart(const RenderScene& scene, const RenderSettings& s, int* passes) {
    const PassPlan plan = plan_passes(s, false, false);
    const Camera camera = make_camera(scene.camera, s.width, s.height);
    std::vector<Film> films;
    for (const TileRect& t : plan.tiles) films.push_back(Film::tile(t.x0, t.y0, t.width(), t.height(), plan.half_buffer, plan.adaptive));
    Film image(s.width, s.height, plan.half_buffer, plan.adaptive);
    for (int pass = 0, target = pass_target(s, plan, 0);; ++pass) {
        for (size_t i = plan.tiles.size(); i-- > 0;) {
            // Each tile's own lamps, as a render node finds them (seen_emitters.h).
            const TileRect& t = plan.tiles[i];
            const SeenEmitters seen = seen_emitters(scene, s, camera, t.x0, t.y0, t.width(), t.height());
            TileContext ctx(scene, s, camera, &seen);
            EXPECT_TRUE(render_tile(ctx, plan.tiles[i], films[i], target));
        }
        for (size_t i = 0; i < plan.tiles.size(); ++i) copy_tile_into(films[i], plan.tiles[i], image);
        *passes = pass + 1;
        const PassEnd end = end_pass(s, plan, image, nullptr, pass, target, 0, 0.0, false, false);
        if (end.stop) break;
        target = end.next_target;
    }
    return image.resolve();
}

RenderSettings settings() {
    RenderSettings s;
    s.width = 40;
    s.height = 30;
    s.spp = 16;
    s.max_depth = 3;
    s.seed = 5;
    s.tile_size = 16;
    s.threads = 2;
    s.estimate_error = true;  // passes of 1, 2, 4, 8, 16 samples, as the server renders
    return s;
}

TEST(Passes, TilesRenderedApartAndAssembledEqualOneProcess) {
    const RenderScene scene = build_render_scene(cornell_spheres(), {});
    for (bool adaptive : {false, true}) {
        RenderSettings s = settings();
        if (adaptive) s.adaptive = AdaptiveSettings{4, 0.05f};
        const Image one = render(scene, s).image;
        int passes = 0;
        const Image farm = render_tiles_apart(scene, s, &passes);
        EXPECT_GT(passes, 1) << "the test must cross pass boundaries";
        ASSERT_EQ(one.rgb.size(), farm.rgb.size());
        EXPECT_EQ(0, std::memcmp(one.rgb.data(), farm.rgb.data(), one.rgb.size() * sizeof(float))) << "adaptive " << adaptive;
        EXPECT_EQ(one.sample_count, farm.sample_count);
    }
}

TEST(Passes, ATileRenderedTwiceFromTheSameStateIsTheSameFilm) {
    const RenderScene scene = build_render_scene(cornell_spheres(), {});
    const RenderSettings s = settings();
    const Camera camera = make_camera(scene.camera, s.width, s.height);
    const TileRect t = make_tiles(s.width, s.height, s.tile_size)[4];
    Film before = Film::tile(t.x0, t.y0, t.width(), t.height(), true, false);
    TileContext warm(scene, s, camera);
    render_tile(warm, t, before, 2);  // the state a pass starts from
    Film a = before, b = before;
    TileContext ca(scene, s, camera), cb(scene, s, camera);
    render_tile(ca, t, a, 4);
    render_tile(cb, t, b, 4);
    EXPECT_TRUE(same_film(a, b));
    EXPECT_FALSE(same_film(a, before)) << "the pass must have added samples";
}

TEST(Passes, OutOfTimeKeepsTheRowsNotStarted) {
    const RenderScene scene = build_render_scene(cornell_spheres(), {});
    const RenderSettings s = settings();
    const Camera camera = make_camera(scene.camera, s.width, s.height);
    const TileRect t = make_tiles(s.width, s.height, s.tile_size)[0];
    Film f = Film::tile(t.x0, t.y0, t.width(), t.height(), true, false);
    TileContext ctx(scene, s, camera);
    int rows = 0;
    EXPECT_FALSE(render_tile(ctx, t, f, 4, [&] { return ++rows > 3; }));
    for (int y = 0; y < t.height(); ++y)
        EXPECT_EQ(f.count[size_t(y) * size_t(f.width)], y < 3 ? 4u : 0u) << "row " << y;
}

TEST(Passes, WholeTilesGiveThePassByPassImageAndCurve) {
    const RenderScene scene = build_render_scene(cornell_spheres(), {});
    const RenderSettings s = settings();
    const PassPlan plan = plan_passes(s, false, false);
    ASSERT_TRUE(plan.whole_tiles);
    ASSERT_EQ(plan.targets, (std::vector<int>{1, 2, 4, 8, 16}));
    const RenderResult one = render(scene, s);
    const Camera camera = make_camera(scene.camera, s.width, s.height);
    Film image(s.width, s.height, plan.half_buffer, plan.adaptive);
    std::vector<std::vector<TargetSums>> sums;
    for (size_t i = plan.tiles.size(); i-- > 0;) {
        const TileRect& t = plan.tiles[i];
        const SeenEmitters seen = seen_emitters(scene, s, camera, t.x0, t.y0, t.width(), t.height());
        TileContext ctx(scene, s, camera, &seen);
        Film film = Film::tile(t.x0, t.y0, t.width(), t.height(), plan.half_buffer, plan.adaptive);
        const WholeTile w = render_whole_tile(ctx, plan, i, film, nullptr, {}, [&] { return double(i); });
        copy_tile_into(film, t, image);
        EXPECT_FALSE(w.cut_short);
        ASSERT_EQ(w.sums.size(), plan.targets.size());
        sums.push_back(w.sums);
    }
    const Image whole = image.resolve();
    EXPECT_EQ(0, std::memcmp(one.image.rgb.data(), whole.rgb.data(), whole.rgb.size() * sizeof(float)));
    const ConvergenceCurve curve = whole_tile_curve(plan, sums);
    ASSERT_EQ(curve.points.size(), one.curve.points.size());
    for (size_t k = 0; k < curve.points.size(); ++k) {
        // The sums add in another order than one pass over the image: equal to the last bits.
        EXPECT_NEAR(curve.points[k].est_rel_mse, one.curve.points[k].est_rel_mse, 1e-9 * std::abs(one.curve.points[k].est_rel_mse)) << k;
        EXPECT_DOUBLE_EQ(curve.points[k].spp_mean, one.curve.points[k].spp_mean) << k;
        EXPECT_EQ(curve.points[k].seconds, double(plan.tiles.size() - 1)) << "timed when the last tile got there";
    }
    sums.pop_back();
    EXPECT_TRUE(whole_tile_curve(plan, sums).points.empty()) << "a point needs every tile";
}

TEST(Passes, EndPassStopsOnSppAtTheLastPlannedPass) {
    RenderSettings s = settings();
    s.estimate_error = false;
    const PassPlan plan = plan_passes(s, false, false);
    EXPECT_FALSE(plan.progressive) << "nothing measured: one pass";
    const Film film(s.width, s.height, false, false);
    const PassEnd end = end_pass(s, plan, film, nullptr, 0, s.spp, uint64_t(s.spp) * 40 * 30, 1.5, false, false);
    ASSERT_TRUE(end.stop);
    EXPECT_EQ(*end.stop, StopReason::spp);
    EXPECT_DOUBLE_EQ(end.point.spp_mean, s.spp);
    EXPECT_EQ(end.point.seconds, 1.5);
    EXPECT_EQ(end_pass(s, plan, film, nullptr, 0, s.spp, 0, 0.0, true, false).stop, StopReason::time_limit);
    EXPECT_EQ(end_pass(s, plan, film, nullptr, 0, s.spp, 0, 0.0, true, true).stop, StopReason::canceled);
    s.estimate_error = true;
    const PassPlan doubling = plan_passes(s, false, false);
    const PassEnd first = end_pass(s, doubling, Film(s.width, s.height, true, false), nullptr, 0, 1, 0, 0.0, false, false);
    EXPECT_FALSE(first.stop);
    EXPECT_EQ(first.next_target, 2);
}

// Denoising starts at the kDenoiseFrom pass; a pass before it is denoised only where the render
// ends there (its spp reached, the clock run out), never to test target_error, so a loose target
// stops at the same pass whatever the machine's speed; a canceled pass never.
TEST(Passes, DenoisesFromTheFourSppPassAndWhereTheRenderEnds) {
    const RenderScene scene = build_render_scene(cornell_spheres(), {});
    RenderSettings s = settings();
    s.estimate_error = false;
    s.denoise = true;
    s.target_error = 1e30;  // met by any denoised image
    const PassPlan plan = plan_passes(s, false, false);
    const Camera camera = make_camera(scene.camera, s.width, s.height);
    Film film(s.width, s.height, plan.half_buffer, plan.adaptive, plan.aovs);
    for (int pass = 0, target = 1; target < kDenoiseFrom; ++pass, target *= 2) {
        for (const TileRect& t : plan.tiles) {
            TileContext ctx(scene, s, camera);
            ASSERT_TRUE(render_tile(ctx, t, film, target));
        }
        const PassEnd going_on = end_pass(s, plan, film, nullptr, pass, target, 0, 0.0, false, false);
        EXPECT_FALSE(going_on.denoised) << target << " spp";
        EXPECT_FALSE(going_on.stop) << "target_error cannot stop a pass it did not denoise";
        if (target < 2) continue;  // one sample has no halves to denoise from
        EXPECT_TRUE(end_pass(s, plan, film, nullptr, pass, target, 0, 0.0, true, false).denoised) << "out of time";
        // A canceled pass is not: a paused job runs it again, and its pause waited for the denoiser.
        EXPECT_FALSE(end_pass(s, plan, film, nullptr, pass, target, 0, 0.0, false, true).denoised) << "canceled";
        EXPECT_FALSE(end_pass(s, plan, film, nullptr, pass, kDenoiseFrom, 0, 0.0, false, true).denoised) << "canceled at 4 spp";
        RenderSettings last = s;
        last.spp = target;
        EXPECT_TRUE(end_pass(last, plan_passes(last, false, false), film, nullptr, pass, target, 0, 0.0, false, false).denoised)
            << "the render's last pass";
        PassPlan capped = plan;
        capped.max_passes = pass + 1;
        EXPECT_TRUE(end_pass(s, capped, film, nullptr, pass, target, 0, 0.0, false, false).denoised)
            << "the pass cap's last pass";
    }
    for (const TileRect& t : plan.tiles) {
        TileContext ctx(scene, s, camera);
        ASSERT_TRUE(render_tile(ctx, t, film, kDenoiseFrom));
    }
    const PassEnd at_four = end_pass(s, plan, film, nullptr, 2, kDenoiseFrom, 0, 0.0, false, false);
    EXPECT_TRUE(at_four.denoised);
    EXPECT_EQ(at_four.stop, StopReason::target_error);
}

TEST(Passes, TilesCoverTheImageOnce) {
    const std::vector<TileRect> tiles = make_tiles(70, 33, 16);
    std::vector<int> covered(70 * 33, 0);
    for (const TileRect& t : tiles)
        for (int y = t.y0; y < t.y1; ++y)
            for (int x = t.x0; x < t.x1; ++x) ++covered[size_t(y) * 70 + size_t(x)];
    for (int c : covered) ASSERT_EQ(c, 1);
    EXPECT_EQ(tiles.size(), 5u * 3u);
}

}  // namespace
}  // namespace tessera
