#pragma once
// Per-pixel accumulation across rendering passes. Only the buffers a render needs exist: the
// prefix sums of the error estimate only when the error is estimated, the running statistics only for
// adaptive sampling.
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "engine/core/large_vector.h"
#include "engine/render/aov.h"
#include "engine/render/denoise.h"
#include "engine/render/image.h"

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

struct Film {
    int width = 0, height = 0;
    int x0 = 0, y0 = 0;                // the image pixel at the film's corner (a tile's film)
    std::vector<glm::dvec3> sum;       // all samples
    // Error estimate only: the sums of the pixel's first h, h/2 and h/4 samples, h the largest
    // power of two below its count (see convergence.h). They depend only on the count, never on
    // how passes, tiles or nodes split the samples.
    std::vector<glm::dvec3> sum_half, sum_quarter, sum_eighth;
    // A denoising render's: the sum of its odd samples (1, 3, 5, …), drawn from a scramble of
    // their own, so that even and odd samples are two independent estimates (denoise.h).
    std::vector<glm::dvec3> sum_odd;
    // ... and of the light its samples saw directly (emitters, the environment), all and odd: the
    // denoiser filters the rest and adds this back, so a lamp's glare never spreads to the wall
    // beside it (features do not tell a lamp from the ceiling it hangs in).
    std::vector<glm::dvec3> seen, seen_odd;
    std::vector<uint32_t> count;       // samples taken
    // Guided sampling (sampling_guide.h): each pixel's sample target in this pass; empty, the
    // pass's own target for every pixel.
    std::vector<uint32_t> goal;
    // A denoising render's: the rays its samples traced, per pixel, so that guided sampling
    // weighs what a pixel's samples cost against the error they remove.
    std::vector<float> rays;
    std::vector<RunningStats> stats;   // illuminance statistics (adaptive only)
    std::vector<uint8_t> done;         // adaptive: converged
    // The AOVs a render asked for (and the denoiser reads): layout.stride doubles per pixel.
    AovLayout aov_layout;
    std::vector<double> aov;

    Film(int w, int h, bool half_buffer, bool adaptive, AovSet aovs = 0) : width(w), height(h), aov_layout(aovs) {
        // In huge pages: a denoising film of 640×480 is 70 MB, and faulted in 4 KiB at a time it
        // took 0.19 s of a 32-spp render of 4.8 s before its first sample.
        const size_t n = size_t(w) * h;
        assign_huge(sum, n, glm::dvec3(0.0));
        assign_huge(count, n, 0u);
        if (aovs & kSplitHalves) {
            assign_huge(sum_odd, n, glm::dvec3(0.0));
            assign_huge(seen, n, glm::dvec3(0.0));
            assign_huge(seen_odd, n, glm::dvec3(0.0));
            assign_huge(rays, n, 0.f);
        }
        if (aov_layout.stride > 0) {
            assign_huge(aov, n * size_t(aov_layout.stride), 0.0);
            for (size_t p = 0; p < n; ++p) clear_aovs(aov_layout, &aov[p * size_t(aov_layout.stride)]);
        }
        if (half_buffer) {
            assign_huge(sum_half, n, glm::dvec3(0.0));
            assign_huge(sum_quarter, n, glm::dvec3(0.0));
            assign_huge(sum_eighth, n, glm::dvec3(0.0));
        }
        if (adaptive) { stats.resize(n); done.assign(n, 0); }
    }
    // What a film keeps per pixel (bytes), and the denoiser's working memory besides: a job's
    // memory is bounded by it before anything is allocated.
    static size_t bytes_per_pixel(bool half_buffer, bool adaptive, AovSet aovs) {
        size_t b = sizeof(glm::dvec3) + sizeof(uint32_t);
        if (half_buffer) b += 3 * sizeof(glm::dvec3);
        if (adaptive) b += sizeof(RunningStats) + 1;
        // The odd and seen sums, the rays traced and guided sampling's targets, the denoiser's own.
        if (aovs & kSplitHalves) b += 3 * sizeof(glm::dvec3) + sizeof(float) + sizeof(uint32_t) + kDenoiseBytesPerPixel;
        return b + size_t(AovLayout(aovs).stride) * sizeof(double);
    }
    // A film of one tile's pixels, for a render node that renders one tile at a time.
    static Film tile(int x0, int y0, int w, int h, bool half_buffer, bool adaptive, AovSet aovs = 0) {
        Film f(w, h, half_buffer, adaptive, aovs);
        f.x0 = x0;
        f.y0 = y0;
        return f;
    }
    void describe(std::vector<std::string>& built, std::vector<std::string>& left_out) const {
        built.push_back("film: sum and sample count per pixel");
        (sum_half.empty() ? left_out : built).push_back("half-sample buffers (error estimate)");
        if (!sum_odd.empty()) built.push_back("odd samples apart, from an independent scramble (the denoiser's two halves)");
        (stats.empty() ? left_out : built).push_back("per-pixel variance statistics (adaptive sampling)");
        if (aov_layout.stride > 0) {
            std::string names;
            for (const std::string& n : aov_names(aov_layout.set)) names += (names.empty() ? "" : ", ") + n;
            built.push_back("AOVs: " + names);
        } else {
            left_out.push_back("AOVs (none asked for)");
        }
    }
    // The AOVs of `which` (kept ones only) as planes of floats, resolved from their sums.
    std::vector<AovPlane> resolve_aovs(AovSet which) const;
    // One AOV the film keeps (std::logic_error for one it does not), resolved into out (its
    // components per pixel, row by row).
    void resolve_aov(Aov a, float* out) const;
    Image resolve() const {
        Image img(width, height);
        resolve_into(img);
        return img;
    }
    // Into an image of this size kept from an earlier call: no new memory (whose first touch
    // costs more than the copy on a VM), for a server that shows every pass.
    void resolve_into(Image& img) const {
        if (img.width != width || img.height != height) img = Image(width, height);
        for (size_t i = 0; i < sum.size(); ++i) {
            const double inv = count[i] ? 1.0 / double(count[i]) : 0.0;
            img.rgb[i * 3 + 0] = float(sum[i].x * inv);
            img.rgb[i * 3 + 1] = float(sum[i].y * inv);
            img.rgb[i * 3 + 2] = float(sum[i].z * inv);
            img.sample_count[i] = float(count[i]);
        }
    }
};

}  // namespace tessera
