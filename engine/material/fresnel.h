#pragma once
// Fresnel reflectance at a smooth interface: exact for dielectrics and conductors (pbrt-v4,
// section 9.3), Schlick's approximation where glTF's material model prescribes it.
#include <algorithm>
#include <cmath>

#include <glm/glm.hpp>

namespace tessera {

// Unpolarised reflectance of a dielectric interface for light arriving at cos_i (> 0, from the
// side whose index is 1) onto a side of relative index eta = η_other / η_this. 1 past the
// critical angle (total internal reflection).
inline float fresnel_dielectric(float cos_i, float eta) {
    cos_i = std::clamp(cos_i, 0.f, 1.f);
    const float sin2_t = (1.f - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.f) return 1.f;
    const float cos_t = std::sqrt(std::max(0.f, 1.f - sin2_t));
    const float r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    const float r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    return 0.5f * (r_parl * r_parl + r_perp * r_perp);
}

// Reflectance of a conductor with complex index eta + i·k (relative to the outside medium) at
// cos_i, one channel: the exact formula for unpolarised light (pbrt-v4's FrComplex written out
// in real arithmetic, as in Lazányi & Szirmay-Kalos 2005).
inline float fresnel_conductor(float cos_i, float eta, float k) {
    cos_i = std::clamp(cos_i, 0.f, 1.f);
    const float c2 = cos_i * cos_i, s2 = 1.f - c2;
    const float e2 = eta * eta, k2 = k * k;
    const float t0 = e2 - k2 - s2;
    const float a2b2 = std::sqrt(std::max(0.f, t0 * t0 + 4.f * e2 * k2));
    const float a = std::sqrt(std::max(0.f, 0.5f * (a2b2 + t0)));
    const float t1 = a2b2 + c2, t2 = 2.f * cos_i * a;
    const float rs = (t1 - t2) / std::max(t1 + t2, 1e-20f);
    const float t3 = c2 * a2b2 + s2 * s2, t4 = t2 * s2;
    const float rp = rs * (t3 - t4) / std::max(t3 + t4, 1e-20f);
    return std::clamp(0.5f * (rp + rs), 0.f, 1.f);
}

inline glm::vec3 fresnel_conductor(float cos_i, const glm::vec3& eta, const glm::vec3& k) {
    return {fresnel_conductor(cos_i, eta.x, k.x), fresnel_conductor(cos_i, eta.y, k.y), fresnel_conductor(cos_i, eta.z, k.z)};
}

inline glm::vec3 fresnel_schlick(const glm::vec3& f0, float cos_i) {
    const float m = std::clamp(1.f - cos_i, 0.f, 1.f);
    const float m5 = (m * m) * (m * m) * m;
    return f0 + (glm::vec3(1.f) - f0) * m5;
}

// Mirror reflection and refraction in a local frame whose z is the normal on wo's side.
inline glm::vec3 reflect_local(const glm::vec3& wo) { return {-wo.x, -wo.y, wo.z}; }

// Refraction of wo (z > 0) through a surface with normal n (on wo's side, unit) into a medium of
// relative index eta = η_other / η_this; false past the critical angle.
inline bool refract(const glm::vec3& wo, const glm::vec3& n, float eta, glm::vec3& wt) {
    const float cos_i = glm::dot(n, wo);
    const float sin2_t = std::max(0.f, 1.f - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.f) return false;
    const float cos_t = std::sqrt(1.f - sin2_t);
    wt = -wo / eta + (cos_i / eta - cos_t) * n;
    return true;
}

}  // namespace tessera
