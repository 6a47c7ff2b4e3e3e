#include "engine/render/convergence.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "engine/render/film.h"
#include "engine/render/image.h"

namespace tessera {

const char* to_string(StopReason r) {
    switch (r) {
        case StopReason::spp: return "spp";
        case StopReason::converged: return "converged";
        case StopReason::time_limit: return "time_limit";
        case StopReason::target_error: return "target_error";
        case StopReason::canceled: return "canceled";
    }
    return "?";
}

ErrorSums error_sums(const Film& film, const Image* reference) {
    ErrorSums e;
    e.pixels = film.sum.size();
    e.half_buffer = !film.sum_half.empty() || !film.sum_odd.empty();
    const bool split = !film.sum_odd.empty();
    e.reference = reference != nullptr;
    constexpr double eps = 0.01;
    for (size_t i = 0; i < film.sum.size(); ++i) {
        const uint32_t count = film.count[i];
        const double c = double(count);
        e.spp += c;
        if (count == 0) continue;
        const glm::dvec3 mean = film.sum[i] / c;
        if (split && count >= 2) {
            // Independent halves (even and odd samples, scrambled apart): their difference gives
            // the variance of the mean with no stratification to correct for; the square of the
            // truth from their product (kHalvesProductFloor).
            const double na = double((count + 1) / 2), nb = double(count / 2);
            const glm::dvec3 a = (film.sum[i] - film.sum_odd[i]) / na, b = film.sum_odd[i] / nb;
            double outer = 0;
            for (int k = 0; k < 3; ++k)
                outer += (a[k] - b[k]) * (a[k] - b[k]) * (na * nb / (c * c)) / (std::max(a[k] * b[k], kHalvesProductFloor * mean[k] * mean[k]) + eps);
            e.est += outer;
            ++e.est_pixels;
        } else if (e.half_buffer && count >= 2) {
            const uint32_t h = 1u << (31 - __builtin_clz(count - 1));  // the largest power of two below c
            const double w = double(h) * double(count - h) / (c * c);
            const glm::dvec3 a = film.sum_half[i] / double(h), b = (film.sum[i] - film.sum_half[i]) / double(count - h);
            double outer = 0;
            for (int k = 0; k < 3; ++k) outer += (a[k] - b[k]) * (a[k] - b[k]) * w / (mean[k] * mean[k] + eps);
            e.est += outer;
            ++e.est_pixels;
            auto difference = [&](const glm::dvec3& first, const glm::dvec3& both, double n) {  // two halves of n each
                const glm::dvec3 x = first / n, y = (both - first) / n;
                double d = 0;
                for (int k = 0; k < 3; ++k) d += (x[k] - y[k]) * (x[k] - y[k]) / 4.0 / (mean[k] * mean[k] + eps);
                return d;
            };
            if (h >= 4) {
                e.deep += difference(film.sum_eighth[i], film.sum_quarter[i], double(h / 4));
                e.deep_outer += outer;
                e.deep_log_split += std::log(c / double(h));
                ++e.deep_pixels;
            } else if (h == 2) {
                e.shallow += difference(film.sum_quarter[i], film.sum_half[i], 1.0);
                e.shallow_outer += outer;
                e.shallow_log_split += std::log(c / double(h));
                ++e.shallow_pixels;
            }
        }
        if (reference) {
            // The reference covers the image; the film may cover one tile of it.
            const size_t x = size_t(film.x0) + i % size_t(film.width), y = size_t(film.y0) + i / size_t(film.width);
            const size_t ri = y * size_t(reference->width) + x;
            for (int k = 0; k < 3; ++k) {
                const double r = reference->rgb[ri * 3 + size_t(k)], d = mean[k] - r;
                e.rel += d * d / (r * r + eps);
                e.mse += d * d;
                e.mae += std::abs(d);
            }
        }
    }
    return e;
}

double relative_mse(const Image& image, const Image& reference) {
    if (image.rgb.size() != reference.rgb.size() || image.rgb.empty()) return -1;
    double rel = 0;
    for (size_t i = 0; i < image.rgb.size(); ++i) {
        const double r = reference.rgb[i], d = double(image.rgb[i]) - r;
        rel += d * d / (r * r + 0.01);
    }
    return rel / double(image.rgb.size());
}

void ErrorSums::add(const ErrorSums& o) {
    spp += o.spp;
    est += o.est;
    deep_outer += o.deep_outer;
    deep += o.deep;
    deep_log_split += o.deep_log_split;
    deep_pixels += o.deep_pixels;
    shallow_outer += o.shallow_outer;
    shallow += o.shallow;
    shallow_log_split += o.shallow_log_split;
    shallow_pixels += o.shallow_pixels;
    rel += o.rel;
    mse += o.mse;
    mae += o.mae;
    pixels += o.pixels;
    est_pixels += o.est_pixels;
    half_buffer = half_buffer || o.half_buffer;
    reference = reference || o.reference;
}

ConvergencePoint ErrorSums::point() const {
    ConvergencePoint pt;
    const double n = double(pixels);
    pt.spp_mean = pixels ? spp / n : 0;
    if (half_buffer && est_pixels) {
        double factor = 1.0;
        // The deeper ratio wherever pixels have the samples for it (most of them decide).
        if (deep_pixels && deep_outer > 0 && deep > 0 && deep_pixels >= shallow_pixels) {
            const double split = std::exp(deep_log_split / double(deep_pixels));
            factor = stratification_factor(convergence_order(deep / deep_outer, split, 2), split);
        } else if (shallow_pixels && shallow_outer > 0 && shallow > 0) {
            const double split = std::exp(shallow_log_split / double(shallow_pixels));
            factor = stratification_factor(convergence_order(shallow / shallow_outer, split, 1), split);
        }
        pt.est_rel_mse = est / double(3 * est_pixels) * factor;
    }
    if (reference && pixels) {
        pt.rel_mse = rel / (3 * n);
        pt.mse = mse / (3 * n);
        pt.mae = mae / (3 * n);
    }
    return pt;
}

double stratification_factor(double alpha, double split) {
    if (!(split > 1.0) || alpha <= 1.0) return 1.0;
    return (split - 1.0) / (std::pow(split, alpha) - 1.0);
}

double convergence_order(double ratio, double split, int levels) {
    // inner/outer = (2^α − 1)V(h/2^(levels−1)) / (V(c)/factor) = (2^α − 1) (2^(levels−1) split)^α
    // factor(α, split): 2^(levels α) at split 2, increasing in α; solved by bisection.
    const double reach = std::ldexp(split, levels - 1);
    auto predicted = [&](double a) { return (std::exp2(a) - 1.0) * std::pow(reach, a) * stratification_factor(a, split); };
    if (!(split > 1.0) || !(ratio > predicted(1.0))) return 1.0;
    if (ratio >= predicted(3.0)) return 3.0;
    double lo = 1.0, hi = 3.0;
    for (int i = 0; i < 50; ++i) {
        const double mid = 0.5 * (lo + hi);
        (predicted(mid) < ratio ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

ConvergencePoint measure_error(const Film& film, const Image* reference) { return error_sums(film, reference).point(); }

std::string convergence_csv(const ConvergenceCurve& c) {
    std::ostringstream o;
    // A denoising render's curve has its denoised image's error in three more columns.
    const bool denoised = std::any_of(c.points.begin(), c.points.end(), [](const ConvergencePoint& p) { return p.denoised_est_rel_mse >= 0; });
    o << "seconds,spp_mean,rel_mse,mse,mae,est_rel_mse" << (denoised ? ",denoised_rel_mse,denoised_est_rel_mse,denoise_seconds" : "") << "\n";
    auto v = [&](double x) { if (x >= 0) o << x; };
    for (const auto& p : c.points) {
        o << p.seconds << "," << p.spp_mean << ",";
        v(p.rel_mse); o << ",";
        v(p.mse); o << ",";
        v(p.mae); o << ",";
        v(p.est_rel_mse);
        if (denoised) {
            o << ",";
            v(p.denoised_rel_mse); o << ",";
            v(p.denoised_est_rel_mse); o << "," << p.denoise_seconds;
        }
        o << "\n";
    }
    return o.str();
}

namespace {

// Labels and titles come from jobs (a comparison's labels, a scene's name): escaped, so that
// "a<b & c" is text in the plot, not broken or foreign markup.
std::string xml_text(const std::string& t) {
    std::string out;
    for (char c : t) {
        switch (c) {
            case '<': out += "&lt;"; break;
            case '>': out += "&gt;"; break;
            case '&': out += "&amp;"; break;
            case '"': out += "&quot;"; break;
            default:
                // Control characters are not allowed in XML 1.0 text.
                if (static_cast<unsigned char>(c) >= 0x20 || c == '\t' || c == '\n') out += c;
        }
    }
    return out;
}

}  // namespace

std::string convergence_svg(const std::vector<ConvergenceCurve>& curves, const std::vector<std::string>& labels,
                            const std::string& title) {
    // Plot the measured relMSE where there is a reference, else the estimate.
    auto y_of = [](const ConvergencePoint& p) { return p.rel_mse > 0 ? p.rel_mse : p.est_rel_mse; };
    double x0 = INFINITY, x1 = 0, y0 = INFINITY, y1 = 0;
    bool any_reference = false;
    for (const auto& c : curves)
        for (const auto& p : c.points) {
            const double y = y_of(p);
            if (p.seconds <= 0 || !(y > 0)) continue;
            x0 = std::min(x0, p.seconds); x1 = std::max(x1, p.seconds);
            y0 = std::min(y0, y); y1 = std::max(y1, y);
            any_reference |= p.rel_mse > 0;
        }
    if (!(x1 > 0)) { x0 = 1e-3; x1 = 1; y0 = 1e-4; y1 = 1; }
    const double lx0 = std::floor(std::log10(x0)), lx1 = std::max(lx0 + 1, std::ceil(std::log10(x1)));
    const double ly0 = std::floor(std::log10(y0)), ly1 = std::max(ly0 + 1, std::ceil(std::log10(y1)));
    const int W = 720, H = 480, L = 80, R = 200, T = 40, B = 60;
    auto px = [&](double x) { return L + (std::log10(x) - lx0) / (lx1 - lx0) * (W - L - R); };
    auto py = [&](double y) { return H - B - (std::log10(y) - ly0) / (ly1 - ly0) * (H - T - B); };
    static const char* colours[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
                                    "#bcbd22", "#17becf"};
    std::ostringstream s;
    s << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << H << "\" font-family=\"sans-serif\" font-size=\"12\">\n";
    s << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
    s << "<text x=\"" << W / 2 << "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">" << xml_text(title) << "</text>\n";
    for (double e = lx0; e <= lx1 + 1e-9; ++e) {
        const double x = px(std::pow(10.0, e));
        s << "<line x1=\"" << x << "\" y1=\"" << T << "\" x2=\"" << x << "\" y2=\"" << H - B << "\" stroke=\"#ddd\"/>\n";
        s << "<text x=\"" << x << "\" y=\"" << H - B + 18 << "\" text-anchor=\"middle\">1e" << int(e) << "</text>\n";
    }
    for (double e = ly0; e <= ly1 + 1e-9; ++e) {
        const double y = py(std::pow(10.0, e));
        s << "<line x1=\"" << L << "\" y1=\"" << y << "\" x2=\"" << W - R << "\" y2=\"" << y << "\" stroke=\"#ddd\"/>\n";
        s << "<text x=\"" << L - 8 << "\" y=\"" << y + 4 << "\" text-anchor=\"end\">1e" << int(e) << "</text>\n";
    }
    s << "<rect x=\"" << L << "\" y=\"" << T << "\" width=\"" << W - L - R << "\" height=\"" << H - T - B << "\" fill=\"none\" stroke=\"black\"/>\n";
    s << "<text x=\"" << (L + W - R) / 2 << "\" y=\"" << H - 15 << "\" text-anchor=\"middle\">render time (seconds, log scale)</text>\n";
    s << "<text transform=\"translate(20," << (T + H - B) / 2 << ") rotate(-90)\" text-anchor=\"middle\">"
      << (any_reference ? "relative MSE against the reference" : "estimated relative MSE (half buffers)") << " (log scale)</text>\n";
    for (size_t i = 0; i < curves.size(); ++i) {
        const char* col = colours[i % 10];
        std::ostringstream pts;
        for (const auto& p : curves[i].points) {
            const double y = y_of(p);
            if (p.seconds <= 0 || !(y > 0)) continue;
            pts << px(p.seconds) << "," << py(y) << " ";
        }
        s << "<polyline fill=\"none\" stroke=\"" << col << "\" stroke-width=\"2\" points=\"" << pts.str() << "\"/>\n";
        const int ly = T + 10 + int(i) * 18;
        s << "<line x1=\"" << W - R + 10 << "\" y1=\"" << ly << "\" x2=\"" << W - R + 30 << "\" y2=\"" << ly << "\" stroke=\"" << col
          << "\" stroke-width=\"2\"/>\n";
        s << "<text x=\"" << W - R + 35 << "\" y=\"" << ly + 4 << "\">" << xml_text(i < labels.size() ? labels[i] : "") << "</text>\n";
    }
    s << "</svg>\n";
    return s.str();
}

}  // namespace tessera
