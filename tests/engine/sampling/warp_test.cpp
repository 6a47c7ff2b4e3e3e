#include "engine/sampling/warp.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <vector>

#include "engine/sampling/rng.h"
#include "tests/test_scale.h"

namespace tessera {
namespace {

// Pearson's chi-square over a (cos θ, φ) grid; `mass(c0, c1)` is the probability that cos θ
// falls in [c0, c1] (φ is uniform for both samplers). The bound dof + 5·√(2·dof) puts the
// false-alarm rate near 1e-6, and the seed is fixed, so the test is also reproducible.
double chi_square(const std::function<glm::vec3(float, float)>& sample, const std::function<double(double, double)>& mass,
                  int n, int& dof) {
    const int nc = 10, np = 20;
    std::vector<double> counts(nc * np, 0.0);
    Pcg32 rng(5, 9);
    for (int i = 0; i < n; ++i) {
        const glm::vec3 w = sample(rng.next_float(), rng.next_float());
        EXPECT_NEAR(glm::length(w), 1.f, 1e-5f);
        EXPECT_GE(w.z, 0.f);
        double phi = std::atan2(double(w.y), double(w.x));
        if (phi < 0) phi += 2 * M_PI;
        const int ic = std::min(nc - 1, int(double(w.z) * nc));
        const int ip = std::min(np - 1, int(phi / (2 * M_PI) * np));
        counts[size_t(ic * np + ip)] += 1;
    }
    double chi = 0;
    for (int ic = 0; ic < nc; ++ic) {
        const double expected = n * mass(double(ic) / nc, double(ic + 1) / nc) / np;
        for (int ip = 0; ip < np; ++ip) {
            const double d = counts[size_t(ic * np + ip)] - expected;
            chi += d * d / expected;
        }
    }
    dof = nc * np - 1;
    return chi;
}

TEST(Warp, CosineHemisphereChiSquare) {
    int dof;
    const double chi = chi_square(sample_cosine_hemisphere, [](double a, double b) { return b * b - a * a; },
                                  1000000 / test::kWorkScale, dof);
    EXPECT_LT(chi, dof + 5 * std::sqrt(2.0 * dof));
}

TEST(Warp, UniformHemisphereChiSquare) {
    int dof;
    const double chi = chi_square(sample_uniform_hemisphere, [](double a, double b) { return b - a; },
                                  1000000 / test::kWorkScale, dof);
    EXPECT_LT(chi, dof + 5 * std::sqrt(2.0 * dof));
}

// The chi-square test must be able to fail: a uniform sampler judged against the cosine pdf.
TEST(Warp, ChiSquareRejectsTheWrongDensity) {
    int dof;
    const double chi = chi_square(sample_uniform_hemisphere, [](double a, double b) { return b * b - a * a; }, 100000, dof);
    EXPECT_GT(chi, dof + 5 * std::sqrt(2.0 * dof));
}

// Each pdf integrates to one over the hemisphere (midpoint rule in cos θ; φ is uniform).
TEST(Warp, PdfsIntegrateToOne) {
    double cos_int = 0, uni_int = 0;
    const int n = 100000;
    for (int i = 0; i < n; ++i) {
        const float c = (float(i) + 0.5f) / float(n);
        cos_int += 2 * M_PI * cosine_hemisphere_pdf(c) / n;
        uni_int += 2 * M_PI * uniform_hemisphere_pdf() / n;
    }
    EXPECT_NEAR(cos_int, 1.0, 1e-6);
    EXPECT_NEAR(uni_int, 1.0, 1e-6);
}

TEST(Warp, TriangleSamplesAreUniformBarycentrics) {
    // Mean of uniform barycentrics is (1/3, 1/3) and E[b0²] = 1/6.
    Pcg32 rng(1, 2);
    const int n = 400000;
    double m0 = 0, m1 = 0, s0 = 0;
    for (int i = 0; i < n; ++i) {
        const glm::vec2 b = sample_triangle(rng.next_float(), rng.next_float());
        ASSERT_GE(b.x, 0.f);
        ASSERT_GE(b.y, 0.f);
        ASSERT_LE(b.x + b.y, 1.f);
        m0 += b.x; m1 += b.y; s0 += double(b.x) * b.x;
    }
    // Standard errors: σ(b0) = √(1/18) → se ≈ 0.00037 at n = 4e5; 5 se bounds.
    EXPECT_NEAR(m0 / n, 1.0 / 3, 0.002);
    EXPECT_NEAR(m1 / n, 1.0 / 3, 0.002);
    EXPECT_NEAR(s0 / n, 1.0 / 6, 0.002);
}

TEST(Warp, FrameIsOrthonormal) {
    Pcg32 rng(4, 4);
    for (int i = 0; i < 10000; ++i) {
        const glm::vec3 n = glm::normalize(glm::vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f));
        const Frame f(n);
        ASSERT_NEAR(glm::dot(f.s, f.t), 0.f, 1e-5f);
        ASSERT_NEAR(glm::dot(f.s, f.n), 0.f, 1e-5f);
        ASSERT_NEAR(glm::length(f.s), 1.f, 1e-5f);
        const glm::vec3 v(0.3f, -0.2f, 0.9f);
        const glm::vec3 back = f.to_local(f.to_world(v));
        ASSERT_NEAR(glm::length(back - v), 0.f, 1e-5f);
    }
}

}  // namespace
}  // namespace tessera
