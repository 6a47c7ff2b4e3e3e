#pragma once
// One worker's state while it renders tiles: its statistics and the per-pixel sample loop
// (uniform or adaptive). Nothing here is shared between threads.
#include <cmath>

#include "engine/render/image.h"
#include "engine/render/renderer.h"
#include "engine/render/integrators.h"
#include "engine/render/render_settings.h"
#include "engine/sampling/rng.h"

namespace tessera {


// Welford's online mean and variance: numerically stable where S2 − S1²/n cancels to noise.
struct RunningStats {
    uint64_t n = 0;
    double mean = 0.0;
    double m2 = 0.0;
    void add(double x) {
        ++n;
        const double d = x - mean;
        mean += d / double(n);
        m2 += d * (x - mean);
    }
    double variance() const { return n > 1 ? m2 / double(n - 1) : 0.0; }
    // CS184's test, 1.96·σ/√n ≤ tolerance·μ, written without a division so that μ = 0 and
    // σ = 0 both end sampling without producing NaN.
    bool converged(double tolerance) const {
        if (n < 2) return false;
        return 1.96 * std::sqrt(variance() / double(n)) <= tolerance * mean;
    }
};

inline float illuminance(const glm::vec3& c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

class TileContext {
public:
    TileContext(const RenderScene& scene, const RenderSettings& settings, const Camera& camera)
        : scene_(scene), settings_(settings), camera_(camera), integrator_(scene, settings, stats) {}

    void render_pixel(int x, int y, Image& image) {
        const uint64_t pixel = uint64_t(y) * uint64_t(settings_.width) + uint64_t(x);
        const float inv_w = 1.f / float(settings_.width), inv_h = 1.f / float(settings_.height);
        glm::dvec3 sum(0.0);
        RunningStats running;
        const bool adaptive = settings_.adaptive.has_value();
        const int batch = adaptive ? std::max(1, settings_.adaptive->batch) : settings_.spp;
        int s = 0;
        while (s < settings_.spp) {
            const int batch_end = std::min(settings_.spp, s + batch);
            for (; s < batch_end; ++s) {
                Pcg32 rng = sample_rng(settings_.seed, pixel, uint64_t(s));
                const float jx = rng.next_float(), jy = rng.next_float();
                Ray ray = generate_ray(camera_, (float(x) + jx) * inv_w, 1.f - (float(y) + jy) * inv_h);
                ++stats.camera_rays;
                glm::vec3 L = integrator_.radiance(ray, rng);
                if (!(std::isfinite(L.x) && std::isfinite(L.y) && std::isfinite(L.z))) {
                    ++stats.nonfinite_samples;
                    L = glm::vec3(0.f);
                }
                sum += glm::dvec3(L);
                if (adaptive) running.add(illuminance(L));
            }
            if (adaptive && running.converged(settings_.adaptive->tolerance)) break;
        }
        stats.samples += uint64_t(s);
        const double inv_n = s > 0 ? 1.0 / double(s) : 0.0;
        float* out = image.pixel(x, y);
        out[0] = float(sum.x * inv_n);
        out[1] = float(sum.y * inv_n);
        out[2] = float(sum.z * inv_n);
        image.sample_count[pixel] = float(s);
    }

    RenderStats stats;

private:
    const RenderScene& scene_;
    const RenderSettings& settings_;
    const Camera& camera_;
    IntegratorDispatch integrator_;
};

}  // namespace tessera
