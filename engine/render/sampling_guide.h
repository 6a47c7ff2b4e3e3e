#pragma once
// Guided sampling for a denoising render: after each pass, the next pass's samples go where the
// denoised image's estimated error is (Rousselle, Knaus and Zwicker 2012, "Adaptive Rendering with
// Non-Local Means Filtering"), not evenly. The denoiser keeps smooth regions at a small error
// with few samples; what it cannot lower (a silhouette's coverage, a lamp's rim, detail no
// feature explains) only samples lower, and those pixels are a few in a hundred.
//
// The rule: a pixel's error falls about as 1/n with its samples n, so an image's error
// Σ e_p n_p / n'_p is least for a total time Σ c_p n'_p, c_p the cost of one of the pixel's
// samples, when n'_p ∝ √(e_p n_p / c_p) (Lagrange), with no pixel losing the samples it has
// (water-filling) and none above `cap`. The cost is the rays the pixel's samples traced (the
// film's): a pixel of the sky costs one, one deep in a box many; weighing it gave 3-14 % less
// time to the same error than counting samples alone (docs/denoising.md). The error map is widened
// first (a neighbourhood's mean, then its maximum): a rim pixel whose samples all missed the lamp
// beside it cannot see its own error, its neighbours can.
#include <cstdint>
#include <vector>

namespace tessera {

struct Film;

// Each pixel's sample target for a pass that takes the film's mean to `mean_target` samples,
// from the denoiser's per-pixel error estimate (Denoised::error) and the film's rays (a film
// without them: every sample costs the same). Each target adds an even number of samples to
// the pixel's count (the film's two halves stay equal) and is at most `cap`; their mean is
// `mean_target` up to that rounding (below it only where the cap binds everywhere). No pixel's
// error counts as zero (a thousandth of the mean at least), so none stops being sampled.
// Depends on nothing but its arguments (a farm's coordinator computes the same targets as one
// process).
std::vector<uint32_t> guided_targets(const Film& film, const std::vector<float>& error, int mean_target, int cap);

}  // namespace tessera
