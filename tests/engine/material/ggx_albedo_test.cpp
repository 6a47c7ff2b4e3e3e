// Holds engine/material/ggx_albedo.cpp to ggx_albedo.h: the tabulated directional albedo of the
// GGX lobe with Schlick's Fresnel, E(μ, α) = f0·a + f90·b, is the integral it claims to be, and
// its cosine-weighted average is 2∫E(μ)μ dμ. Checked against Monte Carlo estimates with fixed
// seeds and tolerances from the estimates' own standard errors: one with the engine's GGX
// sampling (visible normals, random rather than the table's fixed strata), one that never
// samples GGX (cosine-weighted directions, f = F·D·G2 / (4 μo μi) from the definition), so that
// an error in the sampling routine the table is built on shows too; plus the smooth limit (a
// mirror with Schlick's Fresnel) and the bilinear lookup between table nodes.
#include "engine/material/ggx_albedo.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "engine/material/ggx_albedo_tables.h"
#include "engine/material/microfacet.h"
#include "engine/sampling/rng.h"
#include "engine/sampling/warp.h"
#include "tests/test_scale.h"

namespace tessera {
namespace {

// The table's grid: 32 values of μ from 0 to 1 and of √α from 0 to 1 (ggx_albedo.cpp); points on
// it are compared without interpolation error.
constexpr int kGrid = 31;
float grid_mu(int i) { return float(i) / float(kGrid); }
float grid_alpha(int j) {
    const float r = float(j) / float(kGrid);
    return r * r;
}

struct Mean {
    double sum = 0, sum2 = 0;
    int n = 0;
    void add(double x) { sum += x; sum2 += x * x; ++n; }
    double mean() const { return sum / n; }
    double se() const { return std::sqrt(std::max(0.0, sum2 / n - mean() * mean()) / n); }
};

struct Estimate {
    Mean a, b;  // E = f0·a + f90·b
};

glm::vec3 wo_at(float mu) { return {std::sqrt(std::max(0.f, 1.f - mu * mu)), 0.f, mu}; }

// Schlick's weights of f0 and f90 at the angle between wo and h.
void add_fresnel_split(Estimate& e, float oh, double w) {
    const double m = 1.0 - double(oh), m5 = (m * m) * (m * m) * m;
    e.a.add((1.0 - m5) * w);
    e.b.add(m5 * w);
}

// Visible normals (the engine's GGX sampling): f·cos/pdf = F·G2/G1(wo).
Estimate vndf_estimate(float mu, float alpha, int n, uint64_t seed) {
    Pcg32 rng(seed, 1);
    const glm::vec3 wo = wo_at(mu);
    const double g1o = ggx_g1(wo, alpha);
    Estimate e;
    for (int k = 0; k < n; ++k) {
        const float u1 = rng.next_float(), u2 = rng.next_float();
        const glm::vec3 h = ggx_sample_visible_h(wo, {u1, u2}, alpha);
        const float oh = glm::dot(wo, h);
        const glm::vec3 wi = 2.f * oh * h - wo;
        if (!(oh > 0.f) || !(wi.z > 0.f)) {
            add_fresnel_split(e, 1.f, 0.0);
            continue;
        }
        const double g2 = 1.0 / (1.0 + ggx_lambda(wo, alpha) + ggx_lambda(wi, alpha));
        add_fresnel_split(e, oh, g2 / g1o);
    }
    return e;
}

// Cosine-weighted directions, the lobe evaluated from D and Smith's G2 as its definition has it:
// f·cos/pdf = π·F·D·G2 / (4 μo μi). Independent of ggx_sample_visible_h.
Estimate cosine_estimate(float mu, float alpha, int n, uint64_t seed) {
    Pcg32 rng(seed, 2);
    const glm::vec3 wo = wo_at(mu);
    Estimate e;
    for (int k = 0; k < n; ++k) {
        const float u1 = rng.next_float(), u2 = rng.next_float();
        const glm::vec3 wi = sample_cosine_hemisphere(u1, u2);
        if (!(wi.z > 0.f)) {
            add_fresnel_split(e, 1.f, 0.0);
            continue;
        }
        const glm::vec3 h = glm::normalize(wo + wi);
        const double g2 = 1.0 / (1.0 + ggx_lambda(wo, alpha) + ggx_lambda(wi, alpha));
        const double w = kPi * ggx_d(h, alpha) * g2 / (4.0 * wo.z * wi.z);
        add_fresnel_split(e, glm::dot(wo, h), w);
    }
    return e;
}

void expect_matches(const GgxAlbedo& table, const Estimate& e, double allowance, const std::string& where) {
    EXPECT_NEAR(table.a, e.a.mean(), 5 * e.a.se() + allowance) << where << " (a, the f0 weight)";
    EXPECT_NEAR(table.b, e.b.mean(), 5 * e.b.se() + allowance) << where << " (b, the f90 weight)";
}

std::string point(float mu, float alpha) { return "mu " + std::to_string(mu) + ", alpha " + std::to_string(alpha); }

// On the table's nodes the lookup is the tabulated integral itself; the table's fixed 32 × 32
// strata over a continuous integrand (G2 → 0 at the horizon) are far more accurate than the 1e-3
// allowed beside five standard errors. Points off the diagonal: μ and α swapped in the table's
// indexing would show.
TEST(GgxAlbedo, TableNodesMatchVisibleNormalSampling) {
    const int n = 200000 / test::kWorkScale;
    const int nodes[][2] = {{6, 5}, {12, 20}, {20, 9}, {28, 28}, {16, 31}, {3, 14}};
    uint64_t seed = 1;
    for (const auto& ij : nodes) {
        const float mu = grid_mu(ij[0]), alpha = grid_alpha(ij[1]);
        expect_matches(ggx_albedo(mu, alpha), vndf_estimate(mu, alpha, n, seed++), 1e-3, point(mu, alpha));
    }
}

// The same integral estimated without the GGX sampling routine: a wrong density in
// ggx_sample_visible_h would make the table (built from it) disagree with D and G2. Rough enough
// lobes that cosine sampling has a modest variance.
TEST(GgxAlbedo, TableNodesMatchTheLobesDefinition) {
    const int n = 400000 / test::kWorkScale;
    const int nodes[][2] = {{25, 19}, {12, 25}, {18, 31}};
    uint64_t seed = 11;
    for (const auto& ij : nodes) {
        const float mu = grid_mu(ij[0]), alpha = grid_alpha(ij[1]);
        expect_matches(ggx_albedo(mu, alpha), cosine_estimate(mu, alpha, n, seed++), 1e-3, point(mu, alpha));
    }
}

// Between nodes the lookup is bilinear in (μ, √α); over a cell of 1/31 the curvature of E costs
// well under the 4e-3 allowed.
TEST(GgxAlbedo, LookupBetweenNodesStaysOnTheIntegral) {
    const int n = 200000 / test::kWorkScale;
    const float points[][2] = {{0.45f, 0.3f}, {0.7f, 0.05f}, {0.9f, 0.6f}, {0.33f, 0.9f}};
    uint64_t seed = 21;
    for (const auto& p : points)
        expect_matches(ggx_albedo(p[0], p[1]), vndf_estimate(p[0], p[1], n, seed++), 4e-3, point(p[0], p[1]));
}

// A smooth lobe is a mirror with Schlick's Fresnel at h = n: a = 1 − (1 − μ)⁵, b = (1 − μ)⁵, and
// nothing is lost to masking. α below the table's first row (and negative) reads that row.
TEST(GgxAlbedo, SmoothLimitIsSchlicksFresnel) {
    for (float mu : {0.3f, 0.5f, 0.77f, 0.9f, 1.f})
        for (float alpha : {0.f, 1e-6f, -1.f}) {
            const GgxAlbedo e = ggx_albedo(mu, alpha);
            const double m5 = std::pow(1.0 - mu, 5.0);
            // 2e-3: the bilinear lookup of (1 − μ)⁵ between nodes 1/31 apart (its curvature
            // 20 (1 − μ)³ costs up to 9e-4 at μ = 0.3).
            EXPECT_NEAR(e.a, 1.0 - m5, 2e-3) << point(mu, alpha);
            EXPECT_NEAR(e.b, m5, 2e-3) << point(mu, alpha);
            EXPECT_NEAR(e(1.f, 1.f), 1.0, 1e-3) << point(mu, alpha) << ": a white mirror reflects everything";
        }
}

// Single scattering never creates energy: a, b >= 0 and a + b (f0 = f90 = 1) at most 1, over
// the whole domain including its clamped edges; and the albedo is linear in f0 and f90.
TEST(GgxAlbedo, AlbedoIsBoundedAndLinearInF0AndF90) {
    for (float mu = -0.1f; mu <= 1.1f; mu += 0.05f)
        for (float alpha = -0.1f; alpha <= 1.2f; alpha += 0.05f) {
            const GgxAlbedo e = ggx_albedo(mu, alpha);
            ASSERT_TRUE(std::isfinite(e.a) && std::isfinite(e.b)) << point(mu, alpha);
            EXPECT_GE(e.a, 0.f) << point(mu, alpha);
            EXPECT_GE(e.b, 0.f) << point(mu, alpha);
            EXPECT_LE(e.a + e.b, 1.f + 1e-5f) << point(mu, alpha);
            EXPECT_FLOAT_EQ(e(0.04f, 0.7f), 0.04f * e.a + 0.7f * e.b);
        }
    // The roughest lobe (α = 1, a white mirror's F = 1) against an integration of its own
    // (uniform hemisphere, 300,000 samples, height-correlated Smith G2): E(1) = 0.3068 and
    // E(0.2) = 0.6414. Masking takes most of it at normal incidence, where D spreads widest.
    EXPECT_NEAR(ggx_albedo(1.f, 1.f)(1.f, 1.f), 0.3068f, 0.01f);
    EXPECT_NEAR(ggx_albedo(0.2f, 1.f)(1.f, 1.f), 0.6414f, 0.01f);
}

// The average is 2∫E(μ)μ dμ of the lookup itself (a fine midpoint rule over ggx_albedo; the
// table's trapezoid over 32 nodes differs by O(h²)), and of the lobe (μ drawn with density 2μ,
// one visible-normal sample each).
TEST(GgxAlbedo, AverageIsTheCosineWeightedIntegral) {
    const int n = 400000 / test::kWorkScale;
    uint64_t seed = 31;
    for (int j : {0, 8, 15, 28, 31}) {
        const float alpha = grid_alpha(j);
        const GgxAlbedo avg = ggx_albedo_average(alpha);
        double a = 0, b = 0;
        const int steps = 4096;
        for (int k = 0; k < steps; ++k) {
            const float mu = (float(k) + 0.5f) / steps;
            const GgxAlbedo e = ggx_albedo(mu, alpha);
            a += 2.0 * e.a * mu / steps;
            b += 2.0 * e.b * mu / steps;
        }
        EXPECT_NEAR(avg.a, a, 1e-3) << "alpha " << alpha;
        EXPECT_NEAR(avg.b, b, 1e-3) << "alpha " << alpha;
        EXPECT_LE(avg(1.f, 1.f), 1.f + 1e-5f) << "alpha " << alpha;

        Pcg32 rng(seed++, 3);
        Estimate mc;
        for (int k = 0; k < n; ++k) {
            const float mu = std::max(1e-4f, std::sqrt(rng.next_float()));
            const glm::vec3 wo = wo_at(mu);
            const float u1 = rng.next_float(), u2 = rng.next_float();
            const glm::vec3 h = ggx_sample_visible_h(wo, {u1, u2}, std::max(alpha, kMinAlpha));
            const float oh = glm::dot(wo, h);
            const glm::vec3 wi = 2.f * oh * h - wo;
            if (!(oh > 0.f) || !(wi.z > 0.f)) {
                add_fresnel_split(mc, 1.f, 0.0);
                continue;
            }
            const float al = std::max(alpha, kMinAlpha);
            const double g2 = 1.0 / (1.0 + ggx_lambda(wo, al) + ggx_lambda(wi, al));
            add_fresnel_split(mc, oh, g2 / ggx_g1(wo, al));
        }
        expect_matches(avg, mc, 2e-3, "average, alpha " + std::to_string(alpha));
    }
}

// A direction or roughness that is NaN or out of range reads the table's edge, never outside
// it (int(NaN) indexed anywhere: a glTF vertex asked about a NaN direction crashed).
TEST(GgxAlbedo, NanAndOutOfRangeReadTheTablesEdges) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    auto equal = [](GgxAlbedo a, GgxAlbedo b) { return a.a == b.a && a.b == b.b; };
    EXPECT_TRUE(equal(ggx_albedo(nan, 0.3f), ggx_albedo(0.f, 0.3f)));
    EXPECT_TRUE(equal(ggx_albedo(-2.f, 0.3f), ggx_albedo(0.f, 0.3f)));
    EXPECT_TRUE(equal(ggx_albedo(7.f, 0.3f), ggx_albedo(1.f, 0.3f)));
    EXPECT_TRUE(equal(ggx_albedo(0.5f, nan), ggx_albedo(0.5f, 0.f)));
    EXPECT_TRUE(equal(ggx_albedo(0.5f, 9.f), ggx_albedo(0.5f, 1.f)));
    EXPECT_TRUE(equal(ggx_albedo_average(nan), ggx_albedo_average(0.f)));
}

// The tables are integrated when the engine is built (ggx_albedo_table_gen); the numbers the
// engine carries are the quadrature's as this build computes it, to the bit, at every node: a
// stale or mis-printed table would shade every glTF material a little off.
TEST(GgxAlbedo, TheBuiltInTablesAreTheQuadraturesBitForBit) {
    const ggx_albedo_detail::Tables fresh = ggx_albedo_detail::integrate();
    const ggx_albedo_detail::Tables& built = ggx_albedo_detail::built_in();
    auto same = [](GgxAlbedo x, GgxAlbedo y) {
        return std::memcmp(&x.a, &y.a, sizeof(float)) == 0 && std::memcmp(&x.b, &y.b, sizeof(float)) == 0;
    };
    int differ = 0;
    for (size_t k = 0; k < fresh.e.size(); ++k) differ += !same(fresh.e[k], built.e[k]);
    for (size_t k = 0; k < fresh.avg.size(); ++k) differ += !same(fresh.avg[k], built.avg[k]);
    EXPECT_EQ(differ, 0);
    // And the lookups read the built-in tables (at the grid's corner the bilinear weights are 0).
    EXPECT_TRUE(same(ggx_albedo(0.f, 0.f), built.e[0]));
    EXPECT_TRUE(same(ggx_albedo_average(0.f), built.avg[0]));
}

}  // namespace
}  // namespace tessera
