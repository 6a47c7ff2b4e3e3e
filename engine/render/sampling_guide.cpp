#include "engine/render/sampling_guide.h"

#include <algorithm>
#include <cmath>

#include "engine/render/film.h"

namespace tessera {

namespace {

// A pixel's error is held at no less than this share of the image's mean (see below).
constexpr double kErrorFloor = 1e-3;

// The mean over a (2r+1)² window, then the maximum over 3×3: noise in one pixel's estimate
// averages out, and an edge's error reaches both of its sides.
std::vector<double> widened(const std::vector<float>& e, int W, int H) {
    const size_t n = size_t(W) * H;
    std::vector<double> mean(n), out(n);
    constexpr int r = 1;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            double s = 0;
            int k = 0;
            for (int yy = std::max(0, y - r); yy <= std::min(H - 1, y + r); ++yy)
                for (int xx = std::max(0, x - r); xx <= std::min(W - 1, x + r); ++xx, ++k) {
                    const double v = e[size_t(yy) * W + xx];
                    s += std::isfinite(v) && v > 0 ? v : 0.0;
                }
            mean[size_t(y) * W + x] = s / k;
        }
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            double m = 0;
            for (int yy = std::max(0, y - 1); yy <= std::min(H - 1, y + 1); ++yy)
                for (int xx = std::max(0, x - 1); xx <= std::min(W - 1, x + 1); ++xx) m = std::max(m, mean[size_t(yy) * W + xx]);
            out[size_t(y) * W + x] = m;
        }
    return out;
}

}  // namespace

std::vector<uint32_t> guided_targets(const Film& film, const std::vector<float>& error, int mean_target, int cap) {
    const int W = film.width, H = film.height;
    const size_t n = size_t(W) * H;
    std::vector<uint32_t> goal(film.count.begin(), film.count.end());
    if (n == 0 || error.size() != n) return goal;
    std::vector<double> e = widened(error, W, H);
    // No pixel's error is taken for exactly zero (all its samples alike so far, such as a dim
    // corner no path has lit yet): a trickle keeps sampling it, and the pass spends its budget.
    double mean_e = 0;
    for (double v : e) mean_e += v;
    mean_e /= double(n);
    for (double& v : e) v = std::max(v, kErrorFloor * mean_e);
    std::vector<double> w(n);
    double have = 0, wsum = 0;
    for (size_t p = 0; p < n; ++p) {
        const double cost = film.rays.empty() || film.count[p] == 0 ? 1.0 : std::max(1.0, double(film.rays[p]) / film.count[p]);
        w[p] = std::sqrt(e[p] * double(film.count[p]) / cost);
        have += film.count[p];
        wsum += w[p];
    }
    const double total = double(mean_target) * double(n);
    const double top = double(std::max(cap, 2));
    auto spent = [&](double lambda) {
        double s = 0;
        for (size_t p = 0; p < n; ++p) s += std::max(double(film.count[p]), std::min(top, lambda * w[p]));
        return s;
    };
    if (!(wsum > 0) || total <= have) {  // nothing to go by: evenly
        for (size_t p = 0; p < n; ++p) goal[p] = std::max<uint32_t>(goal[p], uint32_t(std::min(mean_target, cap)));
        return goal;
    }
    // Every pixel with an error at the cap spends no more than the total (a budget beyond the
    // cap's reach): that is the pass.
    double at_cap = 0;
    for (size_t p = 0; p < n; ++p) at_cap += w[p] > 0 ? std::max(double(film.count[p]), top) : double(film.count[p]);
    if (at_cap <= total) {
        for (size_t p = 0; p < n; ++p)
            if (w[p] > 0 && top > double(film.count[p]))
                goal[p] = film.count[p] + 2 * uint32_t((top - double(film.count[p])) / 2.0);
        return goal;
    }
    // The largest λ whose targets fit the total (bisection: λ spans many decades).
    double lo = 0, hi = 1;
    while (spent(hi) < total) hi *= 4;
    for (int it = 0; it < 64; ++it) {
        const double mid = 0.5 * (lo + hi);
        (spent(mid) <= total ? lo : hi) = mid;
    }
    for (size_t p = 0; p < n; ++p) {
        const double t = std::max(double(film.count[p]), std::min(top, lo * w[p]));
        const double extra = std::floor((t - double(film.count[p])) / 2.0 + 0.5) * 2.0;
        goal[p] = uint32_t(std::min(top, double(film.count[p]) + std::max(0.0, extra)));
    }
    return goal;
}

}  // namespace tessera
