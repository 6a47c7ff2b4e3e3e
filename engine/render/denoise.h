#pragma once
// A denoiser whose error is estimated from the render's own data.
//
// Filter: candidates of three kinds, blended per pixel by their estimated error.
// - NFOR's own: first-order regression of the colour on the pixel's place, each neighbour
//   weighted by NL-means (below) as Bitterli et al. (2016) weight theirs: the weights keep a
//   window to one surface and one side of a shadow, the first order keeps a gradient that a
//   one-sided window would otherwise flatten (the zero-order mean's bias at every edge).
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
// filter's small error. So it gives only the first filter's bias, pooled over a wide
// neighbourhood; the variance of a candidate is (f(A) − f(B))²/4, or for the NL-means pair,
// whose halves covary through their weights and read it low, the variance those weights give
// where that is more (weighted least squares' sandwich estimator), and its bias beyond the
// first filter's comes from the difference of their outputs less that difference's variance
// (both filtered, so little noise). Bias estimates are pooled and then held at zero or more.
// Each pixel is led by the candidate of least estimated error pooled over its neighbourhood and
// blends in the noisy pixel and the others not refused there, each weighed by the inverse square
// of its estimate; the blend's error estimate is its own halves' variance (or (Σ w_c σ_c)² from
// its candidates' where more) plus the weighted mean of their bias, relative as the convergence
// curve's relMSE is. docs/denoising.md has the figures.
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "engine/render/image.h"

namespace tessera {

struct Film;
class BlockPool;

// The denoiser's working memory per pixel at its peak, counted from denoise.cpp's buffers: the
// resolved features and the samples' spread (40 bytes), its inputs (61), the halves and the
// light they saw (52), four candidates' halves (96), the NL-means pair's variance as their
// weights give it (24), the error maps (108, the candidates' bias among them, which the blend's
// estimate reads), the spread relative two ways and the noise
// around (20), the image (16), its per-pixel error (4) and that error in double with the blend's
// leader, summed in pixel order after the threads (9): 430, with the poolings' (32: the kinds'
// shares at three radii, the row sums they share, a pooled map). Before them, NL-means' planes
// (84) and sums (a row per band) have come and gone. Then, all of that still held, the light seen
// directly filtered per half (24; its guides, 28, come and go before) and its blend's maps (its
// own, the filtered one's variance and bias, each pooled, whether it moved, one kind for every
// pixel: 26) with two more poolings' shares (8), all at most the whole image: 520.
// A render keeps them from one pass to the next (its BlockPool): while it renders, one call's
// maps, as idle blocks; while it denoises, the blocks in use and those of the last call not yet
// taken again, which are only the seen light's maps (86, over the box of its noisy pixels,
// whose size changes from pass to pass): 606, each map's block rounded up to a huge page (2 MiB)
// beside it. A job's memory bound (Film::bytes_per_pixel) counts it.
inline constexpr size_t kDenoiseBytesPerPixel = 614;

// The candidates each pixel chooses from. The noisy pixel is the first; the first filter is the
// one whose bias the others' is measured beyond (denoise.cpp); NL-means is the last (the
// stand-in for the truth in relative errors).
enum class DenoiseFilter : uint8_t { noisy, nlm_regression, box_regression, nlm };
struct DenoiseCandidate {
    DenoiseFilter filter;
    int radius;        // of the window, in pixels
    const char* name;  // in `tessera bench denoise --candidates`
};
inline constexpr std::array<DenoiseCandidate, 4> kDenoiseCandidates{{
    {DenoiseFilter::noisy, 0, "noisy"},
    {DenoiseFilter::nlm_regression, 4, "NL-means regression r4"},
    {DenoiseFilter::box_regression, 2, "box regression r2"},
    {DenoiseFilter::nlm, 4, "NL-means r4"},
}};
static_assert(kDenoiseCandidates.front().filter == DenoiseFilter::noisy && kDenoiseCandidates.back().filter == DenoiseFilter::nlm);
static_assert(kDenoiseCandidates[1].radius == kDenoiseCandidates.back().radius, "the NL-means pair shares its weights");

struct Denoised {
    Image image;               // sample counts as the film's
    double est_rel_mse = -1;        // estimate of the denoised image's relMSE (ε = 0.01)
    double noisy_est_rel_mse = -1;  // the noisy image's, from its halves
    double seconds = 0;
    std::array<double, kDenoiseCandidates.size()> share{};  // fraction of pixels whose blend each candidate leads
    // Per pixel, the estimate of its relative squared error (the mean of which is est_rel_mse):
    // what guided sampling spends the next pass's samples by (sampling_guide.h).
    std::vector<float> error;
};

// Each candidate's output and the candidate each pixel took: what a benchmark needs to measure
// the choice against the truth (`tessera bench denoise --candidates`). Costs memory only when
// asked for.
struct DenoiseCandidates {
    std::array<std::vector<float>, kDenoiseCandidates.size()> rgb;  // 3 per pixel, the halves mixed
    std::vector<uint8_t> taken;                               // per pixel, the candidate leading its blend
    std::vector<float> weight;  // per pixel, each candidate's share of the blend (kDenoiseCandidates.size() each)
    // 3 per pixel, half the gap between the candidate's two filtered halves, (f(A) − f(B))/2: its
    // square is an estimate of the candidate's variance, which its true error less it leaves as
    // bias. A cross-filtered candidate's reads low by the covariance its weights give its halves
    // (docs/denoising.md, "Where the error is").
    std::array<std::vector<float>, kDenoiseCandidates.size()> half_gap;
    // 3 per pixel, the variance the choice and the estimate take for the candidate: the square of
    // half_gap, or for the NL-means pair where it is more, the variance their weights give
    // (denoise.cpp, filter_nlm). Pixels no candidate may touch: half_gap's square.
    std::array<std::vector<float>, kDenoiseCandidates.size()> variance;
    // 3 per pixel, what the blend of the light seen directly with its own NL-means moved the
    // pixel by, after the candidates' blend (denoise.cpp, filter_seen): the image is the
    // candidates' blend plus it.
    std::vector<float> seen_shift;
};

// Whether a film carries what the denoiser reads: its odd samples apart (kSplitHalves) and the
// albedo, normal and depth AOVs.
bool can_denoise(const Film& film);
// Nothing when a pixel has fewer than two samples (no variance to go by) or the film lacks what
// can_denoise asks. The result does not depend on `threads`. `memory`, kept by a render between
// its passes, lends the denoiser its maps again instead of fresh pages each pass (block_pool.h);
// it holds at most one call's maps between calls, which kDenoiseBytesPerPixel counts.
std::optional<Denoised> denoise(const Film& film, int threads = 0, DenoiseCandidates* candidates = nullptr,
                                BlockPool* memory = nullptr);

}  // namespace tessera
