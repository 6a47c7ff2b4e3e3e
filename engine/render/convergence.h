#pragma once
// Error against run time: one point after each rendering pass, measured against a reference
// image when there is one, and estimated from the two half-sample buffers either way.
#include <cstdint>
#include <string>
#include <vector>

namespace tessera {

struct Film;
struct Image;

struct ConvergencePoint {
    double seconds = 0;      // since the render started
    double spp_mean = 0;     // samples per pixel so far
    // Against the reference (negative when there is none): relMSE = mean (x−r)²/(r²+ε), ε = 0.01.
    double rel_mse = -1, mse = -1, mae = -1;
    // Estimated without a reference: mean over pixels and channels of ((A−B)²/4)/(x²+ε), A and B
    // the means of the even- and odd-numbered samples (their difference measures the noise of
    // the full mean; Dammertz et al. 2010 and Cycles use the same two-buffer idea).
    double est_rel_mse = -1;
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
    uint64_t pixels = 0, est_pixels = 0;
    bool half_buffer = false, reference = false;
    void add(const ErrorSums& other);
    ConvergencePoint point() const;  // without its time
};
// Of a film covering the image or one tile of it (`reference` covers the whole image).
ErrorSums error_sums(const Film& film, const Image* reference);

// The error of the film so far, by the definitions above: the half-buffer estimate when the
// film keeps the odd samples, and the error against `reference` when given (same size).
ConvergencePoint measure_error(const Film& film, const Image* reference);

// CSV with a header line; empty fields where a value is not measured.
std::string convergence_csv(const ConvergenceCurve& c);
// A log–log plot (time on x, relative MSE on y), with axes, units and legend; one curve per
// entry of `curves`, labelled by `labels`.
std::string convergence_svg(const std::vector<ConvergenceCurve>& curves, const std::vector<std::string>& labels,
                            const std::string& title);

}  // namespace tessera
