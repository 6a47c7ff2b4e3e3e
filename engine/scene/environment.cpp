#include "engine/scene/environment.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "engine/sampling/warp.h"

namespace tessera {
namespace {

float luminance_of(const glm::vec3& c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

// The bin of a CDF of n + 1 entries (first 0, last 1) that holds u, and u's place within it.
int find_bin(const float* cdf, int n, float u, float& within) {
    const int i = int(std::upper_bound(cdf, cdf + n + 1, u) - cdf) - 1;
    const int bin = std::clamp(i, 0, n - 1);
    const float width = cdf[bin + 1] - cdf[bin];
    within = width > 0.f ? std::clamp((u - cdf[bin]) / width, 0.f, 0x1.fffffep-1f) : 0.f;
    return bin;
}

// The distribution of weights max(0, luminance − floor) × sin θ over env's texels.
void build_distribution(const EnvironmentMap& env, float floor, EnvironmentDistribution& d) {
    const int width = env.width, height = env.height;
    d.floor = floor;
    d.conditional_cdf.assign(size_t(height) * (width + 1), 0.f);
    d.marginal_cdf.assign(height + 1, 0.f);
    double total = 0;
    for (int y = 0; y < height; ++y) {
        // sin θ at the row's centre: the solid angle a texel of the row covers.
        const double st = std::sin(kPi * (y + 0.5) / height);
        float* cdf = &d.conditional_cdf[size_t(y) * (width + 1)];
        double row = 0;
        for (int x = 0; x < width; ++x) {
            row += std::max(0.0, double(luminance_of(env.texels[size_t(y) * width + x])) - floor) * st;
            cdf[x + 1] = float(row);
        }
        for (int x = 1; x <= width; ++x) cdf[x] = row > 0 ? float(cdf[x] / row) : float(x) / float(width);
        cdf[width] = 1.f;
        total += row;
        d.marginal_cdf[y + 1] = float(total);
    }
    if (!std::isfinite(float(total)) || total * double(width) * height > 1e37)
        throw std::invalid_argument("environment map '" + env.source + "' is too bright to sample");
    for (int y = 1; y <= height; ++y) d.marginal_cdf[y] = total > 0 ? float(d.marginal_cdf[y] / total) : float(y) / float(height);
    d.marginal_cdf[height] = 1.f;
    d.total_weight = float(total);
}

// A texel's density per solid angle at polar sin st: its probability spread over its (u, v)
// area, then over solid angle (dω = 2π² sin θ du dv). The weights used sin θ at the row's centre.
float texel_pdf(const EnvironmentMap& env, const EnvironmentDistribution& d, int x, int y, float st) {
    const double stc = std::sin(kPi * (y + 0.5) / env.height);
    const double w = std::max(0.0, double(luminance_of(env.texels[size_t(y) * env.width + x])) - d.floor) * stc;
    return float(w / d.total_weight * env.width * env.height / (2.0 * kPi * kPi * st));
}

const EnvironmentDistribution& distribution(const EnvironmentMap& env, EnvironmentSampling how) {
    return how == EnvironmentSampling::compensated ? env.compensated : env.full;
}

}  // namespace

glm::vec3 environment_direction(float u, float v) {
    const float phi = 2.f * kPi * u, theta = kPi * v;
    const float st = std::sin(theta);
    return {-st * std::sin(phi), std::cos(theta), st * std::cos(phi)};
}

glm::vec2 environment_uv(const glm::vec3& d) {
    // atan2 rather than acos(y): near the poles y keeps too few digits of θ.
    const float theta = std::atan2(std::sqrt(d.x * d.x + d.z * d.z), d.y);
    float phi = std::atan2(d.x, -d.z) + kPi;
    return {std::clamp(phi / (2.f * kPi), 0.f, 0x1.fffffep-1f), std::clamp(theta / kPi, 0.f, 0x1.fffffep-1f)};
}

EnvironmentMap build_environment(int width, int height, const std::vector<float>& rgb, std::string source) {
    if (width <= 0 || height <= 0 || rgb.size() != size_t(width) * size_t(height) * 3)
        throw std::invalid_argument("environment map '" + source + "' is empty or its size does not match its pixels");
    EnvironmentMap env;
    env.source = std::move(source);
    env.width = width;
    env.height = height;
    env.texels.resize(size_t(width) * height);
    for (size_t i = 0; i < env.texels.size(); ++i) {
        const glm::vec3 c(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);
        if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.z) || c.x < 0.f || c.y < 0.f || c.z < 0.f)
            throw std::invalid_argument("environment map '" + env.source + "' has a negative or non-finite pixel at (" +
                                        std::to_string(i % size_t(width)) + ", " + std::to_string(i / size_t(width)) + ")");
        env.texels[i] = c;
    }
    build_distribution(env, 0.f, env.full);
    // The mean luminance over solid angle, by the same row weights.
    double lum = 0, area = 0;
    for (int y = 0; y < height; ++y) {
        const double st = std::sin(kPi * (y + 0.5) / height);
        for (int x = 0; x < width; ++x) lum += double(luminance_of(env.texels[size_t(y) * width + x])) * st;
        area += st * width;
    }
    build_distribution(env, float(lum / area), env.compensated);
    if (!(env.compensated.total_weight > 0.f)) env.compensated = env.full;
    return env;
}

glm::vec3 environment_radiance(const EnvironmentMap& env, const glm::vec3& dir) {
    const glm::vec2 uv = environment_uv(dir);
    const int x = std::min(env.width - 1, int(uv.x * float(env.width)));
    const int y = std::min(env.height - 1, int(uv.y * float(env.height)));
    return env.texels[size_t(y) * env.width + x];
}

float environment_pdf(const EnvironmentMap& env, const glm::vec3& dir, EnvironmentSampling how) {
    const EnvironmentDistribution& d = distribution(env, how);
    if (!(d.total_weight > 0.f)) return 0.f;
    const glm::vec2 uv = environment_uv(dir);
    const int x = std::min(env.width - 1, int(uv.x * float(env.width)));
    const int y = std::min(env.height - 1, int(uv.y * float(env.height)));
    const float st = std::sin(kPi * uv.y);  // as sampling computes it (not √(1 − y²): it loses digits at the poles)
    if (!(st > 0.f)) return 0.f;
    return texel_pdf(env, d, x, y, st);
}

bool sample_environment(const EnvironmentMap& env, glm::vec2 uv, glm::vec3& wi, float& pdf, glm::vec3& radiance,
                        EnvironmentSampling how) {
    const EnvironmentDistribution& d = distribution(env, how);
    if (!(d.total_weight > 0.f)) return false;
    float fy, fx;
    const int y = find_bin(d.marginal_cdf.data(), env.height, uv.y, fy);
    const int x = find_bin(&d.conditional_cdf[size_t(y) * (env.width + 1)], env.width, uv.x, fx);
    // Kept off the texel's edges by a hair, so that the direction maps back to this texel
    // (its radiance and density) whatever the rounding; the radiance is constant over it.
    fx = std::clamp(fx, 1e-3f, 1.f - 1e-3f);
    fy = std::clamp(fy, 1e-3f, 1.f - 1e-3f);
    const float u = (float(x) + fx) / float(env.width), v = (float(y) + fy) / float(env.height);
    wi = environment_direction(u, v);
    radiance = env.texels[size_t(y) * env.width + x];
    const float st = std::sin(kPi * v);
    if (!(st > 0.f)) return false;
    pdf = texel_pdf(env, d, x, y, st);
    return pdf > 0.f;
}

}  // namespace tessera
