#pragma once
// One worker's state while it renders tiles: its statistics and the per-pixel sample loop of
// one pass. Nothing here is shared between threads; a pixel's film entries are written only by
// the worker that owns its tile in that pass.
#include <algorithm>
#include <cmath>

#include "engine/render/film.h"
#include "engine/render/image.h"
#include "engine/render/integrators.h"
#include "engine/sampling/warp.h"
#include "engine/render/render_settings.h"
#include "engine/render/renderer.h"
#include "engine/render/seen_emitters.h"
#include "engine/sampling/sampler.h"

namespace tessera {

inline float illuminance(const glm::vec3& c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

// A cache line of its own: the statistics a worker bumps on every ray must not share a line
// with another worker's context, whose references its integrator reads on every ray. Two
// contexts allocated back to back did share one, and the render of CBbunny took 1.4× as long
// whenever the heap happened to place them so (measured: 3.3 s against 2.2 s).
class alignas(64) TileContext {
public:
    // `seen`: the lamps over the pixels this context renders (seen_emitters.h), or none.
    TileContext(const RenderScene& scene, const RenderSettings& settings, const Camera& camera, const SeenEmitters* seen = nullptr)
        : settings_(settings), camera_(camera), integrator_(scene, settings, stats), motion_(scene.motion.any()),
          seen_(seen && !seen->empty() ? seen : nullptr) {
        if (scene.motion.camera) {
            camera_close_ = make_camera(scene.motion.camera_close, settings.width, settings.height);
            set_thin_lens(camera_close_, scene.motion.camera_close, settings.lens_radius, settings.focal_distance);
            moving_camera_ = true;
        }
    }

    // Takes pixel (x, y), entry `p` of `film`, to `target` samples (uniform), or by one batch
    // (adaptive). Its random streams follow from its place in the image, not in the film.
    void render_pixel(int x, int y, Film& film, size_t p, int target) {
        const size_t pixel = size_t(y) * size_t(settings_.width) + size_t(x);
        const bool adaptive = settings_.adaptive.has_value();
        if (adaptive) {
            if (film.done[p]) return;
            target = std::min(settings_.spp, int(film.count[p]) + std::max(1, settings_.adaptive->batch));
        }
        const float inv_w = 1.f / float(settings_.width), inv_h = 1.f / float(settings_.height);
        glm::dvec3 sum = film.sum[p];
        const bool halves = !film.sum_half.empty();
        glm::dvec3 half(0.0), quarter(0.0), eighth(0.0);
        if (halves) {
            half = film.sum_half[p];
            quarter = film.sum_quarter[p];
            eighth = film.sum_eighth[p];
        }
        int s = int(film.count[p]);
        const uint64_t rays_before = stats.rays();
        const AovLayout& layout = film.aov_layout;
        double* aov_entry = layout.stride > 0 ? &film.aov[p * size_t(layout.stride)] : nullptr;
        const bool split = !film.sum_odd.empty();
        glm::dvec3 odd = split ? film.sum_odd[p] : glm::dvec3(0.0);
        glm::dvec3 seen = split ? film.seen[p] : glm::dvec3(0.0), seen_odd = split ? film.seen_odd[p] : glm::dvec3(0.0);
        SampleAovs aovs;  // cleared per sample only where the film keeps AOVs
        for (; s < target; ++s) {
            if (halves && (s & (s - 1)) == 0) {  // s a power of two: the first s samples are a net
                eighth = quarter;
                quarter = half;
                half = sum;
            }
            // Split halves: even and odd samples are two sequences of their own, scrambled apart.
            Sampler rng = split ? Sampler(settings_.sampler, settings_.seed, pixel | (uint64_t(s & 1) << 62), uint64_t(s >> 1))
                                : Sampler(settings_.sampler, settings_.seed, pixel, uint64_t(s));
            const glm::vec2 j = rng.next_2d();
            const float jx = j.y, jy = j.x;  // independent: the first number drawn goes to x, as it always did
            const float u = (float(x) + jx) * inv_w, v = 1.f - (float(y) + jy) * inv_h;
            Ray ray;
            // Within a shutter the sample draws its time (a still draws none, so its numbers
            // and image stay what they were), and the camera is where that time puts it.
            const float time = motion_ ? rng.next_float() : 0.f;
            const Camera& cam = moving_camera_ ? (moved_ = camera_at(camera_, camera_close_, time)) : camera_;
            if (cam.lens_radius > 0.f) {
                const glm::vec2 l = rng.next_2d();
                ray = generate_ray(cam, u, v, sample_concentric_disk(l.x, l.y));
            } else {
                ray = generate_ray(cam, u, v);  // a pinhole draws no lens sample
            }
            ray.time = time;
            ++stats.camera_rays;
            if (aov_entry) aovs = SampleAovs{};
            glm::vec3 L = integrator_.radiance(ray, rng, aov_entry ? &aovs : nullptr);
            if (!(std::isfinite(L.x) && std::isfinite(L.y) && std::isfinite(L.z))) {
                ++stats.nonfinite_samples;
                L = glm::vec3(0.f);
                // The light split of a dropped sample is dropped with it: the split sums to the image.
                aovs.emission = aovs.environment = aovs.diffuse_direct = aovs.diffuse_indirect = aovs.glossy_direct =
                    aovs.glossy_indirect = glm::vec3(0.f);
            }
            if (seen_) {  // every sample, dropped ones too: the corrections' mean is zero only over all of them
                const glm::vec3 c = seen_->correction(x, y, ray);
                L += c;
                if (aov_entry) aovs.emission += c;  // the light seen directly, so the split still sums to L
            }
            if (aov_entry) add_sample_aovs(layout, aov_entry, aovs, L, s == 0);
            sum += glm::dvec3(L);
            if (split) {
                const glm::dvec3 e = glm::dvec3(aovs.emission) + glm::dvec3(aovs.environment);
                seen += e;
                if (s & 1) {
                    odd += glm::dvec3(L);
                    seen_odd += e;
                }
            }
            stats.max_sample = std::max(stats.max_sample, illuminance(L));
            if (adaptive) film.stats[p].add(illuminance(L));
        }
        if (!film.rays.empty()) film.rays[p] += float(stats.rays() - rays_before);
        stats.samples += uint64_t(s) - film.count[p];
        film.sum[p] = sum;
        if (halves) {
            film.sum_half[p] = half;
            film.sum_quarter[p] = quarter;
            film.sum_eighth[p] = eighth;
        }
        film.count[p] = uint32_t(s);
        if (split) {
            film.sum_odd[p] = odd;
            film.seen[p] = seen;
            film.seen_odd[p] = seen_odd;
        }
        if (adaptive && (s >= settings_.spp || film.stats[p].converged(settings_.adaptive->tolerance))) film.done[p] = 1;
    }

    RenderStats stats;

private:
    const RenderSettings& settings_;
    const Camera& camera_;
    IntegratorDispatch integrator_;
    bool motion_ = false;         // the scene moves within a shutter: each sample draws a time
    bool moving_camera_ = false;  // ... and the camera moves to camera_close_
    Camera camera_close_;
    Camera moved_;                // the camera at this sample's time
    const SeenEmitters* seen_ = nullptr;
};

}  // namespace tessera
