#pragma once
// Microfacet distributions in a local frame (z = macro-surface normal): Beckmann (the CS184
// conductor) and GGX / Trowbridge-Reitz (glTF's metallic-roughness), each with Smith's masking
// (height-correlated for the pair of directions) and a sampling routine with its density of
// half vectors. Heitz 2014, "Understanding the Masking-Shadowing Function"; pbrt-v4 9.6.
#include <algorithm>
#include <cmath>

#include <glm/glm.hpp>

#include "engine/sampling/warp.h"

namespace tessera {

// Below this α a lobe is numerically a mirror: D's peak 1/(πα²) would overflow the pdfs'
// dynamic range and a light sample could never land in it. Roughness is clamped here.
inline constexpr float kMinAlpha = 1e-3f;

// From x and y rather than 1 − z²: near the normal z² rounds to 1 within 6e-8, which is the
// whole of sin²θ in a lobe of α ≈ 1e-3 (D was 12% off there, and a furnace gained 1.7%).
inline float sin2_theta(const glm::vec3& w) { return w.x * w.x + w.y * w.y; }
inline float tan2_theta(const glm::vec3& w) { return sin2_theta(w) / (w.z * w.z); }

// ---- Beckmann ---------------------------------------------------------------------------------

inline float beckmann_d(const glm::vec3& h, float alpha) {
    if (h.z <= 0.f) return 0.f;
    const float t2 = tan2_theta(h);
    if (!std::isfinite(t2)) return 0.f;
    const float c4 = (h.z * h.z) * (h.z * h.z);
    return std::exp(-t2 / (alpha * alpha)) / (kPi * alpha * alpha * c4);
}

// Smith's Λ for Beckmann: Walter et al. 2007's rational fit of the error-function form
// (relative error below 0.35%).
inline float beckmann_lambda(const glm::vec3& w, float alpha) {
    const float t2 = tan2_theta(w);
    if (!(t2 > 0.f)) return 0.f;
    if (!std::isfinite(t2)) return INFINITY;
    const float a = 1.f / (alpha * std::sqrt(t2));
    if (a >= 1.6f) return 0.f;
    return (1.f - 1.259f * a + 0.396f * a * a) / (3.535f * a + 2.181f * a * a);
}

// A half vector with density D(h)·cos θh (which integrates to one over the hemisphere).
inline glm::vec3 beckmann_sample_h(glm::vec2 u, float alpha) {
    const float t2 = -alpha * alpha * std::log1p(-std::min(u.x, 0x1.fffffep-1f));
    const float cos_t = 1.f / std::sqrt(1.f + t2);
    const float sin_t = std::sqrt(std::max(0.f, 1.f - cos_t * cos_t));
    const float phi = 2.f * kPi * u.y;
    return {sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t};
}
inline float beckmann_pdf_h(const glm::vec3& h, float alpha) { return beckmann_d(h, alpha) * std::max(0.f, h.z); }

// ---- GGX ------------------------------------------------------------------------------------

inline float ggx_d(const glm::vec3& h, float alpha) {
    if (h.z <= 0.f) return 0.f;
    const float a2 = alpha * alpha;
    const float d = sin2_theta(h) + a2 * (h.z * h.z);  // cos²θ (α² − 1) + 1 for a unit h, without its cancellation
    return a2 / (kPi * d * d);
}

inline float ggx_lambda(const glm::vec3& w, float alpha) {
    const float t2 = tan2_theta(w);
    if (!std::isfinite(t2)) return INFINITY;
    return 0.5f * (std::sqrt(1.f + alpha * alpha * t2) - 1.f);
}

inline float ggx_g1(const glm::vec3& w, float alpha) { return 1.f / (1.f + ggx_lambda(w, alpha)); }

// A visible normal for wo (z > 0): density G1(wo)·max(0, wo·h)·D(h) / cos θo (Heitz 2018,
// "Sampling the GGX Distribution of Visible Normals"). Far fewer wasted samples than D·cos at
// grazing angles.
inline glm::vec3 ggx_sample_visible_h(const glm::vec3& wo, glm::vec2 u, float alpha) {
    const glm::vec3 vh = glm::normalize(glm::vec3(alpha * wo.x, alpha * wo.y, wo.z));
    const float len2 = vh.x * vh.x + vh.y * vh.y;
    const glm::vec3 t1 = len2 > 0.f ? glm::vec3(-vh.y, vh.x, 0.f) / std::sqrt(len2) : glm::vec3(1.f, 0.f, 0.f);
    const glm::vec3 t2 = glm::cross(vh, t1);
    const float r = std::sqrt(u.x);
    const float phi = 2.f * kPi * u.y;
    const float p1 = r * std::cos(phi);
    float p2 = r * std::sin(phi);
    const float s = 0.5f * (1.f + vh.z);
    p2 = (1.f - s) * std::sqrt(std::max(0.f, 1.f - p1 * p1)) + s * p2;
    const glm::vec3 nh = p1 * t1 + p2 * t2 + std::sqrt(std::max(0.f, 1.f - p1 * p1 - p2 * p2)) * vh;
    return glm::normalize(glm::vec3(alpha * nh.x, alpha * nh.y, std::max(1e-6f, nh.z)));
}
inline float ggx_visible_pdf_h(const glm::vec3& wo, const glm::vec3& h, float alpha) {
    if (wo.z <= 0.f) return 0.f;
    return ggx_g1(wo, alpha) * std::max(0.f, glm::dot(wo, h)) * ggx_d(h, alpha) / wo.z;
}

}  // namespace tessera
