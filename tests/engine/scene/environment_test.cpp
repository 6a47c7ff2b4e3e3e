#include "engine/scene/environment.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>
#include <stdexcept>

#include <gtest/gtest.h>

#include "engine/sampling/rng.h"
#include "engine/sampling/warp.h"
#include "engine/scene/procedural.h"

namespace tessera {
namespace {

EnvironmentMap sky() { return build_environment(64, 32, sky_environment(64, 32), "sky"); }

float luminance(const glm::vec3& c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

// χ² of sample counts per texel against n draws from a distribution of total weight `total`
// whose texel weights are weight(texel luminance) × sin θ (cells expecting under 5 pooled), and
// its degrees of freedom. Texels of weight 0 must have no samples.
std::pair<double, int> texel_chi_square(const EnvironmentMap& env, const std::vector<double>& count, int n, double total,
                                        double (*weight)(double lum, double floor), double floor) {
    double chi = 0, pooled_o = 0, pooled_e = 0;
    int cells = 0;
    for (int y = 0; y < env.height; ++y)
        for (int x = 0; x < env.width; ++x) {
            const double st = std::sin(kPi * (y + 0.5) / env.height);
            const double w = weight(luminance(env.texels[size_t(y) * env.width + x]), floor);
            const double e = n * w * st / total;
            const double o = count[size_t(y) * env.width + x];
            if (w == 0.0) {
                EXPECT_EQ(o, 0.0) << "texel " << x << ", " << y;
                continue;
            }
            if (e < 5) { pooled_o += o; pooled_e += e; continue; }
            chi += (o - e) * (o - e) / e;
            ++cells;
        }
    if (pooled_e > 0) { chi += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e; ++cells; }
    return {chi, cells - 1};
}

// Directions and map coordinates are inverses, and a texel's colour is read back at its centre.
TEST(Environment, DirectionsAndTexelsRoundTrip) {
    std::vector<float> rgb(8 * 4 * 3, 0.f);
    rgb[(2 * 8 + 5) * 3 + 1] = 7.f;  // texel (5, 2): green
    const EnvironmentMap env = build_environment(8, 4, rgb, "t");
    const glm::vec3 d = environment_direction((5 + 0.5f) / 8, (2 + 0.5f) / 4);
    EXPECT_NEAR(glm::length(d), 1.f, 1e-6f);
    EXPECT_EQ(environment_radiance(env, d), glm::vec3(0.f, 7.f, 0.f));
    const glm::vec2 uv = environment_uv(d);
    EXPECT_NEAR(uv.x, 5.5f / 8, 1e-5f);
    EXPECT_NEAR(uv.y, 2.5f / 4, 1e-5f);
    // CS184's convention: row 0 is the zenith, and u = 0.5 looks down −z.
    EXPECT_NEAR(environment_direction(0.3f, 0.f).y, 1.f, 1e-6f);
    const glm::vec3 minus_z = environment_direction(0.5f, 0.5f);
    EXPECT_NEAR(minus_z.z, -1.f, 1e-6f);
}

// Sampling picks texels with the probability the pdf gives them (χ² over all texels), and the
// pdf a sample reports is environment_pdf of its direction.
TEST(Environment, SamplesFollowTheDistributionChiSquare) {
    const EnvironmentMap env = sky();
    const int n = 400000;
    std::vector<double> count(size_t(env.width) * env.height, 0.0);
    Pcg32 rng(3, 5);
    for (int i = 0; i < n; ++i) {
        glm::vec3 wi, Le;
        float pdf;
        ASSERT_TRUE(sample_environment(env, {rng.next_float(), rng.next_float()}, wi, pdf, Le));
        const glm::vec2 uv = environment_uv(wi);
        const int x = std::min(env.width - 1, int(uv.x * env.width)), y = std::min(env.height - 1, int(uv.y * env.height));
        count[size_t(y) * env.width + x] += 1;
        ASSERT_NEAR(pdf, environment_pdf(env, wi), 1e-3f * pdf);
        ASSERT_EQ(Le, environment_radiance(env, wi));
    }
    const auto [chi, dof] = texel_chi_square(env, count, n, env.full.total_weight, [](double lum, double) { return lum; }, 0.0);
    EXPECT_LT(chi, dof + 5 * std::sqrt(2.0 * dof)) << "dof " << dof;
    // The sun holds most of the weight: sampling finds it.
    EXPECT_GT(dof, 100);
}

// The density integrates to one over the sphere (uniform directions, E[pdf / (1/4π)] = 1), and
// a constant map's density is the uniform sphere's away from the poles' rounding.
TEST(Environment, PdfIntegratesToOne) {
    const EnvironmentMap env = sky();
    Pcg32 rng(9, 9);
    double sum = 0;
    const int n = 2000000;
    for (int i = 0; i < n; ++i) {
        const float z = 1.f - 2.f * rng.next_float(), phi = 2.f * kPi * rng.next_float();
        const float r = std::sqrt(std::max(0.f, 1.f - z * z));
        sum += environment_pdf(env, {r * std::cos(phi), z, r * std::sin(phi)}) * 4.0 * kPi;
    }
    EXPECT_NEAR(sum / n, 1.0, 0.03);
    const EnvironmentMap flat = build_environment(64, 32, std::vector<float>(64 * 32 * 3, 1.f), "flat");
    EXPECT_NEAR(environment_pdf(flat, glm::normalize(glm::vec3(0.3f, 0.2f, -0.5f))), 1.f / (4.f * kPi), 0.01f / (4.f * kPi));
}

// The compensated distribution (for MIS'd light samples) is the luminance above the map's mean:
// texels at or below it have density 0, the rest are sampled in proportion (χ²), each sample's
// density is environment_pdf's, and it integrates to one. A flat map has nothing above its
// mean: it keeps the full distribution.
TEST(Environment, CompensatedSamplingTakesTheLuminanceAboveTheMean) {
    // Texels of random brightness, about half of them above the mean.
    std::vector<float> rgb(48 * 24 * 3);
    Pcg32 texels(11, 3);
    for (size_t i = 0; i < rgb.size(); i += 3) {
        const float v = 2.f * texels.next_float();
        rgb[i] = v;
        rgb[i + 1] = 0.5f * v;
        rgb[i + 2] = 0.25f * v;
    }
    const EnvironmentMap env = build_environment(48, 24, rgb, "random");
    const auto how = EnvironmentSampling::compensated;
    ASSERT_GT(env.compensated.floor, 0.f);
    const int n = 400000;
    std::vector<double> count(size_t(env.width) * env.height, 0.0);
    Pcg32 rng(4, 7);
    for (int i = 0; i < n; ++i) {
        glm::vec3 wi, Le;
        float pdf;
        ASSERT_TRUE(sample_environment(env, {rng.next_float(), rng.next_float()}, wi, pdf, Le, how));
        ASSERT_GT(luminance(Le), env.compensated.floor);
        const glm::vec2 uv = environment_uv(wi);
        const int x = std::min(env.width - 1, int(uv.x * env.width)), y = std::min(env.height - 1, int(uv.y * env.height));
        count[size_t(y) * env.width + x] += 1;
        ASSERT_NEAR(pdf, environment_pdf(env, wi, how), 1e-3f * pdf);
    }
    const auto [chi, dof] = texel_chi_square(env, count, n, env.compensated.total_weight,
                                             [](double lum, double floor) { return std::max(0.0, lum - floor); },
                                             double(env.compensated.floor));
    int dark = 0;
    for (int y = 0; y < env.height; ++y)
        for (int x = 0; x < env.width; ++x)
            if (luminance(env.texels[size_t(y) * env.width + x]) <= env.compensated.floor) {
                ++dark;
                EXPECT_EQ(environment_pdf(env, environment_direction((x + 0.5f) / env.width, (y + 0.5f) / env.height), how), 0.f);
            }
    EXPECT_LT(chi, dof + 5 * std::sqrt(2.0 * dof)) << "dof " << dof;
    EXPECT_GT(dof, 300);
    EXPECT_GT(dark, 300);
    // Under a sun only the sun is above the mean; the density still integrates to one.
    const EnvironmentMap sun = sky();
    int above = 0;
    for (const glm::vec3& c : sun.texels) above += luminance(c) > sun.compensated.floor;
    EXPECT_GT(above, 0);
    EXPECT_LT(above, sun.width * sun.height / 100);
    for (const EnvironmentMap* m : {&env, &sun}) {
        // 4x4 points within each texel, each weighted by its share of the texel's solid angle.
        double sum = 0;
        for (int y = 0; y < m->height; ++y)
            for (int x = 0; x < m->width; ++x)
                for (int j = 0; j < 4; ++j)
                    for (int i = 0; i < 4; ++i) {
                        const double v0 = (y + j / 4.0) / m->height, v1 = (y + (j + 1) / 4.0) / m->height;
                        const double dw = 2.0 * kPi / (4.0 * m->width) * (std::cos(kPi * v0) - std::cos(kPi * v1));
                        const float u = float((x + (i + 0.5) / 4.0) / m->width), v = float((v0 + v1) / 2);
                        sum += environment_pdf(*m, environment_direction(u, v), how) * dw;
                    }
        EXPECT_NEAR(sum, 1.0, 0.01) << m->source;
    }
    const EnvironmentMap flat = build_environment(16, 8, std::vector<float>(16 * 8 * 3, 1.f), "flat");
    const glm::vec3 d = glm::normalize(glm::vec3(0.3f, 0.2f, -0.5f));
    EXPECT_EQ(environment_pdf(flat, d, how), environment_pdf(flat, d));
}

// Hostile maps are refused with a reason; a black map samples nothing.
TEST(Environment, BadMapsAreRefused) {
    EXPECT_THROW(build_environment(0, 4, {}, "empty"), std::invalid_argument);
    EXPECT_THROW(build_environment(2, 2, std::vector<float>(5, 1.f), "short"), std::invalid_argument);
    std::vector<float> rgb(2 * 2 * 3, 1.f);
    rgb[4] = NAN;
    EXPECT_THROW(build_environment(2, 2, rgb, "nan"), std::invalid_argument);
    rgb[4] = -1.f;
    EXPECT_THROW(build_environment(2, 2, rgb, "negative"), std::invalid_argument);
    rgb[4] = 3e38f;
    rgb[7] = 3e38f;
    EXPECT_THROW(build_environment(2, 2, rgb, "huge"), std::invalid_argument);
    const EnvironmentMap black = build_environment(2, 2, std::vector<float>(12, 0.f), "black");
    glm::vec3 wi, Le;
    float pdf;
    EXPECT_FALSE(sample_environment(black, {0.5f, 0.5f}, wi, pdf, Le));
    EXPECT_EQ(environment_pdf(black, glm::vec3(0.f, 1.f, 0.f)), 0.f);
}

}  // namespace
}  // namespace tessera
