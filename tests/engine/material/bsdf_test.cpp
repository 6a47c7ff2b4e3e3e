#include "engine/material/bsdf.h"

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <functional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/sampling/rng.h"

namespace tessera {
namespace {

// ---- a chi-square test of sampling against the density (pbrt-v3's and Mitsuba's) -------------

// Regularised lower incomplete gamma P(a, x) (Numerical Recipes 6.2): series below a + 1, Lentz's
// continued fraction above.
double gamma_p(double a, double x) {
    if (x <= 0) return 0;
    const double gln = std::lgamma(a);
    if (x < a + 1) {
        double ap = a, sum = 1 / a, del = sum;
        for (int n = 0; n < 10000 && std::abs(del) > std::abs(sum) * 1e-15; ++n) sum += (del *= x / ++ap);
        return sum * std::exp(-x + a * std::log(x) - gln);
    }
    double b = x + 1 - a, c = 1e300, d = 1 / b, h = d;
    for (int i = 1; i < 10000; ++i) {
        const double an = -i * (i - a);
        b += 2;
        d = an * d + b;
        if (std::abs(d) < 1e-300) d = 1e-300;
        c = b + an / c;
        if (std::abs(c) < 1e-300) c = 1e-300;
        d = 1 / d;
        const double del = d * c;
        h *= del;
        if (std::abs(del - 1) < 1e-15) break;
    }
    return 1 - std::exp(-x + a * std::log(x) - gln) * h;
}

constexpr int kTheta = 24, kPhi = 48, kSub = 16;

struct ChiSquare {
    double p_value = 0;  // probability of a statistic this large if sampling follows the density
    double mass = 0;     // ∫ pdf over the sphere (the probability that sampling succeeds)
    double success = 0;  // the fraction of samples that succeeded
    int dof = 0;
};

// Samples bin by (θ, φ) over the whole sphere; a cell's expected count is the density integrated
// over it (midpoint rule on kSub² points, dω = sin θ dθ dφ); failed samples form one more cell
// against 1 − ∫pdf. Cells expecting fewer than 5 are pooled (Mitsuba's rule).
ChiSquare chi_square(const Bsdf& b, const glm::vec3& wo, int samples, uint64_t seed,
                     const std::function<float(const glm::vec3&)>& pdf) {
    std::vector<double> observed(kTheta * kPhi + 1, 0.0), expected(kTheta * kPhi + 1, 0.0);
    Pcg32 rng(seed, 7);
    for (int i = 0; i < samples; ++i) {
        BsdfSample s;
        const float uc = rng.next_float();
        const glm::vec2 u(rng.next_float(), rng.next_float());
        if (!bsdf_sample(b, wo, uc, u, s)) { observed.back() += 1; continue; }
        const float theta = std::acos(std::clamp(s.wi.z, -1.f, 1.f));
        float phi = std::atan2(s.wi.y, s.wi.x);
        if (phi < 0) phi += 2 * kPi;
        const int ti = std::min(kTheta - 1, int(theta / kPi * kTheta));
        const int pi = std::min(kPhi - 1, int(phi / (2 * kPi) * kPhi));
        observed[ti * kPhi + pi] += 1;
    }
    // The density over one cell by the midpoint rule on n² points, refined until doubling n
    // changes it by under 0.02% (sharp lobes at grazing angles are a fraction of a degree wide).
    auto cell = [&](int ti, int pi, int n) {
        double sum = 0;
        const double dt = kPi / kTheta / n, dp = 2 * kPi / kPhi / n;
        for (int a = 0; a < n; ++a)
            for (int c = 0; c < n; ++c) {
                const double t = ti * (kPi / kTheta) + (a + 0.5) * dt, p = pi * (2 * kPi / kPhi) + (c + 0.5) * dp;
                const glm::vec3 w(std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t));
                sum += pdf(w) * std::sin(t) * dt * dp;
            }
        return sum;
    };
    double mass = 0;
    for (int ti = 0; ti < kTheta; ++ti)
        for (int pi = 0; pi < kPhi; ++pi) {
            int n = kSub;
            double coarse = cell(ti, pi, n), fine = cell(ti, pi, 2 * n);
            while (std::abs(fine - coarse) > 2e-4 * fine + 1e-8 && n < 1024) {
                n *= 2;
                coarse = fine;
                fine = cell(ti, pi, 2 * n);
            }
            expected[ti * kPhi + pi] = fine * samples;
            mass += fine;
        }
    expected.back() = std::max(0.0, 1 - mass) * samples;
    double chi = 0, pooled_o = 0, pooled_e = 0;
    int cells = 0;
    for (size_t i = 0; i < expected.size(); ++i) {
        if (expected[i] < 5) { pooled_o += observed[i]; pooled_e += expected[i]; continue; }
        chi += (observed[i] - expected[i]) * (observed[i] - expected[i]) / expected[i];
        ++cells;
    }
    if (pooled_e > 0) { chi += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e; ++cells; }
    else if (pooled_o > 0) chi = INFINITY;  // samples where the density says none can be
    ChiSquare r;
    r.dof = cells - 1;
    r.p_value = std::isfinite(chi) ? 1 - gamma_p(r.dof / 2.0, chi / 2.0) : 0;
    r.mass = mass;
    r.success = 1 - observed.back() / samples;
    return r;
}

glm::vec3 direction(float theta_deg) {
    const float t = theta_deg * kPi / 180.f;
    return {std::sin(t), 0.f, std::cos(t)};
}

struct Case {
    std::string name;
    Bsdf bsdf;
};

std::vector<Case> glossy_cases() {
    std::vector<Case> cases;
    Bsdf l;
    l.albedo = glm::vec3(0.8f);
    cases.push_back({"lambertian", l});
    for (float alpha : {0.05f, 0.25f, 0.7f}) {
        Bsdf c;
        c.kind = BsdfKind::conductor;
        c.alpha = alpha;
        c.eta = {0.2f, 0.9f, 1.1f};
        c.k = {3.9f, 2.4f, 2.2f};
        cases.push_back({"conductor alpha " + std::to_string(alpha), c});
    }
    for (float n : {4.f, 50.f}) {
        Bsdf p;
        p.kind = BsdfKind::phong;
        p.albedo = glm::vec3(0.9f);
        p.exponent = n;
        cases.push_back({"phong " + std::to_string(n), p});
    }
    for (float metallic : {0.f, 0.5f, 1.f})
        for (float roughness : {0.2f, 0.6f, 1.f}) {
            Bsdf m;
            m.kind = BsdfKind::metallic_roughness;
            m.albedo = {0.9f, 0.6f, 0.3f};
            m.metallic = metallic;
            m.alpha = roughness * roughness;
            cases.push_back({"metallic " + std::to_string(metallic) + " roughness " + std::to_string(roughness), m});
        }
    return cases;
}

constexpr float kIncidence[] = {5.f, 40.f, 75.f, 88.f};

// Sampling follows bsdf_pdf for every non-delta BSDF, several roughness values and incident
// angles: p-values above 0.01 over the number of tests (Šidák's correction, as Mitsuba does).
TEST(Bsdf, SamplingFollowsThePdfChiSquare) {
    const std::vector<Case> cases = glossy_cases();
    const double threshold = 1 - std::pow(1 - 0.01, 1.0 / double(cases.size() * std::size(kIncidence)));
    uint64_t seed = 1;
    for (const Case& c : cases)
        for (float theta : kIncidence) {
            const glm::vec3 wo = direction(theta);
            const ChiSquare r = chi_square(c.bsdf, wo, 400000, seed++, [&](const glm::vec3& wi) { return bsdf_pdf(c.bsdf, wo, wi); });
            EXPECT_GT(r.p_value, threshold) << c.name << " at " << theta << " degrees, dof " << r.dof;
            // The density integrates to the probability that sampling gives a direction.
            EXPECT_NEAR(r.mass, r.success, 0.01) << c.name << " at " << theta << " degrees";
            EXPECT_LE(r.mass, 1.005) << c.name;
        }
}

// The test can fail: the same samples judged against a density of another roughness.
TEST(Bsdf, ChiSquareRejectsAWrongDensity) {
    Bsdf c;
    c.kind = BsdfKind::conductor;
    c.alpha = 0.25f;
    Bsdf wrong = c;
    wrong.alpha = 0.28f;
    const glm::vec3 wo = direction(40.f);
    const ChiSquare r = chi_square(c, wo, 400000, 3, [&](const glm::vec3& wi) { return bsdf_pdf(wrong, wo, wi); });
    EXPECT_LT(r.p_value, 1e-6);
    Bsdf m;
    m.kind = BsdfKind::metallic_roughness;
    m.metallic = 0.5f;
    m.alpha = 0.3f;
    Bsdf m_wrong = m;
    m_wrong.metallic = 0.6f;  // the same lobes, mixed in other proportions
    const ChiSquare r2 = chi_square(m, wo, 400000, 4, [&](const glm::vec3& wi) { return bsdf_pdf(m_wrong, wo, wi); });
    EXPECT_LT(r2.p_value, 1e-6);
}

// A sample's weight is f·cos/pdf of its own direction, as eval and pdf compute them.
TEST(Bsdf, SampleWeightIsEvalOverPdf) {
    for (const Case& c : glossy_cases())
        for (float theta : kIncidence) {
            const glm::vec3 wo = direction(theta);
            Pcg32 rng(11, 3);
            for (int i = 0; i < 2000; ++i) {
                BsdfSample s;
                if (!bsdf_sample(c.bsdf, wo, rng.next_float(), {rng.next_float(), rng.next_float()}, s)) continue;
                const glm::vec3 expect = bsdf_f(c.bsdf, wo, s.wi) * (s.wi.z / bsdf_pdf(c.bsdf, wo, s.wi));
                for (int k = 0; k < 3; ++k) ASSERT_NEAR(s.weight[k], expect[k], 1e-3f * std::max(1.f, expect[k])) << c.name;
                ASSERT_FALSE(s.delta);
                ASSERT_NEAR(s.pdf, bsdf_pdf(c.bsdf, wo, s.wi), 1e-3f * s.pdf) << c.name;
            }
        }
}

// A vertex's BsdfAt (its terms from wo built once) gives what the free functions give, to the
// bit (signed zeros and NaN included), for directions on both sides of the surface, on it and
// undefined (a point light at the shading point): the path integrator's images depend on it. A
// glTF material's sample is weighed by the same f and density, to the bit.
TEST(Bsdf, AVertexsBsdfGivesTheFreeFunctionsValuesBitForBit) {
    std::vector<Case> cases = glossy_cases();
    Bsdf smooth;
    smooth.kind = BsdfKind::metallic_roughness;
    smooth.albedo = {0.9f, 0.6f, 0.3f};
    smooth.alpha = 0.5f * kSmoothAlpha;
    cases.push_back({"metallic_roughness, smooth", smooth});
    Bsdf glass;
    glass.kind = BsdfKind::glass;
    cases.push_back({"glass", glass});
    Pcg32 rng(17, 5);
    auto any_direction = [&] {
        glm::vec3 v = sample_uniform_hemisphere(rng.next_float(), rng.next_float());
        if (rng.next_float() < 0.5f) v.z = -v.z;
        return v;
    };
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const std::vector<glm::vec3> special = {{0.6f, 0.8f, 0.f}, {0.6f, 0.8f, -0.f}, {0.f, 0.f, 1.f}, {nan, nan, nan}};
    auto same = [](float a, float b) { return std::bit_cast<uint32_t>(a) == std::bit_cast<uint32_t>(b); };
    int weighed = 0;
    for (const Case& c : cases)
        for (int i = 0; i < 400; ++i) {
            // Over the whole sphere: a wo below the surface is a path inside a closed object.
            const glm::vec3 wo = i < int(special.size()) ? special[i] : any_direction();
            const BsdfAt at(c.bsdf, wo);
            for (int j = 0; j < 24; ++j) {
                const glm::vec3 wi = j < int(special.size()) ? special[j] : any_direction();
                const glm::vec3 f = at.f(wi), f_free = bsdf_f(c.bsdf, wo, wi);
                const BsdfSplit sp = at.split(wi), sp_free = bsdf_split(c.bsdf, wo, wi);
                for (int k = 0; k < 3; ++k) {
                    ASSERT_TRUE(same(f[k], f_free[k])) << c.name << " " << f[k] << " " << f_free[k];
                    ASSERT_TRUE(same(sp.diffuse[k], sp_free.diffuse[k])) << c.name;
                    ASSERT_TRUE(same(sp.glossy[k], sp_free.glossy[k])) << c.name;
                }
                ASSERT_TRUE(same(at.pdf(wi), bsdf_pdf(c.bsdf, wo, wi))) << c.name;
            }
            BsdfSample s;
            if (c.bsdf.kind != BsdfKind::metallic_roughness ||
                !bsdf_sample(c.bsdf, wo, rng.next_float(), {rng.next_float(), rng.next_float()}, s) || s.delta)
                continue;
            const float pdf = bsdf_pdf(c.bsdf, wo, s.wi);
            const glm::vec3 weight = bsdf_f(c.bsdf, wo, s.wi) * (s.wi.z / pdf);
            ASSERT_TRUE(same(s.pdf, pdf)) << c.name;
            for (int k = 0; k < 3; ++k) ASSERT_TRUE(same(s.weight[k], weight[k])) << c.name;
            ++weighed;
        }
    EXPECT_GT(weighed, 1000);  // the glTF samples above the surface were compared
}

// Helmholtz reciprocity: f(wo, wi) = f(wi, wo).
TEST(Bsdf, Reciprocity) {
    Pcg32 rng(5, 1);
    for (const Case& c : glossy_cases())
        for (int i = 0; i < 5000; ++i) {
            const glm::vec3 a = sample_uniform_hemisphere(rng.next_float(), rng.next_float());
            const glm::vec3 b = sample_uniform_hemisphere(rng.next_float(), rng.next_float());
            const glm::vec3 fab = bsdf_f(c.bsdf, a, b), fba = bsdf_f(c.bsdf, b, a);
            for (int k = 0; k < 3; ++k) ASSERT_NEAR(fab[k], fba[k], 1e-4f * std::max(1.f, fab[k])) << c.name;
        }
}

// The directional albedo ∫ f·cos dωi (the mean sample weight): at most 1 for every BSDF with
// white parameters, and exactly the Lambertian albedo or the mirror's reflectance.
double directional_albedo(const Bsdf& b, const glm::vec3& wo, int n = 200000) {
    Pcg32 rng(21, 9);
    double sum = 0;
    for (int i = 0; i < n; ++i) {
        BsdfSample s;
        if (bsdf_sample(b, wo, rng.next_float(), {rng.next_float(), rng.next_float()}, s)) sum += s.weight.x;
    }
    return sum / n;
}

TEST(Bsdf, WhiteBsdfsReflectAtMostWhatArrives) {
    Bsdf lambert;
    lambert.albedo = glm::vec3(1.f);
    EXPECT_NEAR(directional_albedo(lambert, direction(30.f)), 1.0, 1e-6);
    Bsdf mirror;
    mirror.kind = BsdfKind::mirror;
    mirror.albedo = glm::vec3(1.f);
    EXPECT_EQ(directional_albedo(mirror, direction(60.f)), 1.0);
    for (float alpha : {0.05f, 0.3f, 1.f}) {
        Bsdf c;  // a perfect conductor: k → ∞ gives F = 1
        c.kind = BsdfKind::conductor;
        c.alpha = alpha;
        c.eta = glm::vec3(1.f);
        c.k = glm::vec3(1e4f);
        Bsdf m;
        m.kind = BsdfKind::metallic_roughness;
        m.albedo = glm::vec3(1.f);
        m.alpha = alpha;
        for (float metallic : {0.f, 1.f}) {
            m.metallic = metallic;
            for (float theta : kIncidence) {
                const double ac = directional_albedo(c, direction(theta)), am = directional_albedo(m, direction(theta));
                EXPECT_LE(ac, 1.0 + 0.01) << "conductor alpha " << alpha << " at " << theta;
                EXPECT_LE(am, 1.0 + 0.01) << "metallic " << metallic << " alpha " << alpha << " at " << theta;
                // Single scattering loses energy only where masking matters: little when smooth.
                if (alpha <= 0.05f && theta < 80.f) {
                    EXPECT_GT(ac, 0.97) << "conductor at " << theta;
                }
            }
        }
    }
}

// Glass: the Fresnel split is sampled exactly; ior 1 transmits everything straight on; total
// internal reflection beyond the critical angle; reflection + transmission conserve energy
// (after the η² radiance factor is undone).
TEST(Bsdf, GlassSplitsByFresnel) {
    Bsdf g;
    g.kind = BsdfKind::glass;
    g.albedo = glm::vec3(1.f);
    g.transmittance = glm::vec3(1.f);
    g.ior = 1.f;
    BsdfSample s;
    const glm::vec3 wo = glm::normalize(glm::vec3(0.3f, -0.2f, 0.9f));
    ASSERT_TRUE(bsdf_sample(g, wo, 0.5f, {0.f, 0.f}, s));
    EXPECT_NEAR(glm::length(s.wi + wo), 0.f, 1e-6f);  // straight through
    EXPECT_NEAR(s.weight.x, 1.f, 1e-6f);
    g.ior = 1.f / 1.5f;  // from inside glass
    const float critical = std::asin(1.f / 1.5f);
    const glm::vec3 grazing(std::sin(critical + 0.05f), 0.f, std::cos(critical + 0.05f));
    for (float uc : {0.f, 0.5f, 0.999f}) {
        ASSERT_TRUE(bsdf_sample(g, grazing, uc, {0.f, 0.f}, s));
        EXPECT_GT(s.wi.z, 0.f);  // reflected, whatever uc
    }
    g.ior = 1.5f;
    for (float theta : {0.f, 30.f, 60.f, 85.f}) {
        const glm::vec3 w = direction(theta);
        const float F = fresnel_dielectric(w.z, 1.5f);
        Pcg32 rng(2, 2);
        int reflected = 0;
        double energy = 0;
        const int n = 100000;
        for (int i = 0; i < n; ++i) {
            ASSERT_TRUE(bsdf_sample(g, w, rng.next_float(), {0.f, 0.f}, s));
            ASSERT_TRUE(s.delta);
            if (s.wi.z > 0) ++reflected;
            energy += s.wi.z > 0 ? s.weight.x : s.weight.x * 1.5f * 1.5f;
            // Snell's law
            if (s.wi.z < 0) {
                ASSERT_NEAR(std::sqrt(1 - s.wi.z * s.wi.z) * 1.5f, std::sqrt(1 - w.z * w.z), 1e-5f);
            }
        }
        const double sd = std::sqrt(F * (1 - F) / n);
        EXPECT_NEAR(double(reflected) / n, F, 5 * sd + 1e-9) << theta;
        EXPECT_NEAR(energy / n, 1.0, 1e-5) << theta;
    }
}

// Fresnel: the exact conductor formula meets its limits (normal incidence and grazing), and the
// dielectric one meets the normal-incidence value ((η−1)/(η+1))².
TEST(Bsdf, FresnelLimits) {
    EXPECT_NEAR(fresnel_dielectric(1.f, 1.5f), 0.04f, 1e-6f);
    EXPECT_NEAR(fresnel_dielectric(0.f, 1.5f), 1.f, 1e-6f);
    const float eta = 0.2f, k = 3.9f;
    EXPECT_NEAR(fresnel_conductor(1.f, eta, k), ((eta - 1) * (eta - 1) + k * k) / ((eta + 1) * (eta + 1) + k * k), 1e-5f);
    EXPECT_NEAR(fresnel_conductor(0.f, eta, k), 1.f, 1e-5f);
    // With k = 0 a conductor is a dielectric.
    for (float c : {0.1f, 0.5f, 0.9f}) EXPECT_NEAR(fresnel_conductor(c, 1.5f, 0.f), fresnel_dielectric(c, 1.5f), 1e-5f);
}

// Delta lobes say so; black ones end the path.
TEST(Bsdf, KindsReportDeltaAndBlack) {
    Bsdf b;
    EXPECT_FALSE(bsdf_is_delta(b));
    b.albedo = glm::vec3(0.f);
    EXPECT_TRUE(bsdf_is_black(b));
    b.kind = BsdfKind::mirror;
    EXPECT_TRUE(bsdf_is_delta(b));
    b.kind = BsdfKind::glass;
    EXPECT_FALSE(bsdf_is_black(b));  // it still transmits
    EXPECT_EQ(bsdf_f(b, direction(10.f), direction(-10.f)), glm::vec3(0.f));
    EXPECT_EQ(bsdf_pdf(b, direction(10.f), direction(-10.f)), 0.f);
}

}  // namespace
}  // namespace tessera
