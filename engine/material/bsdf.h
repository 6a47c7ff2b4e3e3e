#pragma once
// The closed set of BSDFs, as plain data and free functions switched on a tag: no virtual call
// per sample. Every function works in a local frame whose z is the shading normal turned to
// wo's side (wo.z > 0 for a well-formed query); glass reads its relative index from `ior`, which
// the integrator inverts when wo is inside the object.
//
// bsdf_f and bsdf_pdf describe the non-delta part (zero for mirror, glass and
// lobes smoother than kSmoothAlpha); bsdf_sample draws
// from the whole BSDF and returns f·|cos θi|/pdf, so delta lobes need no density. BsdfAt is
// the one piece of state: a vertex's BSDF with what depends on wo alone built once.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>

#include <glm/glm.hpp>

#include "engine/material/fresnel.h"
#include "engine/material/ggx_albedo.h"
#include "engine/material/microfacet.h"
#include "engine/sampling/warp.h"

namespace tessera {

enum class BsdfKind : uint8_t {
    lambertian,          // albedo / π
    mirror,              // perfect specular reflection × albedo
    glass,               // smooth Fresnel dielectric: reflection × albedo, refraction × transmittance
    conductor,           // CS184 microfacet: Beckmann, exact conductor Fresnel with eta + i·k per channel
    phong,               // CS184 "glossy": normalised Phong lobe (exponent) around the mirror direction
    metallic_roughness,  // glTF 2.0 Appendix B: GGX specular, Lambertian base, mixed by metallic
};

struct Bsdf {
    BsdfKind kind = BsdfKind::lambertian;
    glm::vec3 albedo{0.5f};         // reflectance; glTF: base colour
    glm::vec3 transmittance{1.f};   // glass
    float ior = 1.5f;               // glass: η_far / η_near; glTF: the dielectric's index (KHR_materials_ior)
    float alpha = 0.5f;             // conductor (Beckmann α), metallic_roughness (GGX α = roughness²)
    glm::vec3 eta{1.f}, k{0.f};     // conductor
    float metallic = 0.f;           // metallic_roughness
    float specular = 1.f;           // metallic_roughness: KHR_materials_specular's factor
    float exponent = 1.f;           // phong
};

struct BsdfSample {
    glm::vec3 wi;       // local
    glm::vec3 weight;   // f·|cos θi| / pdf
    float pdf = 0.f;    // per solid angle; for a delta lobe, the probability of choosing it
    bool delta = false;
};

inline float luminance(const glm::vec3& c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

// Below this α a microfacet lobe is a perfect mirror (pbrt-v4's EffectivelySmooth): no light
// sample can land in it and its density would overflow, so it is a delta lobe, sampled only from
// the BSDF. Normalised Phong of the same width: α² ≈ 2 / (n + 2).
inline constexpr float kSmoothAlpha = kMinAlpha;
inline constexpr float kSmoothPhongExponent = 2.f / (kSmoothAlpha * kSmoothAlpha) - 2.f;

// Whether the BSDF has a delta lobe (a sampled direction may come back with `delta`).
inline bool bsdf_has_delta(const Bsdf& b) {
    switch (b.kind) {
        case BsdfKind::mirror:
        case BsdfKind::glass: return true;
        case BsdfKind::conductor:
        case BsdfKind::metallic_roughness: return b.alpha < kSmoothAlpha;
        case BsdfKind::phong: return b.exponent >= kSmoothPhongExponent;
        case BsdfKind::lambertian: return false;
    }
    return false;
}

// Whether the BSDF is nothing but delta lobes: direct lighting has nothing to find there.
inline bool bsdf_is_delta(const Bsdf& b) {
    if (!bsdf_has_delta(b)) return false;
    if (b.kind == BsdfKind::metallic_roughness) return b.metallic >= 1.f || b.albedo == glm::vec3(0.f);
    return true;
}

// Whether the BSDF has a glossy (non-delta, non-Lambertian) lobe, which direct lighting always
// estimates by MIS of light and lobe samples.
inline bool bsdf_has_glossy(const Bsdf& b) {
    switch (b.kind) {
        case BsdfKind::conductor:
        case BsdfKind::phong:
        case BsdfKind::metallic_roughness: return !bsdf_has_delta(b);
        default: return false;
    }
}

inline bool bsdf_is_black(const Bsdf& b) {
    const glm::vec3 zero(0.f);
    switch (b.kind) {
        case BsdfKind::glass: return b.albedo == zero && b.transmittance == zero;
        case BsdfKind::conductor: return false;
        case BsdfKind::metallic_roughness: return b.albedo == zero && b.metallic >= 1.f;
        default: return b.albedo == zero;
    }
}

// Whether bsdf_sample reads its 1-D number `uc` (a choice between lobes): the integrator draws
// it only then, so a Lambertian path takes the same sample dimensions as it always did.
inline bool bsdf_chooses_lobe(const Bsdf& b) { return b.kind == BsdfKind::glass || b.kind == BsdfKind::metallic_roughness; }

namespace bsdf_detail {

// glTF metallic-roughness: Schlick's F for the mixed specular lobe (f0 and f90 mixed by
// metallic; the dielectric's from its index and KHR_materials_specular's factor) over a
// Lambertian base. The base takes what the dielectric's specular lobe leaves, by that lobe's
// directional albedo E at both ends, (1 − E(μo))(1 − E(μi)) / (1 − E_avg), rather than by glTF's
// sample 1 − F(v·h): reciprocal, and white dielectrics then reflect at most what arrives
// (glTF's sample formula reflects up to 1.57 at grazing incidence; docs/materials.md).
struct MetallicRoughness {
    glm::vec3 f0, f90;
    float d_f0, d_f90;   // the dielectric's
    glm::vec3 c_diff;
    float alpha;
    float e_o;           // E(μo): the dielectric lobe's directional albedo toward wo
    float base_o;        // 1 − E(μo), over 1 − E_avg
    explicit MetallicRoughness(const Bsdf& b, const glm::vec3& wo) {
        const float r = (b.ior - 1.f) / (b.ior + 1.f);
        d_f0 = std::min(1.f, r * r) * b.specular;
        d_f90 = b.specular;
        f0 = glm::mix(glm::vec3(d_f0), b.albedo, b.metallic);
        f90 = glm::mix(glm::vec3(d_f90), glm::vec3(1.f), b.metallic);
        c_diff = b.albedo * (1.f - b.metallic);
        alpha = std::max(b.alpha, kMinAlpha);
        const float avg = ggx_albedo_average(alpha)(d_f0, d_f90);
        e_o = ggx_albedo(wo.z, alpha)(d_f0, d_f90);
        base_o = avg < 1.f ? std::max(0.f, 1.f - e_o) / (1.f - avg) : 0.f;
    }
    glm::vec3 f_spec(float c) const {
        const float m = std::clamp(1.f - c, 0.f, 1.f);
        return f0 + (f90 - f0) * ((m * m) * (m * m) * m);
    }
    // The GGX specular lobe (none when it is smooth: a delta lobe).
    glm::vec3 f_glossy(const Bsdf& b, const glm::vec3& wo, const glm::vec3& wi) const {
        if (b.alpha < kSmoothAlpha) return glm::vec3(0.f);
        glm::vec3 h = wo + wi;
        if (h == glm::vec3(0.f)) return glm::vec3(0.f);
        h = glm::normalize(h);
        const float vh = std::max(0.f, glm::dot(wo, h));
        const float g = 1.f / (1.f + ggx_lambda(wo, alpha) + ggx_lambda(wi, alpha));
        return f_spec(vh) * (ggx_d(h, alpha) * g / (4.f * wo.z * wi.z));
    }
    // The density of sampling the specular lobe alone (visible normals).
    float pdf_glossy(const glm::vec3& wo, const glm::vec3& wi) const {
        glm::vec3 h = wo + wi;
        if (h == glm::vec3(0.f)) return 0.f;
        h = glm::normalize(h);
        const float oh = glm::dot(wo, h);
        return oh > 0.f ? ggx_visible_pdf_h(wo, h, alpha) / (4.f * oh) : 0.f;
    }
    glm::vec3 f_base(const glm::vec3& wi) const {
        return c_diff * (kInvPi * base_o * std::max(0.f, 1.f - ggx_albedo(wi.z, alpha)(d_f0, d_f90)));
    }
    // The probability of sampling the specular lobe, from wo alone: each lobe's albedo guess.
    float p_spec(const glm::vec3& wo) const {
        const float s = luminance(f_spec(wo.z));
        const float d = luminance(c_diff) * std::max(0.f, 1.f - e_o);
        if (d <= 0.f) return 1.f;
        if (s <= 0.f) return 0.f;
        return std::clamp(s / (s + d), 0.1f, 0.9f);
    }
    // The whole BSDF and its sampling density, both directions above the surface.
    glm::vec3 f(const Bsdf& b, const glm::vec3& wo, const glm::vec3& wi) const { return f_glossy(b, wo, wi) + f_base(wi); }
    float pdf(const Bsdf& b, const glm::vec3& wo, const glm::vec3& wi) const {
        const float ps = p_spec(wo);
        const float spec = b.alpha < kSmoothAlpha ? 0.f : pdf_glossy(wo, wi);
        return ps * spec + (1.f - ps) * cosine_hemisphere_pdf(wi.z);
    }
};

}  // namespace bsdf_detail

inline glm::vec3 bsdf_f(const Bsdf& b, const glm::vec3& wo, const glm::vec3& wi) {
    switch (b.kind) {
        case BsdfKind::lambertian: return wi.z > 0.f && wo.z > 0.f ? b.albedo * kInvPi : glm::vec3(0.f);
        case BsdfKind::mirror:
        case BsdfKind::glass: return glm::vec3(0.f);
        case BsdfKind::conductor: {
            if (wo.z <= 0.f || wi.z <= 0.f || bsdf_has_delta(b)) return glm::vec3(0.f);
            glm::vec3 h = wo + wi;
            if (h == glm::vec3(0.f)) return glm::vec3(0.f);
            h = glm::normalize(h);
            const float alpha = std::max(b.alpha, kMinAlpha);
            const float g = 1.f / (1.f + beckmann_lambda(wo, alpha) + beckmann_lambda(wi, alpha));
            const glm::vec3 F = fresnel_conductor(glm::dot(wi, h), b.eta, b.k);
            return F * (beckmann_d(h, alpha) * g / (4.f * wo.z * wi.z));
        }
        case BsdfKind::phong: {
            if (wo.z <= 0.f || wi.z <= 0.f || bsdf_has_delta(b)) return glm::vec3(0.f);
            const float c = glm::dot(reflect_local(wo), wi);
            if (c <= 0.f) return glm::vec3(0.f);
            return b.albedo * ((b.exponent + 2.f) * (0.5f * kInvPi) * std::pow(c, b.exponent));
        }
        case BsdfKind::metallic_roughness: {
            if (wo.z <= 0.f || wi.z <= 0.f) return glm::vec3(0.f);
            return bsdf_detail::MetallicRoughness(b, wo).f(b, wo, wi);
        }
    }
    return glm::vec3(0.f);
}

inline float bsdf_pdf(const Bsdf& b, const glm::vec3& wo, const glm::vec3& wi) {
    switch (b.kind) {
        case BsdfKind::lambertian: return wo.z > 0.f ? cosine_hemisphere_pdf(wi.z) : 0.f;
        case BsdfKind::mirror:
        case BsdfKind::glass: return 0.f;
        case BsdfKind::conductor: {
            if (wo.z <= 0.f || wi.z <= 0.f || bsdf_has_delta(b)) return 0.f;
            glm::vec3 h = wo + wi;
            if (h == glm::vec3(0.f)) return 0.f;
            h = glm::normalize(h);
            const float oh = glm::dot(wo, h);
            return oh > 0.f ? beckmann_pdf_h(h, std::max(b.alpha, kMinAlpha)) / (4.f * oh) : 0.f;
        }
        case BsdfKind::phong: {
            if (wo.z <= 0.f || wi.z <= 0.f || bsdf_has_delta(b)) return 0.f;
            const float c = glm::dot(reflect_local(wo), wi);
            return c > 0.f ? (b.exponent + 1.f) * (0.5f * kInvPi) * std::pow(c, b.exponent) : 0.f;
        }
        case BsdfKind::metallic_roughness: {
            if (wo.z <= 0.f || wi.z <= 0.f) return 0.f;
            return bsdf_detail::MetallicRoughness(b, wo).pdf(b, wo, wi);
        }
    }
    return 0.f;
}

namespace bsdf_detail {

// A sampled reflection direction s.wi given its density and weight from `pdf` and `f` (mixtures
// and lobes clipped by the horizon: the density is the whole sampling routine's).
template <class Pdf, class F>
inline bool weigh_by(BsdfSample& s, const Pdf& pdf, const F& f) {
    if (s.wi.z <= 0.f) return false;
    s.pdf = pdf(s.wi);
    if (!(s.pdf > 0.f)) return false;
    s.weight = f(s.wi) * (s.wi.z / s.pdf);
    s.delta = false;
    return true;
}
inline bool weigh(const Bsdf& b, const glm::vec3& wo, BsdfSample& s) {
    return weigh_by(s, [&](const glm::vec3& wi) { return bsdf_pdf(b, wo, wi); },
                    [&](const glm::vec3& wi) { return bsdf_f(b, wo, wi); });
}

}  // namespace bsdf_detail

// `uc` is read only where bsdf_chooses_lobe(b). False: no direction (the path ends there).
inline bool bsdf_sample(const Bsdf& b, const glm::vec3& wo, float uc, glm::vec2 u, BsdfSample& s) {
    if (wo.z <= 0.f) return false;
    switch (b.kind) {
        case BsdfKind::lambertian: {
            s.wi = sample_cosine_hemisphere(u.x, u.y);
            s.pdf = cosine_hemisphere_pdf(s.wi.z);
            s.weight = b.albedo;
            s.delta = false;
            return s.wi.z > 0.f;
        }
        case BsdfKind::mirror: {
            s.wi = reflect_local(wo);
            s.pdf = 1.f;
            s.weight = b.albedo;
            s.delta = true;
            return true;
        }
        case BsdfKind::glass: {
            const float F = fresnel_dielectric(wo.z, b.ior);
            s.delta = true;
            if (uc < F) {
                s.wi = reflect_local(wo);
                s.pdf = F;
                s.weight = b.albedo;
                return true;
            }
            if (!refract(wo, glm::vec3(0.f, 0.f, 1.f), b.ior, s.wi)) return false;  // F = 1 there; unreachable
            s.pdf = 1.f - F;
            // Radiance, not importance: it is compressed by η² entering the denser side.
            s.weight = b.transmittance / (b.ior * b.ior);
            return s.wi.z < 0.f;
        }
        case BsdfKind::conductor: {
            if (bsdf_has_delta(b)) {
                s.wi = reflect_local(wo);
                s.pdf = 1.f;
                s.weight = fresnel_conductor(wo.z, b.eta, b.k);
                s.delta = true;
                return true;
            }
            const glm::vec3 h = beckmann_sample_h(u, std::max(b.alpha, kMinAlpha));
            const float oh = glm::dot(wo, h);
            if (oh <= 0.f) return false;
            s.wi = 2.f * oh * h - wo;
            return bsdf_detail::weigh(b, wo, s);
        }
        case BsdfKind::phong: {
            if (bsdf_has_delta(b)) {
                // The lobe's limit: ∫ f cos θi dωi → albedo · cos θo as the exponent grows.
                s.wi = reflect_local(wo);
                s.pdf = 1.f;
                s.weight = b.albedo * wo.z;
                s.delta = true;
                return true;
            }
            const float c = std::pow(u.x, 1.f / (b.exponent + 1.f));
            const float sn = std::sqrt(std::max(0.f, 1.f - c * c));
            const float phi = 2.f * kPi * u.y;
            s.wi = Frame(reflect_local(wo)).to_world({sn * std::cos(phi), sn * std::sin(phi), c});
            return bsdf_detail::weigh(b, wo, s);
        }
        case BsdfKind::metallic_roughness: {
            const bsdf_detail::MetallicRoughness m(b, wo);
            const float ps = m.p_spec(wo);
            if (uc < ps && b.alpha < kSmoothAlpha) {
                // The smooth specular lobe: a mirror whose Fresnel is Schlick's at h = n.
                s.wi = reflect_local(wo);
                s.pdf = ps;
                s.weight = m.f_spec(wo.z) / ps;
                s.delta = true;
                return true;
            }
            if (uc < ps) {
                const glm::vec3 h = ggx_sample_visible_h(wo, u, m.alpha);
                const float oh = glm::dot(wo, h);
                if (oh <= 0.f) return false;
                s.wi = 2.f * oh * h - wo;
            } else {
                s.wi = sample_cosine_hemisphere(u.x, u.y);
            }
            // Weighed by the terms built here: bsdf_pdf and bsdf_f would build them again from wo
            // (their table lookups were most of their cost, docs/benchmarks.md).
            return bsdf_detail::weigh_by(s, [&](const glm::vec3& wi) { return m.pdf(b, wo, wi); },
                                         [&](const glm::vec3& wi) { return m.f(b, wo, wi); });
        }
    }
    return false;
}

// The non-delta part of a BSDF in the two pieces direct lighting treats differently
// (engine/render/path_integrator.h): the diffuse piece, which `hemisphere` and `importance`
// estimate their CS184 way, and the glossy lobe, always estimated by MIS.
struct BsdfSplit {
    glm::vec3 diffuse{0.f};
    glm::vec3 glossy{0.f};
};

inline BsdfSplit bsdf_split(const Bsdf& b, const glm::vec3& wo, const glm::vec3& wi) {
    BsdfSplit r;
    if (wo.z <= 0.f || wi.z <= 0.f) return r;
    switch (b.kind) {
        case BsdfKind::lambertian: r.diffuse = b.albedo * kInvPi; break;
        case BsdfKind::conductor:
        case BsdfKind::phong: r.glossy = bsdf_f(b, wo, wi); break;
        case BsdfKind::metallic_roughness: {
            const bsdf_detail::MetallicRoughness m(b, wo);
            r.diffuse = m.f_base(wi);
            r.glossy = m.f_glossy(b, wo, wi);
            break;
        }
        default: break;
    }
    return r;
}

// A BSDF at one vertex, seen from wo (local frame): what depends on wo alone is built once (a
// glTF material's Fresnel terms and albedo-table lookups), not again for every direction the
// vertex weighs (each light sample's f and density, the continuation's, the light split's
// lobes). Its f, pdf and split are bsdf_f's, bsdf_pdf's and bsdf_split's, bit for bit.
class BsdfAt {
public:
    BsdfAt(const Bsdf& b, const glm::vec3& wo) : b_(b), wo_(wo) {
        if (b.kind == BsdfKind::metallic_roughness && wo.z > 0.f) m_.emplace(b, wo);
    }
    BsdfAt(Bsdf&&, const glm::vec3&) = delete;  // it keeps a reference
    const Bsdf& bsdf() const { return b_; }
    const glm::vec3& wo() const { return wo_; }
    // The guards are the free functions' (wi.z <= 0, so a NaN direction gives what they give).
    glm::vec3 f(const glm::vec3& wi) const {
        if (!m_) return bsdf_f(b_, wo_, wi);
        if (wi.z <= 0.f) return glm::vec3(0.f);
        return m_->f(b_, wo_, wi);
    }
    float pdf(const glm::vec3& wi) const {
        if (!m_) return bsdf_pdf(b_, wo_, wi);
        if (wi.z <= 0.f) return 0.f;
        return m_->pdf(b_, wo_, wi);
    }
    BsdfSplit split(const glm::vec3& wi) const {
        if (!m_) return bsdf_split(b_, wo_, wi);
        BsdfSplit r;
        if (wi.z <= 0.f) return r;
        r.diffuse = m_->f_base(wi);
        r.glossy = m_->f_glossy(b_, wo_, wi);
        return r;
    }

private:
    const Bsdf& b_;
    glm::vec3 wo_;
    std::optional<bsdf_detail::MetallicRoughness> m_;
};

}  // namespace tessera
