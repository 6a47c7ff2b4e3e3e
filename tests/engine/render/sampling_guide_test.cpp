// Guided sampling: the targets spend the pass's budget (their mean is the pass's), keep the
// halves equal, take from no pixel, and favour the pixels whose error is large as the 1/n model
// says they should (a smaller modelled error than spending evenly) and whose samples are cheap; a guided render gives the same
// image whatever the thread count, and it is unbiased: its image's mean over a region equals a
// uniform render's to within their noise.
#include "engine/render/sampling_guide.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <vector>

#include "engine/io/scene_loader.h"
#include "engine/render/film.h"
#include "engine/render/passes.h"
#include "engine/render/renderer.h"
#include "engine/scene/procedural.h"
#include "tests/seen_whole.h"

namespace tessera {
namespace {

Film film_with_counts(int w, int h, uint32_t count) {
    Film f(w, h, false, false, kDenoiseAovs);
    std::fill(f.count.begin(), f.count.end(), count);
    return f;
}

// The error the 1/n model predicts after the pass: Σ e_p n_p / n'_p.
double modelled_error(const Film& f, const std::vector<float>& e, const std::vector<uint32_t>& goal) {
    double s = 0;
    for (size_t p = 0; p < e.size(); ++p) s += double(e[p]) * f.count[p] / double(goal[p]);
    return s;
}

TEST(SamplingGuide, TargetsSpendThePassBudgetEvenlyKeptAndNeverTakeSamples) {
    const int W = 64, H = 48;
    Film f = film_with_counts(W, H, 8);
    // An image's error as a render's is: low and smooth across surfaces, high along a silhouette
    // and at a lamp's rim, with each pixel's estimate noisy about that.
    std::mt19937 rng(3);
    std::lognormal_distribution<float> noise(0.f, 0.5f);
    std::vector<float> e(size_t(W) * H);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const bool silhouette = std::abs(x - 20 - y / 3) <= 1, rim = std::hypot(x - 48, y - 12) < 4;
            e[size_t(y) * W + x] = (silhouette || rim ? 1e-3f : 1e-5f * (1.f + float(x) / W)) * noise(rng);
        }
    // Some pixels have more samples already, as after a guided pass.
    for (size_t p = 0; p < f.count.size(); p += 7) f.count[p] = 40;
    for (int mean : {16, 32, 128}) {
        SCOPED_TRACE(mean);
        const std::vector<uint32_t> g = guided_targets(f, e, mean, 16 * mean);
        ASSERT_EQ(g.size(), f.count.size());
        double sum = 0;
        for (size_t p = 0; p < g.size(); ++p) {
            EXPECT_GE(g[p], f.count[p]);
            EXPECT_EQ((g[p] - f.count[p]) % 2, 0u) << "the halves stay equal";
            EXPECT_LE(g[p], uint32_t(16 * mean));
            sum += g[p];
        }
        EXPECT_NEAR(sum / double(g.size()), double(mean), 1.0) << "the pass's mean, up to rounding to even";
        std::vector<uint32_t> even(f.count.size());
        for (size_t p = 0; p < even.size(); ++p) even[p] = std::max<uint32_t>(f.count[p], uint32_t(mean));
        EXPECT_LT(modelled_error(f, e, g), 0.8 * modelled_error(f, e, even)) << "better spent than evenly";
        EXPECT_EQ(g, guided_targets(f, e, mean, 16 * mean)) << "the same targets every time";
    }
}

TEST(SamplingGuide, SamplesGoWhereTheErrorIsAndToItsNeighbours) {
    const int W = 40, H = 30;
    const Film f = film_with_counts(W, H, 8);
    std::vector<float> e(size_t(W) * H, 1e-6f);
    const size_t hot = size_t(15) * W + 20;
    e[hot] = 1e-2f;
    const std::vector<uint32_t> g = guided_targets(f, e, 16, 256);
    EXPECT_GT(g[hot], 64u);
    // Its neighbours may hide the same error from their own samples (a rim whose samples missed the lamp).
    EXPECT_GT(g[hot + 1], 32u);
    EXPECT_GT(g[hot - W], 32u);
    EXPECT_LE(g[0], 16u) << "a far pixel gets less than the mean";
    // Error in one pixel alone (and its neighbours', widened) and a budget beyond what they can
    // take at the cap: they get the cap, and the pixels whose error is zero so far (all their
    // samples alike) still share the rest, so that the pass keeps its mean.
    std::vector<float> lone(size_t(W) * H, 0.f);
    lone[hot] = 1e-2f;
    const std::vector<uint32_t> capped = guided_targets(f, lone, 64, 128);
    EXPECT_EQ(capped[hot], 128u);
    EXPECT_GT(capped[0], 8u) << "a pixel whose error is zero so far is still sampled";
    EXPECT_NEAR(std::accumulate(capped.begin(), capped.end(), 0.0) / double(capped.size()), 64.0, 1.0);
    // Nothing to go by (no error anywhere, or none finite): every pixel alike.
    for (float bad : {0.f, std::nanf(""), -1.f}) {
        const std::vector<float> flat(size_t(W) * H, bad);
        for (uint32_t t : guided_targets(f, flat, 16, 256)) EXPECT_EQ(t, 16u);
    }
}

// Where a pixel's samples cost more (more rays each), the same error buys fewer of them:
// n' ∝ √(e n / c), so at 16 times the cost a quarter of the samples beyond what it has.
TEST(SamplingGuide, CostlierSamplesAreSpentMoreSparingly) {
    const int W = 32, H = 32;
    Film f = film_with_counts(W, H, 8);
    for (size_t p = 0; p < f.rays.size(); ++p) f.rays[p] = float(f.count[p]) * (p < f.rays.size() / 2 ? 1.f : 16.f);
    const std::vector<float> e(size_t(W) * H, 1e-4f);
    const std::vector<uint32_t> g = guided_targets(f, e, 32, 512);
    const double cheap = g[size_t(W) * 4 + 5], dear = g[size_t(W) * 28 + 5];
    EXPECT_NEAR(dear / cheap, 0.25, 0.03) << cheap << " samples where one costs a ray, " << dear << " where it costs 16";
    Film free_of_cost = film_with_counts(W, H, 8);
    free_of_cost.rays.clear();
    for (uint32_t t : guided_targets(free_of_cost, e, 32, 512)) EXPECT_EQ(t, 32u) << "no costs: one error, one target";
}

RenderSettings guided_settings(int spp, int threads) {
    RenderSettings s;
    s.width = 40;
    s.height = 30;
    s.spp = spp;
    s.max_depth = 3;
    s.threads = threads;
    s.tile_size = 8;
    s.seed = 5;
    s.denoise = true;
    return s;
}

TEST(SamplingGuide, AGuidedRenderIsTheSameWhateverTheThreadCountAndSamplesUnevenly) {
    const RenderScene scene = build_render_scene(test::seen_whole(builtin_scene("builtin:cornell_box")), {});
    const RenderResult one = render(scene, guided_settings(32, 1)), two = render(scene, guided_settings(32, 2));
    ASSERT_TRUE(one.denoised && two.denoised);
    EXPECT_EQ(one.image.rgb, two.image.rgb);
    EXPECT_EQ(one.image.sample_count, two.image.sample_count);
    EXPECT_EQ(one.denoised->image.rgb, two.denoised->image.rgb);
    const auto [fewest, most] = std::minmax_element(one.image.sample_count.begin(), one.image.sample_count.end());
    EXPECT_GE(*fewest, float(kGuidedFrom)) << "no pixel below the uniform passes";
    EXPECT_GT(*most, 64.f) << "the error's pixels get far more than the mean";
    const double mean = std::accumulate(one.image.sample_count.begin(), one.image.sample_count.end(), 0.0) / one.image.sample_count.size();
    EXPECT_NEAR(mean, 32.0, 1.0);
    RenderSettings uniform = guided_settings(32, 2);
    uniform.guided = false;
    const RenderResult u = render(scene, uniform);
    EXPECT_TRUE(std::all_of(u.image.sample_count.begin(), u.image.sample_count.end(), [](float c) { return c == 32.f; }));
}

// Which pixels get more samples depends on their samples so far, which could bias a pixel's
// mean; the image's mean (each pixel's, averaged) against a uniform render's, over many seeds'
// worth of pixels: the difference is within 4 standard errors of the two.
TEST(SamplingGuide, AGuidedImageHasTheUniformImagesMean) {
    const RenderScene scene = build_render_scene(test::seen_whole(builtin_scene("builtin:cornell_box")), {});
    RenderSettings g = guided_settings(32, 2), u = guided_settings(32, 2);
    u.guided = false;
    u.seed = 11;
    const RenderResult rg = render(scene, g), ru = render(scene, u);
    const size_t n = rg.image.sample_count.size();
    // Per pixel, the two images' difference; its mean over the image and that mean's standard error.
    double s = 0, s2 = 0;
    for (size_t p = 0; p < n; ++p) {
        const double d = (rg.image.rgb[p * 3] + rg.image.rgb[p * 3 + 1] + rg.image.rgb[p * 3 + 2]) -
                         (ru.image.rgb[p * 3] + ru.image.rgb[p * 3 + 1] + ru.image.rgb[p * 3 + 2]);
        s += d;
        s2 += d * d;
    }
    const double mean = s / double(n), se = std::sqrt((s2 / double(n) - mean * mean) / double(n));
    EXPECT_LT(std::abs(mean), 4 * se + 1e-6) << "mean difference " << mean << ", standard error " << se;
}

}  // namespace
}  // namespace tessera
