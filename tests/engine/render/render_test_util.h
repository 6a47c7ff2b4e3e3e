#pragma once
// Helpers for statistical render tests: tolerances come from the measured variance.
#include <cmath>

#include "engine/render/renderer.h"
#include "engine/scene/intersect.h"

namespace tessera::test {

struct MeanEstimate {
    double mean = 0;
    double se = 0;  // standard error of `mean`
};

// Mean luminance-free (channel 0) pixel value over an image whose pixels share one
// expectation (a furnace): pixels are independent, so se = sd/√n.
inline MeanEstimate iid_pixel_mean(const Image& img, int channel = 0) {
    const size_t n = size_t(img.width) * img.height;
    double s = 0, s2 = 0;
    for (size_t i = 0; i < n; ++i) {
        const double v = img.rgb[i * 3 + channel];
        s += v;
    }
    const double m = s / double(n);
    for (size_t i = 0; i < n; ++i) {
        const double d = img.rgb[i * 3 + channel] - m;
        s2 += d * d;
    }
    return {m, std::sqrt(s2 / double(n - 1) / double(n))};
}

// Mean over all channels and pixels of an image whose pixels differ in expectation: the noise
// is measured from two renders with different seeds (var of a pixel ≈ (a − b)²/2).
inline MeanEstimate paired_mean(const Image& a, const Image& b) {
    const size_t n = a.rgb.size();
    double s = 0, var = 0;
    for (size_t i = 0; i < n; ++i) {
        s += 0.5 * (double(a.rgb[i]) + b.rgb[i]);
        const double d = double(a.rgb[i]) - b.rgb[i];
        var += d * d / 2.0 / 2.0;  // variance of the pair's average
    }
    return {s / double(n), std::sqrt(var) / double(n)};
}

// One image's mean from two renders of `st` with seeds 1 and 2 (paired_mean's noise estimate).
inline MeanEstimate mean_of_two_seeds(const RenderScene& scene, RenderSettings st) {
    st.seed = 1;
    const Image a = render(scene, st).image;
    st.seed = 2;
    const Image b = render(scene, st).image;
    return paired_mean(a, b);
}

inline constexpr DirectLighting kStrategies[] = {DirectLighting::hemisphere, DirectLighting::importance, DirectLighting::mis};
inline const char* name(DirectLighting d) {
    return d == DirectLighting::hemisphere ? "hemisphere" : d == DirectLighting::importance ? "importance" : "mis";
}

// Hemisphere, light and MIS sampling of `st` (its `direct` ignored) give the same mean within
// five combined standard errors, and the image is not black.
inline void expect_strategies_agree(const RenderScene& scene, RenderSettings st) {
    double means[3], ses[3];
    for (int i = 0; i < 3; ++i) {
        st.direct = kStrategies[i];
        const MeanEstimate m = mean_of_two_seeds(scene, st);
        means[i] = m.mean;
        ses[i] = m.se;
    }
    for (int i = 1; i < 3; ++i)
        EXPECT_NEAR(means[i], means[0], 5 * std::hypot(ses[i], ses[0]))
            << name(kStrategies[i]) << " vs hemisphere: " << means[i] << " vs " << means[0];
    EXPECT_GT(means[0], 0.01);
}

inline RenderResult render_desc(const SceneDescription& d, const RenderSettings& st, RenderSceneOptions o = {}) {
    return render(build_render_scene(d, o), st);
}

}  // namespace tessera::test
