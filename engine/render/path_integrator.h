#pragma once
// Unidirectional path tracing with the CS184 semantics: max_depth 0 shows emitters only,
// 1 adds direct lighting, n adds up to n bounces; `accumulate` sums bounces 0..n and `nth`
// keeps only bounce n. Direct lighting at every vertex comes from light samples (and uniform
// hemisphere samples for the diffuse part under `hemisphere`), so all three strategies
// estimate the same integral. The continuation ray adds emission only where that vertex's
// estimate needs it: after a delta lobe (mirror, glass, smooth metal), whose light no light
// sample can find, with weight one; and as the BSDF sample of MIS (the whole BSDF under `mis`,
// a glossy lobe always), weighted against the light samples. Either way it counts for the
// vertex it left, once.
#include <algorithm>
#include <cmath>

#include "engine/geometry/spawn.h"
#include "engine/render/aov.h"
#include "engine/render/light_sampler.h"
#include "engine/render/renderer.h"
#include "engine/sampling/sampler.h"
#include "engine/sampling/warp.h"
#include "engine/scene/environment.h"
#include "engine/scene/intersect.h"
#include "engine/scene/surface_textures.h"

namespace tessera {

// The reflectance the albedo AOV shows for a BSDF (texture applied): the base colour of
// diffuse, Phong and glTF materials, a conductor's reflectance at normal incidence. Perfect
// specular BSDFs have none of their own: the AOV looks through them.
inline glm::vec3 aov_albedo(const Bsdf& b) {
    if (b.kind == BsdfKind::conductor) {
        const glm::vec3 e = b.eta, k = b.k;
        return b.albedo * (((e - 1.f) * (e - 1.f) + k * k) / ((e + 1.f) * (e + 1.f) + k * k));
    }
    return b.albedo;
}

// Per channel, the share of f that is the glossy lobe's (all of it where f is zero).
inline glm::vec3 glossy_share(const BsdfSplit& p) {
    const glm::vec3 t = p.diffuse + p.glossy;
    return {t.x > 0.f ? p.glossy.x / t.x : 1.f, t.y > 0.f ? p.glossy.y / t.y : 1.f, t.z > 0.f ? p.glossy.z / t.z : 1.f};
}

// The geometric AOVs of a camera ray's first hit (its BSDF's albedo and shading normal are
// refined where textures apply, in the integrator).
inline void record_first_hit(const RenderScene& s, const Ray& ray, const Hit& hit, const SurfaceInteraction& si, SampleAovs& a) {
    a.depth = hit.t * glm::length(ray.d);
    a.position = si.p;
    a.normal = si.ns;
    a.material = si.material + 1;
    const size_t meshes = s.mesh_first_tri.empty() ? 0 : s.mesh_first_tri.size() - 1;
    if (hit.sphere) {
        a.object = uint32_t(meshes + hit.prim + 1);
    } else {
        const auto it = std::upper_bound(s.mesh_first_tri.begin(), s.mesh_first_tri.end(), hit.prim);
        a.object = uint32_t(it - s.mesh_first_tri.begin());
    }
    if (a.object - 1 < s.object_hashes.size()) a.object_hash = s.object_hashes[a.object - 1];
    if (si.material < s.material_hashes.size()) a.material_hash = s.material_hashes[si.material];
    const Bsdf& b = s.materials[si.material].bsdf;
    a.albedo = bsdf_is_delta(b) ? glm::vec3(0.f) : aov_albedo(b);
}

class PathIntegrator {
public:
    PathIntegrator(const RenderScene& scene, const RenderSettings& settings, RenderStats& stats)
        : s_(scene), st_(settings), stats_(stats),
          env_(settings.environment && !settings.environment->empty() ? settings.environment.get() : nullptr),
          selection_(chosen_light_selection(scene, settings.light_selection)),
          by_power_(selection_ == LightSelection::power && scene.area_lights.size() > 1),
          by_tree_(selection_ == LightSelection::tree && !scene.light_tree.empty()),
          light_samples_(float(std::max(1, settings.light_rays))) {}

    // `aovs`, when given, receives the sample's AOVs: the first hit's geometry and the light
    // split of L (emission and environment seen directly, then the first vertex's direct light and
    // everything after it, each shared between its diffuse and glossy lobes), which sums to L.
    glm::vec3 radiance(Ray ray, Sampler& rng, SampleAovs* aovs = nullptr) {
        Hit hit;
        if (!intersect(s_, ray, hit, stats_.traversal)) {
            const glm::vec3 bg = include(0) ? background(glm::normalize(ray.d)) : glm::vec3(0.f);
            if (aovs) aovs->environment = bg;
            return bg;
        }
        SurfaceInteraction si = surface_at(s_, ray, hit);
        if (aovs) record_first_hit(s_, ray, hit, si, *aovs);
        glm::vec3 wo = -glm::normalize(ray.d);
        glm::vec3 L = include(0) ? emitted(si, hit, wo) : glm::vec3(0.f);
        if (aovs) aovs->emission = L;
        glm::vec3 beta(1.f);
        Bsdf textured;  // a textured material's BSDF at the current vertex
        // The light split (aovs only): L when the first vertex's light is all in, its direct
        // light by lobe, and the glossy share of the emission its continuation finds and of
        // everything after it.
        glm::vec3 L_first(0.f), cont_glossy(0.f), found_glossy(0.f);
        bool first_done = false;
        DirectSplit split;
        // The albedo AOV looks through perfect specular vertices: their weights so far.
        glm::vec3 albedo_through(1.f);
        bool albedo_pending = false;
        for (int depth = 1; depth <= st_.max_depth; ++depth) {
            if (aovs && depth == 2) {
                L_first = L;
                first_done = true;
            }
            const Material& mat = s_.materials[si.material];
            const Bsdf* bsdf = &mat.bsdf;
            if (mat.textures != kNoTextures && !hit.sphere) {
                // Normal maps bend ns as the surface was modelled, before it is turned to wo.
                textured = mat.bsdf;
                apply_textures(s_, s_.material_textures[mat.textures], hit.prim, hit.b1, hit.b2, textured, si.ns, si.ng, hit.instance);
                bsdf = &textured;
            }
            if (aovs && (depth == 1 || albedo_pending)) {
                if (depth == 1) aovs->normal = si.ns;
                if (bsdf_is_delta(*bsdf)) {
                    albedo_pending = true;
                } else {
                    aovs->albedo = albedo_through * aov_albedo(*bsdf);
                    albedo_pending = false;
                }
            }
            const bool back = face(si, wo);
            const Bsdf& b = *bsdf;
            if (bsdf_is_black(b)) break;  // nothing is reflected from here on
            const Frame frame(si.ns);
            const glm::vec3 wo_l = frame.to_local(wo);
            const BsdfAt at(b, wo_l);
            // A delta lobe sees lights only along its own directions: a continuation drawn from
            // it carries the emission it finds, in place of direct lighting, for this same
            // bounce. The rest of the BSDF gets light samples here; where MIS applies (the
            // whole BSDF under `mis`, a glossy lobe always) the continuation is also its BSDF
            // sample, as in pbrt, so MIS costs no ray of its own.
            const bool has_delta = bsdf_has_delta(b);
            const bool only_delta = has_delta && bsdf_is_delta(b);
            const MisPart part = only_delta ? MisPart::none : mis_part(b);
            const bool last = depth == st_.max_depth;
            // Whether the continuation is this vertex's MIS BSDF sample (lights it could find).
            const bool mis_here = part != MisPart::none && include(depth) && (!s_.area_lights.empty() || env_);
            if (!only_delta) {
                if (include(depth)) L += beta * direct(si, at, frame, part, rng, aovs && depth == 1 ? &split : nullptr);
                if (last && !has_delta && !mis_here) break;
            }
            // Roulette before the continuation unless it is the MIS BSDF sample: then after its
            // emission is counted.
            if (!mis_here && !last && !roulette(beta, rng)) break;
            glm::vec3 wi, weight;
            float pdf = 0.f;
            bool delta = false;  // the continuation came from a delta lobe
            if (b.kind == BsdfKind::lambertian) {
                // Cosine-weighted: f·cos/pdf of the Lambertian lobe is its albedo.
                const glm::vec2 u = rng.next_2d();
                const glm::vec3 wl = sample_cosine_hemisphere(u.x, u.y);
                wi = frame.to_world(wl);
                if (glm::dot(wi, si.ng) <= 0.f) break;  // below the true surface (shading normal bent away)
                weight = b.albedo;
                pdf = cosine_hemisphere_pdf(wl.z);
            } else {
                BsdfSample bs;
                if (!sample(b, back, wo_l, rng, bs)) break;
                // At the last vertex only a delta lobe's light, or MIS's share, is still to count.
                if (last && !bs.delta && !mis_here) break;
                wi = frame.to_world(bs.wi);
                if ((glm::dot(wi, si.ng) > 0.f) != (bs.wi.z > 0.f)) break;  // the true surface disagrees
                weight = bs.weight;
                pdf = bs.pdf;
                delta = bs.delta;
                if (aovs && depth == 1) {
                    cont_glossy = delta ? glm::vec3(1.f) : glossy_share(at.split(bs.wi));
                    found_glossy = part == MisPart::glossy && !delta ? glm::vec3(1.f) : cont_glossy;
                }
            }
            if (aovs && albedo_pending) {
                if (delta) albedo_through *= weight;
                else albedo_pending = false;  // a specular vertex's rough part: no albedo to look through to
            }
            Ray next = spawn_ray(si.p, si.p_err, si.ng, wi, si.tri, si.instance, si.time);
            // At the last vertex MIS's BSDF sample is direct lighting's ray, not a bounce.
            if (last && !delta) ++stats_.shadow_rays;
            else ++stats_.bounce_rays;
            const glm::vec3 beta_here = beta;
            beta *= weight;
            const bool hit_next = intersect(s_, next, hit, stats_.traversal);
            if (delta) {
                if (!hit_next) {
                    if (include(depth)) L += beta * background(wi);
                    break;
                }
                si = surface_at(s_, next, hit);
                if (include(depth)) L += beta * emitted(si, hit, -wi);
            } else if (mis_here) {
                // The emission the continuation finds, weighted against the light samples that
                // could have found it (`n` of them, power heuristic), for this vertex's bounce.
                const glm::vec3 fw = part == MisPart::whole ? weight : glossy_weight(at, frame.to_local(wi), pdf);
                if (!hit_next) {
                    if (env_) L += beta_here * fw * environment_radiance(*env_, wi) * bsdf_mis_weight(pdf, environment_pdf(*env_, wi, env_sampling(part)));
                    break;
                }
                const SurfaceInteraction from = si;
                si = surface_at(s_, next, hit);
                L += beta_here * fw * mis_emission(from, at, frame, wi, si, hit);
            } else {
                if (!hit_next) break;
                si = surface_at(s_, next, hit);
            }
            if (last) break;
            if (mis_here && !roulette(beta, rng)) break;
            wo = -wi;
        }
        if (aovs) {
            if (albedo_pending) aovs->albedo = albedo_through;  // the path ended behind specular vertices
            const glm::vec3 at_first = first_done ? L_first : L;
            const glm::vec3 found = at_first - aovs->emission - split.diffuse - split.glossy;
            aovs->glossy_direct = split.glossy + found * found_glossy;
            aovs->diffuse_direct = at_first - aovs->emission - aovs->glossy_direct;
            const glm::vec3 after = L - at_first;
            aovs->glossy_indirect = after * cont_glossy;
            aovs->diffuse_indirect = after - aovs->glossy_indirect;
        }
        return L;
    }

private:
    bool include(int bounce) const { return counts_bounce(st_, bounce); }

    glm::vec3 sky(const glm::vec3& d) const { return (s_.has_sky && d.y > 0.f) ? s_.sky : glm::vec3(0.f); }
    // What a ray that leaves the scene sees: the CS184 sky and the environment map.
    glm::vec3 background(const glm::vec3& d) const {
        glm::vec3 L = sky(d);
        if (env_) L += environment_radiance(*env_, d);
        return L;
    }

    // Emission leaving the hit toward wo: triangles of lights only (spheres are not lights yet).
    glm::vec3 emitted(const SurfaceInteraction& si, const Hit& hit, const glm::vec3& wo) const {
        if (hit.sphere) return glm::vec3(0.f);
        const Material& m = s_.materials[si.material];
        if (!m.emissive()) return glm::vec3(0.f);
        if (!m.double_sided && glm::dot(si.ng, wo) <= 0.f) return glm::vec3(0.f);
        return m.textures == kNoTextures ? m.emission : emission_at(s_, m, hit.prim, hit.b1, hit.b2);
    }

    // Two-sided shading: both normals turned toward the viewer. True when they were turned: wo
    // is on the back of the surface (inside a closed object with outward normals).
    static bool face(SurfaceInteraction& si, const glm::vec3& wo) {
        if (glm::dot(si.ng, wo) >= 0.f) return false;
        si.ng = -si.ng;
        si.ns = -si.ns;
        return true;
    }

    // A direction from a BSDF other than Lambertian's; glass seen from inside has the inverse
    // relative index.
    bool sample(const Bsdf& b, bool back, const glm::vec3& wo_l, Sampler& rng, BsdfSample& bs) {
        const float uc = bsdf_chooses_lobe(b) ? rng.next_float() : 0.f;
        const glm::vec2 u = rng.next_2d();
        if (b.kind == BsdfKind::glass && back) {
            Bsdf inverse = b;
            inverse.ior = 1.f / b.ior;
            return bsdf_sample(inverse, wo_l, uc, u, bs);
        }
        return bsdf_sample(b, wo_l, uc, u, bs);
    }

    static float power_heuristic(float a, float b) { return a * a / (a * a + b * b); }

    // Which part of a vertex's BSDF is estimated by MIS of light samples and the continuation
    // (its one BSDF sample): all of it under `mis`, a glossy lobe under every strategy.
    enum class MisPart { none, glossy, whole };
    MisPart mis_part(const Bsdf& b) const {
        if (st_.direct == DirectLighting::mis) return MisPart::whole;
        return bsdf_has_glossy(b) ? MisPart::glossy : MisPart::none;
    }
    // The environment's light samples leave the sky below the map's mean to the BSDF sample
    // where every one of them is MIS-weighted against it: not under `importance`, whose
    // diffuse part has the light samples alone.
    EnvironmentSampling env_sampling(MisPart part) const {
        const bool all_weighted = part == MisPart::whole || (part == MisPart::glossy && st_.direct == DirectLighting::hemisphere);
        return all_weighted ? EnvironmentSampling::compensated : EnvironmentSampling::full;
    }
    // Power-heuristic weights between `light_samples_` light samples of density pdf_l and one
    // BSDF sample of density pdf_b (Veach's heuristic with the sample counts).
    float bsdf_mis_weight(float pdf_b, float pdf_l) const { return power_heuristic(pdf_b, light_samples_ * pdf_l); }
    float light_mis_weight(float pdf_l, float pdf_b) const { return power_heuristic(light_samples_ * pdf_l, pdf_b); }

    // The continuation's density toward wi, as the light samples' weights see it.
    static float continuation_pdf(const BsdfAt& at, const glm::vec3& wl) {
        return at.bsdf().kind == BsdfKind::lambertian ? (wl.z > 0.f ? cosine_hemisphere_pdf(wl.z) : 0.f) : at.pdf(wl);
    }
    // The glossy lobe's f·cos/pdf for a continuation drawn from the whole BSDF with density pdf.
    static glm::vec3 glossy_weight(const BsdfAt& at, const glm::vec3& wl, float pdf) {
        return pdf > 0.f ? at.split(wl).glossy * (wl.z / pdf) : glm::vec3(0.f);
    }

    // Direct light at the first vertex by lobe, for the light split.
    struct DirectSplit {
        glm::vec3 diffuse{0.f}, glossy{0.f};
    };

    // Russian roulette on the path's throughput; false ends the path.
    bool roulette(glm::vec3& beta, Sampler& rng) const {
        if (st_.russian_roulette <= 0.f) return true;
        if (rng.next_float() >= st_.russian_roulette) return false;
        beta /= st_.russian_roulette;
        return true;
    }

    // The emission a continuation from `from` (its BSDF there: `at`) found at `hs`, times its
    // MIS weight against the light samples that could have chosen the same point. The weight's
    // geometry is taken from the shading point, not from the offset ray origin (whose offset is
    // not small against the distance far from the origin), as the light sample computes it, so
    // the two weights sum to one.
    glm::vec3 mis_emission(const SurfaceInteraction& from, const BsdfAt& at, const Frame& frame, const glm::vec3& wi,
                           const SurfaceInteraction& hs, const Hit& h) const {
        if (h.sphere) return glm::vec3(0.f);
        const uint32_t lti = s_.tri_shading[h.prim].light;
        if (lti == kNoLight) return glm::vec3(0.f);
        const glm::vec3 Le = emitted(hs, h, -wi);
        if (Le == glm::vec3(0.f)) return glm::vec3(0.f);
        const glm::vec3 d = anchored_difference(hs.anchor, hs.local, from.anchor, from.local);
        const float dist = glm::length(d);
        if (!(dist > 0.f)) return glm::vec3(0.f);
        const glm::vec3 wp = d / dist;
        const float pdf_bp = continuation_pdf(at, frame.to_local(wp));
        float pdf_l;
        if (by_tree_) {
            const float area = light_triangle_at(s_, lti, hs.time).area;
            const float cos_l = std::abs(glm::dot(hs.ng, wp));
            pdf_l = cos_l > 0.f && area > 0.f ? light_tree_pmf(s_.light_tree, from.p, from.ns, lti) * dist * dist / (cos_l * area) : 0.f;
        } else {
            const AreaLight& light = s_.area_lights[s_.light_triangles[lti].light];
            pdf_l = area_light_pdf(s_, lti, hs.ng, wp, dist, hs.time) * (by_power_ ? light.power_pmf : 1.f);
        }
        return Le * bsdf_mis_weight(pdf_bp, pdf_l);
    }

    // Direct lighting at a vertex from the non-delta part of its BSDF, by light samples (and,
    // under `hemisphere`, uniform hemisphere samples for the diffuse part). The diffuse part
    // follows `direct` (CS184: hemisphere samples, light samples, or MIS of light and BSDF
    // samples); a glossy lobe is always estimated by MIS, since neither light nor BSDF samples
    // alone find both small lights and narrow lobes. `part` says what MIS covers: its light
    // samples are weighted here against the continuation, which radiance() weighs in turn as
    // the BSDF sample. A Lambertian BSDF keeps its constant f without a call per sample.
    glm::vec3 direct(const SurfaceInteraction& si, const BsdfAt& at, const Frame& frame, MisPart part, Sampler& rng,
                     DirectSplit* split = nullptr) {
        const Bsdf& b = at.bsdf();
        const glm::vec3& wo_l = at.wo();
        if (!s_.has_lights() && !env_) return glm::vec3(0.f);
        const bool lambert = b.kind == BsdfKind::lambertian;
        const glm::vec3 f_lambert = b.albedo * kInvPi;
        const bool hemisphere = st_.direct == DirectLighting::hemisphere;
        auto f = [&](const glm::vec3& wi) { return lambert ? f_lambert : at.f(frame.to_local(wi)); };
        // f toward a light sample of density `pdf`, MIS-weighted where MIS applies; under
        // `hemisphere` only the glossy lobe (the diffuse part has its own samples).
        auto f_light = [&](const glm::vec3& wi, float pdf) -> glm::vec3 {
            if (part == MisPart::none) return f(wi);
            const glm::vec3 wl = frame.to_local(wi);
            const float w = light_mis_weight(pdf, continuation_pdf(at, wl));
            if (part == MisPart::whole) return f(wi) * w;
            const BsdfSplit p = at.split(wl);
            return hemisphere ? p.glossy * w : p.diffuse + p.glossy * w;
        };
        glm::vec3 Ld(0.f);
        // The glossy lobe's part of Ld (split only): f_light's glossy part toward a light sample.
        glm::vec3 Lg(0.f);
        auto g_light = [&](const glm::vec3& wi, float pdf) -> glm::vec3 {
            if (lambert) return glm::vec3(0.f);
            const glm::vec3 wl = frame.to_local(wi);
            const float w = part == MisPart::none ? 1.f : light_mis_weight(pdf, continuation_pdf(at, wl));
            return at.split(wl).glossy * w;
        };
        auto done = [&] {
            if (split) {
                split->glossy = Lg;
                split->diffuse = Ld - Lg;
            }
            return Ld;
        };
        // Delta lights have one deterministic direction: one shadow ray each, in every strategy.
        for (size_t k = 0; k < s_.delta_lights.size(); ++k) {
            const DeltaLight dl = delta_light_at(s_, k, si.time);
            if (dl.kind == DeltaKind::point) {
                const glm::vec3 d = dl.position - si.p;
                const float dist2 = glm::dot(d, d);
                if (!(dist2 > 0.f)) continue;  // a light at the shading point has no direction
                const glm::vec3 wi = d / std::sqrt(dist2);
                const float c = glm::dot(si.ns, wi);
                if (c <= 0.f || glm::dot(si.ng, wi) <= 0.f) continue;
                ++stats_.shadow_rays;
                if (!occluded(s_, spawn_ray_to(si.p, si.p_err, si.ng, dl.position, si.tri, si.instance, si.time), stats_.traversal)) {
                    Ld += f(wi) * dl.intensity * (c / dist2);
                    if (split && !lambert) Lg += at.split(frame.to_local(wi)).glossy * dl.intensity * (c / dist2);
                }
            } else {
                const glm::vec3 wi = -dl.direction;
                const float c = glm::dot(si.ns, wi);
                if (c <= 0.f || glm::dot(si.ng, wi) <= 0.f) continue;
                ++stats_.shadow_rays;
                if (!occluded(s_, spawn_ray(si.p, si.p_err, si.ng, wi, si.tri, si.instance, si.time), stats_.traversal)) {
                    Ld += f(wi) * dl.intensity * c;
                    if (split && !lambert) Lg += at.split(frame.to_local(wi)).glossy * dl.intensity * c;
                }
            }
        }
        const int n = std::max(1, st_.light_rays);
        if (hemisphere) {
            // The diffuse part from uniform hemisphere samples (all of a Lambertian BSDF).
            const int count = n * int(s_.area_lights.size() + (s_.has_sky ? 1 : 0) + (env_ ? 1 : 0));
            for (int i = 0; i < count; ++i) {
                const glm::vec2 u = rng.next_2d();
                const glm::vec3 wl = sample_uniform_hemisphere(u.x, u.y);
                const glm::vec3 wi = frame.to_world(wl);
                if (glm::dot(wi, si.ng) <= 0.f) continue;
                const glm::vec3 fd = lambert ? f_lambert : at.split(wl).diffuse;
                if (fd == glm::vec3(0.f)) continue;
                Ray r = spawn_ray(si.p, si.p_err, si.ng, wi, si.tri, si.instance, si.time);
                ++stats_.shadow_rays;
                Hit h;
                glm::vec3 Le;
                if (intersect(s_, r, h, stats_.traversal)) Le = emitted(surface_at(s_, r, h), h, -wi);
                else Le = background(wi);
                Ld += fd * Le * (glm::dot(si.ns, wi) / (uniform_hemisphere_pdf() * float(count)));
            }
            if (part == MisPart::none) return done();
        }
        const bool by_power = by_power_, by_tree = by_tree_;
        // A light sample, its light chosen with probability `pick`.
        auto shade = [&](const LightSample& ls, float pick) {
            const float c = glm::dot(si.ns, ls.wi);
            if (c <= 0.f || glm::dot(si.ng, ls.wi) <= 0.f) return;
            const float pdf = ls.pdf_w * pick;
            const glm::vec3 fw = f_light(ls.wi, pdf);
            if (fw == glm::vec3(0.f)) return;
            ++stats_.shadow_rays;
            if (occluded(s_, spawn_ray_between(si.p, si.p_err, si.ng, ls.point, ls.point_err, ls.n, si.tri, si.instance, si.time), stats_.traversal)) return;
            const glm::vec3 Le = s_.textured_emission
                                     ? emission_at(s_, s_.materials[s_.tri_shading[ls.prim].material], ls.prim, ls.b1, ls.b2)
                                     : ls.Le;
            Ld += fw * Le * (c / (pdf * float(n)));
            if (split) Lg += g_light(ls.wi, pdf) * Le * (c / (pdf * float(n)));
        };
        auto light_sample = [&](const AreaLight& light, float pick) {
            LightSample ls;
            if (sample_area_light(s_, light, si.anchor, si.local, rng, ls, si.time)) shade(ls, pick);
        };
        if (by_tree) {
            for (int i = 0; i < n; ++i) {
                // Sobol: one 2-D point walks the tree with its first coordinate (rescaled at each
                // choice) and then places the point on the triangle, stratified over all lights.
                const bool one_point = rng.kind() == SamplerKind::sobol;
                float u = one_point ? 0.f : rng.next_float();
                glm::vec2 uv = rng.next_2d();
                if (one_point) u = uv.x;
                uint32_t lt;
                float pmf;
                if (!sample_light_tree(s_.light_tree, si.p, si.ns, u, lt, pmf)) continue;
                if (one_point) uv.x = u;
                LightSample ls;
                if (sample_light_triangle(s_, lt, uv, si.anchor, si.local, ls, si.time)) shade(ls, pmf);
            }
        } else if (by_power) {
            for (int i = 0; i < n; ++i) {
                const float u = rng.next_float();
                const auto it = std::lower_bound(s_.area_lights.begin(), s_.area_lights.end(), u,
                                                 [](const AreaLight& l, float v) { return l.power_cdf <= v; });
                const AreaLight& light = it == s_.area_lights.end() ? s_.area_lights.back() : *it;
                light_sample(light, light.power_pmf);
            }
        } else {
            for (const AreaLight& light : s_.area_lights)
                for (int i = 0; i < n; ++i) light_sample(light, 1.f);
        }
        if (env_) {
            // The environment is one more light: `n` samples by its luminance.
            const EnvironmentSampling how = env_sampling(part);
            for (int i = 0; i < n; ++i) {
                const glm::vec2 u = rng.next_2d();
                glm::vec3 wi, Le;
                float pdf;
                if (!sample_environment(*env_, u, wi, pdf, Le, how)) continue;
                const float c = glm::dot(si.ns, wi);
                if (c <= 0.f || glm::dot(si.ng, wi) <= 0.f) continue;
                const glm::vec3 fw = f_light(wi, pdf);
                if (fw == glm::vec3(0.f)) continue;
                ++stats_.shadow_rays;
                if (occluded(s_, spawn_ray(si.p, si.p_err, si.ng, wi, si.tri, si.instance, si.time), stats_.traversal)) continue;
                Ld += fw * Le * (c / (pdf * float(n)));
                if (split) Lg += g_light(wi, pdf) * Le * (c / (pdf * float(n)));
            }
        }
        if (s_.has_sky) {
            // The sky is sampled with the BSDF: f·L·cos/pdf is the sample's weight times L
            // (for the Lambertian lobe, its albedo). A delta lobe's share is its continuation's.
            for (int i = 0; i < n; ++i) {
                glm::vec3 wi, weight, share(0.f);
                if (lambert) {
                    const glm::vec2 u = rng.next_2d();
                    wi = frame.to_world(sample_cosine_hemisphere(u.x, u.y));
                    weight = b.albedo;
                } else {
                    BsdfSample bs;
                    if (!sample(b, false, wo_l, rng, bs) || bs.delta || bs.wi.z <= 0.f) continue;
                    wi = frame.to_world(bs.wi);
                    weight = bs.weight;
                    if (split) share = glossy_share(at.split(bs.wi));
                }
                if (glm::dot(wi, si.ng) <= 0.f || wi.y <= 0.f) continue;
                ++stats_.shadow_rays;
                if (!occluded(s_, spawn_ray(si.p, si.p_err, si.ng, wi, si.tri, si.instance, si.time), stats_.traversal)) {
                    Ld += weight * s_.sky / float(n);
                    if (split) Lg += share * weight * s_.sky / float(n);
                }
            }
        }
        return done();
    }

    const RenderScene& s_;
    const RenderSettings& st_;
    RenderStats& stats_;
    const EnvironmentMap* env_;  // none: black beyond the scene
    LightSelection selection_;   // `automatic` resolved for this scene
    bool by_power_, by_tree_;    // how area lights share the light samples
    float light_samples_;        // per light (`all`) or in all (`power`, `tree`), and for the environment
};

}  // namespace tessera
