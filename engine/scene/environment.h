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

struct EnvironmentMap {
    std::string source;
    int width = 0, height = 0;
    std::vector<glm::vec3> texels;       // row-major, row 0 at the zenith
    std::vector<float> marginal_cdf;     // height + 1 entries: the rows
    std::vector<float> conditional_cdf;  // height × (width + 1): the texels within each row
    std::vector<float> row_weight;       // each row's total weight
    float total_weight = 0.f;
    bool empty() const { return width == 0; }
};

// `rgb`: width × height × 3 linear floats, row 0 at the top. Throws std::invalid_argument for
// an empty map, a negative or non-finite texel, or one so large its weights overflow.
EnvironmentMap build_environment(int width, int height, const std::vector<float>& rgb, std::string source);

glm::vec3 environment_radiance(const EnvironmentMap& env, const glm::vec3& dir);
// Density per solid angle of sample_environment choosing direction `dir` (unit).
float environment_pdf(const EnvironmentMap& env, const glm::vec3& dir);
// A direction toward the map from uv in [0,1)²; false where the map is black.
bool sample_environment(const EnvironmentMap& env, glm::vec2 uv, glm::vec3& wi, float& pdf, glm::vec3& radiance);

// The unit direction of map coordinates (u, v), and back.
glm::vec3 environment_direction(float u, float v);
glm::vec2 environment_uv(const glm::vec3& dir);

}  // namespace tessera
