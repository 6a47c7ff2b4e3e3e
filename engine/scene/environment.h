#pragma once
// An environment light: a latitude-longitude map of radiance at infinity (CS184's `-e`), seen
// where rays leave the scene and importance-sampled by a 2-D piecewise-constant distribution
// over its texels, weighted by luminance × sin θ (pbrt-v4's PiecewiseConstant2D).
//
// Directions follow CS184: θ = acos(y) from +y (row 0 is the zenith), φ = atan2(x, −z) + π,
// u = φ / 2π, v = θ / π. Radiance is constant over a texel, so the density that sampling gives
// is exactly proportional to what it returns: MIS weights and the estimator agree.
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace tessera {

// A 2-D piecewise-constant distribution over the texels: weight max(0, luminance − floor) ×
// sin θ at the row's centre.
struct EnvironmentDistribution {
    std::vector<float> marginal_cdf;     // height + 1 entries: the rows
    std::vector<float> conditional_cdf;  // height × (width + 1): the texels within each row
    float total_weight = 0.f;
    float floor = 0.f;  // luminance taken off every texel
};

struct EnvironmentMap {
    std::string source;
    int width = 0, height = 0;
    std::vector<glm::vec3> texels;       // row-major, row 0 at the zenith
    EnvironmentDistribution full;        // by luminance: for light samples alone
    // By luminance above the map's mean (Karlík et al. 2019, "MIS Compensation", as pbrt-v4's
    // ImageInfiniteLight): for light samples that MIS combines with BSDF samples, which find
    // the dim sky better than the light samples did. A sun beside a sky kept 86% of the full
    // distribution's weight in 7 texels and still sent the rest to the sky, rarely and with
    // huge weights. The full distribution again where no texel is above the mean (a flat map).
    EnvironmentDistribution compensated;
    bool empty() const { return width == 0; }
};

// Which distribution a light sample of the environment draws from: `compensated` only where
// every such sample is MIS-weighted against a BSDF sample that can find any direction.
enum class EnvironmentSampling { full, compensated };

// `rgb`: width × height × 3 linear floats, row 0 at the top. Throws std::invalid_argument for
// an empty map, a negative or non-finite texel, or one so large its weights overflow.
EnvironmentMap build_environment(int width, int height, const std::vector<float>& rgb, std::string source);

glm::vec3 environment_radiance(const EnvironmentMap& env, const glm::vec3& dir);
// Density per solid angle of sample_environment choosing direction `dir` (unit).
float environment_pdf(const EnvironmentMap& env, const glm::vec3& dir, EnvironmentSampling how = EnvironmentSampling::full);
// A direction toward the map from uv in [0,1)²; false where the distribution is zero.
bool sample_environment(const EnvironmentMap& env, glm::vec2 uv, glm::vec3& wi, float& pdf, glm::vec3& radiance,
                        EnvironmentSampling how = EnvironmentSampling::full);

// The unit direction of map coordinates (u, v), and back.
glm::vec3 environment_direction(float u, float v);
glm::vec2 environment_uv(const glm::vec3& dir);

}  // namespace tessera
