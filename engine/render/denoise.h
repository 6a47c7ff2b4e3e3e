#pragma once
// A denoiser whose error is estimated from the render's own data.
//
// Filter: first-order regression of the pixel colour on its features (albedo, shading normal,
// depth) over a window, as NFOR does (Bitterli et al. 2016, "Nonlinearly Weighted First-order
// Regression for Denoising Monte Carlo Renderings"), with the window's pixels weighted equally
// as in guided image filtering (He et al. 2013), which Bauszat et al. (2011) applied to path
// tracing. Uniform weights make the regression's sums box sums, so a window of any size costs the
// same per pixel: several window sizes fit in the 2 s per megapixel budget, where NFOR's
// per-neighbour NL-means weights take minutes. Edges the features see (silhouettes, creases,
// albedo boundaries) survive because a linear model in the features fits each side of them;
// texture survives because the colour is divided by the albedo first and multiplied back after
// (albedo demodulation).
//
// Two independent halves: a denoising render draws its even and odd samples from two scrambles
// of their own (tile_context.h), so the halves A and B are independent estimates of the pixel,
// each stratified in itself. (The prefix halves of the error estimate are not: one Sobol net split
// in two, their difference overstates the error by a factor that has to be estimated;
// convergence.h.) The regression is linear in the colour, so each candidate filters A and B apart
// with the same weights, and its output is their mean.
//
// Error: the candidates are no filter and windows of three sizes. Cross-validation between
// independent halves gives each one's error with nothing to calibrate,
// MSE = [(f(A) − B)² + (f(B) − A)²]/2 − (A − B)²/2 − (f(A) − f(B))²/4, but per pixel that is
// about (A − μ)(B − μ), whose heavy tail (a firefly in one half) swamps a strong filter's small
// error. So it gives only the smallest window's bias, pooled over a wide neighbourhood; the
// variance of a candidate is (f(A) − f(B))²/4, and its bias beyond the smallest window's comes
// from the difference of their outputs less that difference's variance (both filtered, so
// little noise). Bias estimates are pooled and then held at zero or more, which errs high when
// the noise is large (at a few samples per pixel). Each pixel takes the candidate of least
// estimated error pooled over its neighbourhood; the denoised image's error estimate is the
// chosen candidates', relative as the convergence curve's relMSE is (against the widest
// window's image, the smoothest stand-in for the truth). docs/denoising.md has the figures.
#include <array>
#include <optional>
#include <string>

#include "engine/render/image.h"

namespace tessera {

struct Film;

// Candidate windows (radius in pixels); 0 is the noisy pixel itself.
inline constexpr std::array<int, 4> kDenoiseRadii{0, 3, 7, 15};

struct Denoised {
    Image image;               // sample counts as the film's
    double est_rel_mse = -1;        // estimate of the denoised image's relMSE (ε = 0.01)
    double noisy_est_rel_mse = -1;  // the noisy image's, from its halves
    double seconds = 0;
    std::array<double, kDenoiseRadii.size()> share{};  // fraction of pixels that took each candidate
};

// Whether a film carries what the denoiser reads: its odd samples apart (kSplitHalves) and the
// albedo, normal and depth AOVs.
bool can_denoise(const Film& film);
// Nothing when a pixel has fewer than two samples (no variance to go by) or the film lacks what
// can_denoise asks. The result does not depend on `threads`.
std::optional<Denoised> denoise(const Film& film, int threads = 0);

}  // namespace tessera
