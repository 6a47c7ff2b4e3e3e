#include "engine/render/renderer.h"

#include <gtest/gtest.h>

#include <atomic>
#include <algorithm>
#include <cstring>
#include <vector>

#include <glm/gtc/type_ptr.hpp>

#include "engine/render/tile_context.h"
#include "engine/scene/procedural.h"
#include "tests/engine/render/render_test_util.h"
#include "tests/seen_whole.h"

namespace tessera {
namespace {

RenderSettings small(int spp = 4) {
    RenderSettings s;
    s.width = 64;
    s.height = 48;
    s.spp = spp;
    s.max_depth = 3;
    s.light_rays = 2;
    s.seed = 99;
    return s;
}

// Same seed, same image, bit for bit, whatever the thread count and tile size.
TEST(Renderer, BitwiseIdenticalForAnyThreadCountAndTileSize) {
    const RenderScene scene = build_render_scene(cornell_spheres(), {});
    RenderSettings s = small();
    s.threads = 1;
    s.tile_size = 64;
    const Image ref = render(scene, s).image;
    for (auto [threads, tile] : {std::pair{2, 8}, {3, 16}, {2, 7}}) {
        s.threads = threads;
        s.tile_size = tile;
        const Image img = render(scene, s).image;
        ASSERT_EQ(img.rgb.size(), ref.rgb.size());
        EXPECT_EQ(0, std::memcmp(img.rgb.data(), ref.rgb.data(), ref.rgb.size() * sizeof(float)))
            << threads << " threads, tile " << tile;
    }
    s.seed = 100;
    const Image other = render(scene, s).image;
    EXPECT_NE(0, std::memcmp(other.rgb.data(), ref.rgb.data(), ref.rgb.size() * sizeof(float)));
}

TEST(Renderer, CancellationStopsBetweenTiles) {
    const RenderScene scene = build_render_scene(cornell_spheres(), {});
    std::atomic<bool> cancel{false};
    size_t seen = 0;
    RenderCallbacks cb;
    cb.cancel = &cancel;
    cb.progress = [&](const RenderProgress& p) {
        seen = p.tiles_done;
        if (p.tiles_done >= 2) cancel = true;
    };
    RenderSettings s = small();
    s.threads = 1;
    s.tile_size = 8;
    const RenderResult r = render(scene, s, cb);
    EXPECT_TRUE(r.stats.canceled);
    EXPECT_LT(seen, size_t(48));  // 8×6 tiles in all
}

TEST(Renderer, ProgressReachesEveryTile) {
    const RenderScene scene = build_render_scene(cornell_box(), {});
    std::atomic<size_t> last{0};
    RenderCallbacks cb;
    cb.progress = [&](const RenderProgress& p) {
        size_t prev = last.load();
        while (p.tiles_done > prev && !last.compare_exchange_weak(prev, p.tiles_done)) {}
    };
    RenderSettings s = small(1);
    s.tile_size = 16;
    const RenderResult r = render(scene, s, cb);
    EXPECT_EQ(last.load(), size_t(4 * 3));
    EXPECT_EQ(r.stats.samples, uint64_t(64 * 48));
    EXPECT_EQ(r.stats.camera_rays, uint64_t(64 * 48));
}

// Welford against the write-ups' S2 − S1²/n: with a large mean the textbook form cancels to
// noise (here it is off by orders of magnitude), the online form does not.
TEST(Adaptive, WelfordKeepsPrecisionWhereSumsOfSquaresFail) {
    RunningStats w;
    float s1 = 0, s2 = 0;  // what a CS184 pixel accumulates (floats)
    const int n = 1000;
    for (int i = 0; i < n; ++i) {
        const double x = 1e4 + ((i % 2) ? 1.0 : -1.0);  // variance ≈ 1
        w.add(x);
        s1 += float(x);
        s2 += float(x * x);
    }
    EXPECT_NEAR(w.variance(), 1.001, 1e-3);
    const double naive = (double(s2) - double(s1) * s1 / n) / (n - 1);
    EXPECT_GT(std::abs(naive - 1.0), 10.0) << "naive variance " << naive;
}

TEST(Adaptive, ZeroMeanAndZeroVarianceStopWithoutNaN) {
    RunningStats zero;
    for (int i = 0; i < 32; ++i) zero.add(0.0);
    EXPECT_TRUE(zero.converged(0.05));  // μ = 0, σ = 0: nothing more to learn
    RunningStats flat;
    for (int i = 0; i < 32; ++i) flat.add(0.7);
    EXPECT_TRUE(flat.converged(0.05));
    RunningStats noisy_zero_mean;
    for (int i = 0; i < 32; ++i) noisy_zero_mean.add(i % 2 ? 1.0 : -1.0);
    EXPECT_FALSE(noisy_zero_mean.converged(0.05));  // keeps sampling, bounded by spp
}

TEST(Adaptive, NeverExceedsSppAndSpendsMoreAtEdges) {
    const RenderScene scene = build_render_scene(test::seen_whole(cornell_spheres()), {});
    RenderSettings s = small(256);
    s.width = 80;
    s.height = 60;
    s.max_depth = 1;
    s.adaptive = AdaptiveSettings{16, 0.05f};
    // CS184's rule reads each pixel's sample variance; with independent samples that variance is
    // what the pixel's error is made of, so where it goes is the rule's own behaviour. (Sobol
    // points stratify the pixel and the light, and the rule, blind to that, spends about evenly:
    // 63 against 65 samples here.)
    s.sampler = SamplerKind::independent;
    const RenderResult r = render(scene, s);
    float lo = 1e9f, hi = 0;
    for (float c : r.image.sample_count) {
        ASSERT_LE(c, 256.f);
        ASSERT_GE(c, 16.f);
        lo = std::min(lo, c);
        hi = std::max(hi, c);
    }
    EXPECT_LT(lo, hi);
    EXPECT_LT(double(r.stats.samples), 256.0 * 80 * 60);
    // Rank pixels by the local contrast of the final image: the most contrasted tenth (edges,
    // shadow boundaries) must have received more samples on average than the flattest third.
    std::vector<std::pair<double, double>> contrast_samples;
    auto lum = [&](int xx, int yy) { return double(illuminance(glm::make_vec3(r.image.pixel(xx, yy)))); };
    for (int y = 1; y < s.height - 1; ++y) {
        for (int x = 1; x < s.width - 1; ++x) {
            const double c = lum(x, y) + 1e-3;
            const double g = std::abs(lum(x + 1, y) - lum(x - 1, y)) + std::abs(lum(x, y + 1) - lum(x, y - 1));
            contrast_samples.push_back({g / c, r.image.sample_count[size_t(y) * s.width + x]});
        }
    }
    std::sort(contrast_samples.begin(), contrast_samples.end());
    const size_t n = contrast_samples.size();
    double edge_sum = 0, flat_sum = 0;
    const size_t edge_n = n / 10, flat_n = n / 3;
    for (size_t i = 0; i < flat_n; ++i) flat_sum += contrast_samples[i].second;
    for (size_t i = n - edge_n; i < n; ++i) edge_sum += contrast_samples[i].second;
    EXPECT_GT(edge_sum / edge_n, flat_sum / flat_n);
}

}  // namespace
}  // namespace tessera
