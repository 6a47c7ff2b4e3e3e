// The pass schedule as render nodes use it: tiles rendered one at a time into films of their
// own, carried from pass to pass and assembled, give the one-process image bit for bit; a tile
// rendered twice from the same state gives the same film (a farm's late duplicate is harmless).
#include "engine/render/passes.h"

#include <gtest/gtest.h>

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

// What a farm does: every pass, every tile on a context of its own, from the tile's film of the
// pass before; after the pass, the films assembled and the stop rule applied.
Image render_as_farm(const RenderScene& scene, const RenderSettings& s, int* passes) {
    const PassPlan plan = plan_passes(s, false, false);
    const Camera camera = make_camera(scene.camera, s.width, s.height);
    const std::vector<TileRect> tiles = make_tiles(s.width, s.height, s.tile_size);
    std::vector<Film> films;
    for (const TileRect& t : tiles) films.push_back(Film::tile(t.x0, t.y0, t.width(), t.height(), plan.half_buffer, plan.adaptive));
    Film image(s.width, s.height, plan.half_buffer, plan.adaptive);
    int target = 0;
    for (int pass = 0; pass < plan.max_passes; ++pass) {
        target = pass_target(s, plan, target);
        for (size_t i = tiles.size(); i-- > 0;) {  // any order
            TileContext ctx(scene, s, camera);
            EXPECT_TRUE(render_tile(ctx, tiles[i], films[i], target));
        }
        for (size_t i = 0; i < tiles.size(); ++i) copy_tile_into(films[i], tiles[i], image);
        ConvergencePoint pt = measure_error(image, nullptr);
        *passes = pass + 1;
        if (stop_after_pass(s, plan, image, target, pt, false, false)) break;
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
        const Image farm = render_as_farm(scene, s, &passes);
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
