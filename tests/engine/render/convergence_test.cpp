#include "engine/render/convergence.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "engine/render/renderer.h"
#include "engine/scene/procedural.h"
#include "tests/seen_whole.h"

namespace tessera {
namespace {

RenderSettings base() {
    RenderSettings s;
    s.width = 48;
    s.height = 36;
    s.spp = 64;
    s.max_depth = 2;
    s.direct = DirectLighting::hemisphere;  // noisy on purpose
    s.seed = 3;
    return s;
}

// The half-buffer estimate tracks the true error: in the furnace every pixel's exact value is
// known (1 + a + a²), so the measured relMSE against that constant image is the truth.
// With Sobol points too, where the two halves of a pixel's samples are correlated nets and their
// difference alone overstates the error by 2^α − 1 (seven times here, where the error falls
// as N^-3): the estimate measures α from its own samples (convergence.h).
TEST(Convergence, EstimateTracksTheMeasuredError) {
    const RenderScene scene = build_render_scene(furnace_box(0.5f, 1.f), {});
    for (SamplerKind k : {SamplerKind::independent, SamplerKind::sobol}) {
        RenderSettings s = base();
        s.estimate_error = true;
        s.sampler = k;
        Image exact(s.width, s.height);
        for (float& v : exact.rgb) v = 1.75f;
        RenderCallbacks cb;
        cb.reference = &exact;
        const RenderResult r = render(scene, s, cb);
        ASSERT_GE(r.curve.points.size(), 6u);
        for (const ConvergencePoint& p : r.curve.points) {
            if (p.spp_mean < 8) continue;  // the estimate needs a few samples per half
            EXPECT_GT(p.est_rel_mse, 0.4 * p.rel_mse) << p.spp_mean << " sobol " << (k == SamplerKind::sobol);
            EXPECT_LT(p.est_rel_mse, 2.5 * p.rel_mse) << p.spp_mean << " sobol " << (k == SamplerKind::sobol);
        }
        const auto& a = r.curve.points[3];
        const auto& b = r.curve.points.back();
        if (k == SamplerKind::independent) {
            // relMSE falls roughly as 1/spp: 64 spp against 8 spp.
            EXPECT_NEAR(a.rel_mse / b.rel_mse, b.spp_mean / a.spp_mean, 0.5 * b.spp_mean / a.spp_mean);
        } else {
            // The furnace under hemisphere sampling is a smooth integrand: scrambled nets beat
            // 1/spp by far (measured: 650× for 8× the samples).
            EXPECT_GT(a.rel_mse / b.rel_mse, 4 * b.spp_mean / a.spp_mean);
        }
        EXPECT_EQ(r.curve.stop, StopReason::spp);
    }
}

// Where Sobol points gain least and the error falls unevenly (the Cornell box at depth 5, light
// sampling: edges, a small lamp, indirect light), against a converged reference: the corrected
// estimate stays near the truth (measured with the CLI at 320x240 against a 4,096-spp reference:
// 0.63-0.96x from 8 to 128 spp, the reference's own error included), where the halves'
// difference alone said up to 2.7x. This smaller render, the whole box seen (measured 0.55-0.82x
// from 8 to 128 spp), against 2,048 independent samples, is held to 0.4-2.5x.
TEST(Convergence, EstimateTracksTheMeasuredErrorOnTheCornellBox) {
    const RenderScene scene = build_render_scene(test::seen_whole(cornell_box()), {});
    RenderSettings s = base();
    s.width = 64;
    s.height = 48;
    s.max_depth = 5;
    s.direct = DirectLighting::importance;
    RenderSettings ref = s;
    ref.spp = 2048;
    ref.sampler = SamplerKind::independent;
    const Image reference = render(scene, ref).image;
    s.estimate_error = true;
    s.spp = 128;
    RenderCallbacks cb;
    cb.reference = &reference;
    const RenderResult r = render(scene, s, cb);
    int checked = 0;
    for (const ConvergencePoint& p : r.curve.points) {
        if (p.spp_mean < 8) continue;
        EXPECT_GT(p.est_rel_mse, 0.4 * p.rel_mse) << p.spp_mean;
        EXPECT_LT(p.est_rel_mse, 2.5 * p.rel_mse) << p.spp_mean;
        ++checked;
    }
    EXPECT_EQ(checked, 5);
}

// The correction's two pieces: no change at α = 1 (independent samples) or without a split;
// 1/(2^α − 1) for halves; and α read back from the ratio it predicts, at the levels used.
TEST(Convergence, StratificationFactorAndOrderInvertEachOther) {
    EXPECT_EQ(stratification_factor(1.0, 2.0), 1.0);
    EXPECT_EQ(stratification_factor(2.5, 1.0), 1.0);
    EXPECT_NEAR(stratification_factor(2.0, 2.0), 1.0 / 3.0, 1e-12);
    EXPECT_NEAR(stratification_factor(3.0, 2.0), 1.0 / 7.0, 1e-12);
    EXPECT_EQ(convergence_order(2.0, 2.0, 1), 1.0);   // independent: the error halves with each level
    EXPECT_EQ(convergence_order(1.5, 2.0, 1), 1.0);   // noise below that: held at 1
    EXPECT_EQ(convergence_order(1e6, 2.0, 2), 3.0);   // held at 3
    for (double alpha : {1.3, 1.8, 2.6})
        for (double split : {2.0, 1.5625, 1.125})
            for (int levels : {1, 2}) {
                const double reach = std::ldexp(split, levels - 1);
                const double ratio = (std::exp2(alpha) - 1) * std::pow(reach, alpha) * stratification_factor(alpha, split);
                EXPECT_NEAR(convergence_order(ratio, split, levels), alpha, 1e-9) << alpha << " " << split << " " << levels;
            }
    EXPECT_NEAR(convergence_order(std::pow(4.0, 2.2), 2.0, 2), 2.2, 1e-9);
}

// Rendering in passes (to measure the error) gives the same image, bit for bit, as one pass.
TEST(Convergence, PassesDoNotChangeTheImage) {
    const RenderScene scene = build_render_scene(cornell_spheres(), {});
    RenderSettings s = base();
    const Image one = render(scene, s).image;
    s.estimate_error = true;
    const RenderResult multi = render(scene, s);
    EXPECT_GT(multi.curve.points.size(), 1u);
    EXPECT_EQ(0, std::memcmp(one.rgb.data(), multi.image.rgb.data(), one.rgb.size() * sizeof(float)));
}

TEST(Convergence, StopsAtTargetErrorOrTimeLimit) {
    const RenderScene scene = build_render_scene(cornell_spheres(), {});
    RenderSettings s = base();
    s.spp = 1 << 16;
    s.target_error = 0.05;
    const RenderResult r = render(scene, s);
    EXPECT_EQ(r.curve.stop, StopReason::target_error);
    EXPECT_LE(r.curve.points.back().est_rel_mse, 0.05);
    EXPECT_LT(r.curve.points.back().spp_mean, 1 << 16);
    s.target_error = 0;
    s.time_limit_s = 0.2;
    const RenderResult t = render(scene, s);
    EXPECT_EQ(t.curve.stop, StopReason::time_limit);
    EXPECT_LT(t.stats.render_seconds, 2.0);
}

// Leaving out what a render does not need: no half buffer without an error estimate, no
// variance statistics without adaptive sampling.
TEST(Convergence, FilmBuildsOnlyTheBuffersARenderNeeds) {
    const RenderScene scene = build_render_scene(cornell_box(), {});
    RenderSettings s = base();
    s.spp = 4;
    const RenderResult plain = render(scene, s);
    auto has = [](const std::vector<std::string>& v, const char* what) {
        for (const auto& x : v) if (x.find(what) != std::string::npos) return true;
        return false;
    };
    EXPECT_TRUE(has(plain.left_out, "half-sample"));
    EXPECT_TRUE(has(plain.left_out, "variance"));
    EXPECT_EQ(plain.curve.points.size(), 1u) << "one pass when nothing is measured";
    s.estimate_error = true;
    s.adaptive = AdaptiveSettings{2, 0.05f};
    const RenderResult full = render(scene, s);
    EXPECT_TRUE(has(full.built, "half-sample"));
    EXPECT_TRUE(has(full.built, "variance"));
}

TEST(Convergence, CsvAndSvgAreReadable) {
    ConvergenceCurve c;
    c.points = {{0.1, 1, 0.5, 0.1, 0.2, 0.4}, {0.2, 2, 0.25, 0.05, 0.1, 0.2}};
    const std::string csv = convergence_csv(c);
    EXPECT_EQ(csv, "seconds,spp_mean,rel_mse,mse,mae,est_rel_mse\n0.1,1,0.5,0.1,0.2,0.4\n0.2,2,0.25,0.05,0.1,0.2\n");
    const std::string svg = convergence_svg({c}, {"one"}, "title");
    for (const char* s : {"<svg", "polyline", "render time (seconds, log scale)", "relative MSE", ">one<", "1e-1"})
        EXPECT_NE(svg.find(s), std::string::npos) << s;
    // Labels and titles from jobs are text, never markup.
    const std::string hostile = convergence_svg({c, c}, {"a<b & \"c\"", "</text><script>x</script>"}, "t<i>tle\x01");
    EXPECT_NE(hostile.find(">a&lt;b &amp; &quot;c&quot;<"), std::string::npos) << hostile;
    EXPECT_EQ(hostile.find("<script>"), std::string::npos);
    EXPECT_EQ(hostile.find("<i>"), std::string::npos);
    EXPECT_EQ(hostile.find('\x01'), std::string::npos);
}

}  // namespace
}  // namespace tessera
