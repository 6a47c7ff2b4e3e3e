#pragma once
// Error against run time: one point after each rendering pass, measured against a reference
// image when there is one, and estimated from the two half-sample buffers either way.
#include <cstdint>
#include <string>
#include <vector>

namespace tessera {

// The square of a pixel's truth, from two independent halves a and b of its samples, is taken as
// their product (unbiased, where the mean's square is too large by the mean's variance) but no
// less than this share of the mean's square: where one half saw a lamp's or the sky's edge and
// the other did not, the product is near zero and the relative error it divides would be
// enormous. Measured (`tessera bench denoise -r 160 120 --ref-spp 2048`, 4-256 spp): the floor
// at 1/16 put the lamp room's estimate at 3.9× the truth at 4 spp, 1 (the mean's square alone)
// the Duck's at 0.44×; at 1/2 the denoised image's estimate lies within 0.55-1.33× on every
// scene. (A glossy box's noisy estimate stays low at 4-16 spp, 0.33-0.46: a firefly, relative to
// its own brightness, looks small.)
inline constexpr double kHalvesProductFloor = 0.5;

struct Film;
struct Image;

struct ConvergencePoint {
    double seconds = 0;      // since the render started
    double spp_mean = 0;     // samples per pixel so far
    // Against the reference (negative when there is none): relMSE = mean (x−r)²/(r²+ε), ε = 0.01.
    double rel_mse = -1, mse = -1, mae = -1;
    // Estimated without a reference, per pixel and channel from prefix sums of its c samples:
    // A, the mean of its first h (h the largest power of two below c), and B, of the rest.
    // ((A−B)² h(c−h)/c²)/(x²+ε) is the variance of the mean of c independent samples (Dammertz
    // et al. 2010 and Cycles use two such buffers). Sobol points are not independent: A and B
    // are both scrambled nets, and for error falling as N^-α the difference of two halves
    // overstates the error of the whole by (2^α − 1) (Var(A−B)/4 = V(c/2) − V(c)). The same
    // difference two levels down (the first h/4 samples against the next h/4) measures α from
    // the image's own samples, and the estimate is divided by the factor it gives. Two levels,
    // not one: a 2-D net of 2^k points stratifies better for even k than for odd, and the ratio
    // of neighbouring levels swings with it (measured: estimates 0.44-1.9x the true error at
    // 4-32 spp on the Cornell box, against 0.8-1.3x two levels apart). α is held to [1, 3]:
    // independent samples give α = 1 and no change, smooth 2-D integrands Owen scrambling's N^-3.
    double est_rel_mse = -1;
    // The denoised image's (engine/render/denoise.h), when the render denoises: against the
    // reference, and estimated from its two independent halves (denoise.h).
    double denoised_rel_mse = -1, denoised_est_rel_mse = -1;
    double denoise_seconds = 0;
};

enum class StopReason { spp, converged, time_limit, target_error, canceled };
const char* to_string(StopReason r);

struct ConvergenceCurve {
    std::vector<ConvergencePoint> points;
    StopReason stop = StopReason::spp;
};

// The sums behind a ConvergencePoint: they add up over tiles, so a render farm's nodes each
// measure their own tiles and the point of the whole image is their sum (in another order than
// one process's, so equal to the last few bits).
struct ErrorSums {
    double spp = 0, est = 0, rel = 0, mse = 0, mae = 0;
    // Pixels with at least 5 samples (deep) or 3 to 4 (shallow): the estimate at their count
    // (outer), at h/2 (deep) or h (shallow), and the sums of log(c/h), which give α.
    double deep_outer = 0, deep = 0, deep_log_split = 0, shallow_outer = 0, shallow = 0, shallow_log_split = 0;
    uint64_t pixels = 0, est_pixels = 0, deep_pixels = 0, shallow_pixels = 0;
    bool half_buffer = false, reference = false;
    void add(const ErrorSums& other);
    ConvergencePoint point() const;  // without its time
};
// Of a film covering the image or one tile of it (`reference` covers the whole image).
ErrorSums error_sums(const Film& film, const Image* reference);

// relMSE of `image` against `reference` (same size), as ConvergencePoint::rel_mse defines it.
double relative_mse(const Image& image, const Image& reference);

// How much the halves' difference overstates the error when the error falls as N^-α, for
// halves of h and c − h samples (c/h = split): 1 at α = 1, 1/(2^α − 1) at split 2.
double stratification_factor(double alpha, double split);
// α from the ratio of an inner estimate `levels` halvings down to the outer one
// (ConvergencePoint), held to [1, 3].
double convergence_order(double inner_over_outer, double split, int levels);

// The error of the film so far, by the definitions above: the half-buffer estimate when the
// film keeps the prefix sums, and the error against `reference` when given (same size).
ConvergencePoint measure_error(const Film& film, const Image* reference);

// CSV with a header line; empty fields where a value is not measured.
std::string convergence_csv(const ConvergenceCurve& c);
// A log–log plot (time on x, relative MSE on y), with axes, units and legend; one curve per
// entry of `curves`, labelled by `labels`.
std::string convergence_svg(const std::vector<ConvergenceCurve>& curves, const std::vector<std::string>& labels,
                            const std::string& title);

}  // namespace tessera
