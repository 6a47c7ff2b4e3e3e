#pragma once
// A denoiser whose error is estimated from the render's own data.
//
// Filter: candidates of two kinds, chosen per pixel by their estimated error.
// - First-order regression of the pixel colour on its features (shading normal, depth, screen
//   position) over a window, as NFOR does (Bitterli et al. 2016, "Nonlinearly Weighted
//   First-order Regression for Denoising Monte Carlo Renderings"), with the window's pixels
//   weighted equally as in guided image filtering (He et al. 2013), which Bauszat et al. (2011)
//   applied to path tracing: the regression's sums are box sums, so a window of any size costs the
//   same per pixel. Edges the features see (silhouettes, creases) stay hard because a linear
//   model fits each side of them.
// - NL-means (Rousselle, Knaus and Zwicker 2012) over a small window, each half weighted by the
//   other half's colour (NFOR's cross-filtering) and by geometry: it keeps what the features do
//   not explain, shadows and highlights.
// Texture survives because the colour is divided by the albedo first and multiplied back after
// (albedo demodulation). Light seen directly (lamps, the environment) is taken out before and
// added back after, so glare never spreads to a neighbour; pixels that saw no surface are left
// as they are.
//
// Two independent halves: a denoising render draws its even and odd samples from two scrambles
// of their own (tile_context.h), so the halves A and B are independent estimates of the pixel,
// each stratified in itself. (The prefix halves of the error estimate are not: one Sobol net split
// in two, their difference overstates the error by a factor that has to be estimated;
// convergence.h.) Every candidate filters A and B apart, and its output is their mean.
//
// Error: cross-validation between independent halves gives each candidate's error with nothing
// to calibrate, MSE = [(f(A) − B)² + (f(B) − A)²]/2 − (A − B)²/2 − (f(A) − f(B))²/4, but per
// pixel that is about (A − μ)(B − μ), whose heavy tail (a firefly in one half) swamps a strong
// filter's small error. So it gives only the smallest window's bias, pooled over a wide
// neighbourhood; the variance of a candidate is (f(A) − f(B))²/4, and its bias beyond the
// smallest window's comes from the difference of their outputs less that difference's variance
// (both filtered, so little noise). Bias estimates are pooled and then held at zero or more.
// Each pixel takes the candidate of least estimated error pooled over its neighbourhood; the
// denoised image's error estimate is the chosen candidates', relative as the convergence curve's
// relMSE is. docs/denoising.md has the figures.
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "engine/render/image.h"

namespace tessera {

struct Film;

// The denoiser's working memory per pixel at its peak, counted from denoise.cpp's buffers: the
// resolved features (28 bytes), its inputs (61), the halves and the light they saw (52), four
// candidates' halves (96), the NL-means guide (28), the error maps (88) and the image (16), with
// room to spare (the pooling's temporaries, 36, live after the NL-means guide is gone). A job's memory bound (Film::bytes_per_pixel) counts it.
inline constexpr size_t kDenoiseBytesPerPixel = 400;

// Candidate windows (radius in pixels): 0 is the noisy pixel itself, a positive radius a
// regression's box, a negative one NL-means' window (the last).
inline constexpr std::array<int, 4> kDenoiseRadii{0, 2, 4, -4};
static_assert(kDenoiseRadii.front() == 0 && kDenoiseRadii.back() < 0);

struct Denoised {
    Image image;               // sample counts as the film's
    double est_rel_mse = -1;        // estimate of the denoised image's relMSE (ε = 0.01)
    double noisy_est_rel_mse = -1;  // the noisy image's, from its halves
    double seconds = 0;
    std::array<double, kDenoiseRadii.size()> share{};  // fraction of pixels that took each candidate
};

// Each candidate's output and the candidate each pixel took: what a benchmark needs to measure
// the choice against the truth (`tessera bench denoise --candidates`). Costs memory only when
// asked for.
struct DenoiseCandidates {
    std::array<std::vector<float>, kDenoiseRadii.size()> rgb;  // 3 per pixel, the halves mixed
    std::vector<uint8_t> taken;                               // per pixel, an index into kDenoiseRadii
};

// Whether a film carries what the denoiser reads: its odd samples apart (kSplitHalves) and the
// albedo, normal and depth AOVs.
bool can_denoise(const Film& film);
// Nothing when a pixel has fewer than two samples (no variance to go by) or the film lacks what
// can_denoise asks. The result does not depend on `threads`.
std::optional<Denoised> denoise(const Film& film, int threads = 0, DenoiseCandidates* candidates = nullptr);

}  // namespace tessera
