#include "engine/material/ggx_albedo.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <thread>
#include <vector>

#include "engine/material/microfacet.h"

namespace tessera {
namespace {

// 128² strata: at 32² the midpoint rule over the visible-normal map (piecewise smooth) was 0.5%
// high at low roughness (α ≈ 0.08, μ ≈ 0.65: 0.983 against 0.978 by Monte Carlo).
constexpr int kMu = 32, kRough = 32, kStrata = 128;

struct Tables {
    std::array<GgxAlbedo, kMu * kRough> e;
    std::array<GgxAlbedo, kRough> avg;
};

float mu_at(int i) { return std::max(1e-3f, float(i) / float(kMu - 1)); }
float alpha_at(int j) {
    const float r = float(j) / float(kRough - 1);
    return std::max(r * r, kMinAlpha);
}

void integrate_row(Tables& t, int j);

Tables integrate() {
    Tables t;
    // Rows of roughness on threads of their own (16M samples in all; each row's numbers are
    // the same whichever thread adds them).
    std::vector<std::thread> threads;
    const int n = std::clamp(int(std::thread::hardware_concurrency()), 1, kRough);
    for (int k = 0; k < n; ++k)
        threads.emplace_back([&t, k, n] {
            for (int j = k; j < kRough; j += n) integrate_row(t, j);
        });
    for (std::thread& th : threads) th.join();
    return t;
}

void integrate_row(Tables& t, int j) {
    const float alpha = alpha_at(j);
    for (int i = 0; i < kMu; ++i) {
        const float mu = mu_at(i);
        const glm::vec3 wo(std::sqrt(std::max(0.f, 1.f - mu * mu)), 0.f, mu);
        const float g1o = ggx_g1(wo, alpha);
        double a = 0, b = 0;
        // Visible normals: f·cos/pdf = F·G2/G1(wo).
        for (int u = 0; u < kStrata; ++u)
            for (int v = 0; v < kStrata; ++v) {
                const glm::vec2 uv((float(u) + 0.5f) / kStrata, (float(v) + 0.5f) / kStrata);
                const glm::vec3 h = ggx_sample_visible_h(wo, uv, alpha);
                const float oh = glm::dot(wo, h);
                if (oh <= 0.f) continue;
                const glm::vec3 wi = 2.f * oh * h - wo;
                if (wi.z <= 0.f) continue;
                const float g2 = 1.f / (1.f + ggx_lambda(wo, alpha) + ggx_lambda(wi, alpha));
                const float w = g2 / g1o;
                const float m = 1.f - oh, m5 = (m * m) * (m * m) * m;
                a += (1.f - m5) * w;
                b += m5 * w;
            }
        t.e[j * kMu + i] = {float(a / (kStrata * kStrata)), float(b / (kStrata * kStrata))};
    }
    // 2∫E μ dμ by the trapezoid rule over the μ grid.
    double a = 0, b = 0;
    for (int i = 0; i + 1 < kMu; ++i) {
        const double m0 = double(i) / (kMu - 1), m1 = double(i + 1) / (kMu - 1);
        const GgxAlbedo &e0 = t.e[j * kMu + i], &e1 = t.e[j * kMu + i + 1];
        a += (e0.a * m0 + e1.a * m1) * (m1 - m0);
        b += (e0.b * m0 + e1.b * m1) * (m1 - m0);
    }
    t.avg[j] = {float(a), float(b)};
}

const Tables& tables() {
    static const Tables t = integrate();
    return t;
}

// The table's coordinate along √α, as (index, weight of index + 1).
std::pair<int, float> rough_coord(float alpha) {
    // Written so that NaN reads the first entry (std::clamp and std::max pass NaN on, and int(NaN)
    // indexes anywhere): a lookup never leaves its table, whatever direction it is asked about.
    const float x = std::min(std::sqrt(alpha > 0.f ? alpha : 0.f), 1.f) * float(kRough - 1);
    const int j = std::min(int(x), kRough - 2);
    return {j, x - float(j)};
}

GgxAlbedo lerp(const GgxAlbedo& p, const GgxAlbedo& q, float w) { return {p.a + (q.a - p.a) * w, p.b + (q.b - p.b) * w}; }

}  // namespace

GgxAlbedo ggx_albedo(float mu, float alpha) {
    const Tables& t = tables();
    const auto [j, wj] = rough_coord(alpha);
    const float x = (mu > 0.f ? std::min(mu, 1.f) : 0.f) * float(kMu - 1);  // NaN: 0, as in rough_coord
    const int i = std::min(int(x), kMu - 2);
    const float wi = x - float(i);
    const GgxAlbedo lo = lerp(t.e[j * kMu + i], t.e[j * kMu + i + 1], wi);
    const GgxAlbedo hi = lerp(t.e[(j + 1) * kMu + i], t.e[(j + 1) * kMu + i + 1], wi);
    return lerp(lo, hi, wj);
}

GgxAlbedo ggx_albedo_average(float alpha) {
    const auto [j, wj] = rough_coord(alpha);
    return lerp(tables().avg[j], tables().avg[j + 1], wj);
}

}  // namespace tessera
