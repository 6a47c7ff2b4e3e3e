// The denoiser against the truth on two small scenes: its image is better than the noisy one and
// its error estimate lies within 0.5-2x of the error measured against a converged reference;
// the same image whatever the thread count; nothing to denoise without two samples or the AOVs.
#include "engine/render/denoise.h"

#include <gtest/gtest.h>

#include <string>

#include "engine/render/film.h"
#include "engine/render/renderer.h"
#include "engine/scene/procedural.h"

namespace tessera {
namespace {

RenderSettings settings(int spp) {
    RenderSettings s;
    s.width = 48;
    s.height = 36;
    s.spp = spp;
    s.max_depth = 4;
    s.threads = 2;
    return s;
}

void expect_tracks_the_truth(const std::string& name) {
    SCOPED_TRACE(name);
    const RenderScene scene = build_render_scene(builtin_scene(name), {});
    RenderSettings rs = settings(2048);
    rs.seed = 7;
    rs.estimate_error = true;
    const RenderResult ref = render(scene, rs);
    // The reference's own error adds to what is measured against it.
    const double ref_err = ref.curve.points.back().est_rel_mse;
    ASSERT_GT(ref_err, 0.0);
    for (int spp : {8, 32}) {
        SCOPED_TRACE(spp);
        RenderSettings s = settings(spp);
        s.seed = 1;
        s.denoise = true;
        const RenderResult r = render(scene, s);
        ASSERT_TRUE(r.denoised);
        const double noisy = relative_mse(r.image, ref.image) - ref_err;
        const double denoised = relative_mse(r.denoised->image, ref.image) - ref_err;
        EXPECT_LT(denoised, noisy / 3) << "denoising gains at least 3x";
        const double est = r.curve.points.back().denoised_est_rel_mse;
        EXPECT_EQ(est, r.denoised->est_rel_mse);
        EXPECT_GE(est / denoised, 0.5) << "estimate " << est << ", true " << denoised;
        EXPECT_LE(est / denoised, 2.0) << "estimate " << est << ", true " << denoised;
        // The noisy image's estimate from the independent halves, exact in expectation.
        const double noisy_est = r.curve.points.back().est_rel_mse;
        EXPECT_GE(noisy_est / noisy, 0.7) << "estimate " << noisy_est << ", true " << noisy;
        EXPECT_LE(noisy_est / noisy, 1.4) << "estimate " << noisy_est << ", true " << noisy;
    }
}

TEST(Denoise, BetterThanNoisyAndItsEstimateTracksTheTruthOnTheCornellBox) { expect_tracks_the_truth("builtin:cornell_box"); }
TEST(Denoise, BetterThanNoisyAndItsEstimateTracksTheTruthInTheLampRoom) { expect_tracks_the_truth("builtin:lamp_room"); }

TEST(Denoise, SameImageWhateverTheThreadCount) {
    const RenderScene scene = build_render_scene(builtin_scene("builtin:cornell_spheres"), {});
    RenderSettings s = settings(8);
    s.denoise = true;
    s.threads = 1;
    const RenderResult one = render(scene, s);
    s.threads = 2;
    s.tile_size = 8;
    const RenderResult two = render(scene, s);
    ASSERT_TRUE(one.denoised && two.denoised);
    EXPECT_EQ(one.image.rgb, two.image.rgb);
    EXPECT_EQ(one.denoised->image.rgb, two.denoised->image.rgb);
    EXPECT_EQ(one.denoised->est_rel_mse, two.denoised->est_rel_mse);
    // Every pass from the second on has its denoised error; the first (one sample) has none.
    ASSERT_GE(one.curve.points.size(), 2u);
    EXPECT_LT(one.curve.points.front().denoised_est_rel_mse, 0.0);
    for (size_t i = 1; i < one.curve.points.size(); ++i) EXPECT_GE(one.curve.points[i].denoised_est_rel_mse, 0.0);
}

TEST(Denoise, NothingToDenoiseWithoutTwoSamplesOrTheFeatures) {
    const RenderScene scene = build_render_scene(builtin_scene("builtin:cornell_box"), {});
    RenderSettings s = settings(1);
    s.denoise = true;
    EXPECT_FALSE(render(scene, s).denoised) << "one sample has no halves";
    Film plain(8, 8, true, false);
    EXPECT_FALSE(can_denoise(plain));
    EXPECT_FALSE(denoise(plain));
    Film features(8, 8, false, false, kDenoiseAovs);
    EXPECT_TRUE(can_denoise(features));
    EXPECT_FALSE(denoise(features)) << "no samples yet";
}

TEST(Denoise, ATargetErrorStopsOnTheDenoisedImage) {
    const RenderScene scene = build_render_scene(builtin_scene("builtin:cornell_box"), {});
    RenderSettings s = settings(1024);
    s.target_error = 2e-3;
    const RenderResult noisy = render(scene, s);
    s.denoise = true;
    const RenderResult denoised = render(scene, s);
    EXPECT_EQ(noisy.curve.stop, StopReason::target_error);
    EXPECT_EQ(denoised.curve.stop, StopReason::target_error);
    EXPECT_LE(denoised.curve.points.back().denoised_est_rel_mse, 2e-3);
    EXPECT_LT(denoised.curve.points.back().spp_mean, noisy.curve.points.back().spp_mean / 2)
        << "the denoised image is good enough with far fewer samples";
}

}  // namespace
}  // namespace tessera
