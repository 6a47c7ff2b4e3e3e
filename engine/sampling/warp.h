#pragma once
// Warps from the unit square to directions and points, each with its density. Directions are
// in a local frame with z along the normal.
#include <algorithm>
#include <cmath>
#include <numbers>

#include <glm/glm.hpp>

namespace tessera {

inline constexpr float kPi = std::numbers::pi_v<float>;
inline constexpr float kInvPi = 1.f / kPi;

// Malley's method: a concentric disk sample lifted to the hemisphere (Shirley & Chiu 1997).
inline glm::vec2 sample_concentric_disk(float u1, float u2) {
    const float a = 2.f * u1 - 1.f, b = 2.f * u2 - 1.f;
    if (a == 0.f && b == 0.f) return {0.f, 0.f};
    float r, phi;
    if (std::abs(a) > std::abs(b)) { r = a; phi = (kPi / 4.f) * (b / a); }
    else { r = b; phi = kPi / 2.f - (kPi / 4.f) * (a / b); }
    return {r * std::cos(phi), r * std::sin(phi)};
}

inline glm::vec3 sample_cosine_hemisphere(float u1, float u2) {
    const glm::vec2 d = sample_concentric_disk(u1, u2);
    const float z = std::sqrt(std::max(0.f, 1.f - d.x * d.x - d.y * d.y));
    return {d.x, d.y, z};
}
inline float cosine_hemisphere_pdf(float cos_theta) { return cos_theta > 0.f ? cos_theta * kInvPi : 0.f; }

inline glm::vec3 sample_uniform_hemisphere(float u1, float u2) {
    const float z = u1;
    const float r = std::sqrt(std::max(0.f, 1.f - z * z));
    const float phi = 2.f * kPi * u2;
    return {r * std::cos(phi), r * std::sin(phi), z};
}
inline constexpr float uniform_hemisphere_pdf() { return 1.f / (2.f * kPi); }

// Uniform point on a triangle as barycentrics (b0, b1); low-distortion mapping of Heitz 2019.
inline glm::vec2 sample_triangle(float u1, float u2) {
    float b0, b1;
    if (u1 < u2) { b0 = u1 / 2.f; b1 = u2 - b0; }
    else { b1 = u2 / 2.f; b0 = u1 - b1; }
    return {b0, b1};
}

// An orthonormal frame around a unit normal (Duff et al. 2017, branchless ONB).
struct Frame {
    glm::vec3 s, t, n;
    explicit Frame(const glm::vec3& nn) : n(nn) {
        const float sign = std::copysign(1.f, n.z);
        const float a = -1.f / (sign + n.z);
        const float b = n.x * n.y * a;
        s = {1.f + sign * n.x * n.x * a, sign * b, -sign * n.x};
        t = {b, sign + n.y * n.y * a, -n.y};
    }
    glm::vec3 to_world(const glm::vec3& v) const { return v.x * s + v.y * t + v.z * n; }
    glm::vec3 to_local(const glm::vec3& v) const { return {glm::dot(v, s), glm::dot(v, t), glm::dot(v, n)}; }
};

}  // namespace tessera
