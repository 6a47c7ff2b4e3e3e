#include "engine/scene/animation.h"

#include <algorithm>
#include <cmath>

namespace tessera {
namespace {

// Key k's value (cubic_spline: the middle of its three).
const float* value_at(const AnimationChannel& c, size_t k) {
    const size_t per_key = c.interpolation == Interpolation::cubic_spline ? 3 : 1;
    return c.values.data() + (k * per_key + (per_key == 3 ? 1 : 0)) * size_t(c.width);
}

void normalise(float* q) {
    const double len = std::sqrt(double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2] + double(q[3]) * q[3]);
    if (len > 0 && std::isfinite(len))
        for (int j = 0; j < 4; ++j) q[j] = float(q[j] / len);
}

// Shorter-arc spherical interpolation; falls back to normalised lerp where the two are nearly
// parallel (sin θ would divide by almost zero).
void slerp(const float* a, const float* b, double s, float* out) {
    double dot = 0;
    for (int j = 0; j < 4; ++j) dot += double(a[j]) * b[j];
    const double sign = dot < 0 ? -1.0 : 1.0;
    dot *= sign;
    double wa = 1 - s, wb = s;
    if (dot < 0.9995) {
        const double theta = std::acos(std::min(dot, 1.0));
        const double sin_theta = std::sin(theta);
        wa = std::sin((1 - s) * theta) / sin_theta;
        wb = std::sin(s * theta) / sin_theta;
    }
    for (int j = 0; j < 4; ++j) out[j] = float(wa * a[j] + wb * sign * b[j]);
    normalise(out);
}

}  // namespace

void sample(const AnimationChannel& c, double t, float* out) {
    const size_t keys = c.times.size();
    const size_t w = size_t(c.width);
    if (keys == 0 || w == 0) return;
    const bool rotation = c.property == AnimatedProperty::rotation;
    if (!(t > c.times.front())) {  // NaN too
        std::copy_n(value_at(c, 0), w, out);
        if (rotation) normalise(out);
        return;
    }
    if (t >= c.times.back()) {
        std::copy_n(value_at(c, keys - 1), w, out);
        if (rotation) normalise(out);
        return;
    }
    // times[k] <= t < times[k + 1]
    const size_t k = size_t(std::upper_bound(c.times.begin(), c.times.end(), float(t)) - c.times.begin()) - 1;
    const size_t k1 = std::min(k + 1, keys - 1);
    const double t0 = c.times[k], t1 = c.times[k1];
    const double dt = t1 - t0;
    const double s = dt > 0 ? std::clamp((t - t0) / dt, 0.0, 1.0) : 0.0;
    const float* a = value_at(c, k);
    const float* b = value_at(c, k1);
    switch (c.interpolation) {
        case Interpolation::step:
            std::copy_n(a, w, out);
            break;
        case Interpolation::linear:
            if (rotation && w == 4) return slerp(a, b, s, out);
            for (size_t j = 0; j < w; ++j) out[j] = float((1 - s) * a[j] + s * b[j]);
            break;
        case Interpolation::cubic_spline: {
            // Hermite spline over [t0, t1] with the out-tangent of key k and the in-tangent of
            // key k + 1, both scaled by the interval (glTF 2.0, Appendix C).
            const float* out_tangent = a + w;
            const float* in_tangent = b - w;
            const double s2 = s * s, s3 = s2 * s;
            const double h00 = 2 * s3 - 3 * s2 + 1, h10 = s3 - 2 * s2 + s, h01 = -2 * s3 + 3 * s2, h11 = s3 - s2;
            for (size_t j = 0; j < w; ++j)
                out[j] = float(h00 * a[j] + h10 * dt * out_tangent[j] + h01 * b[j] + h11 * dt * in_tangent[j]);
            break;
        }
    }
    if (rotation) normalise(out);
}

}  // namespace tessera
