#pragma once
// Floating-point helpers for conservative error bounds (pbrt-v4, section 6.8).
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

namespace tessera {

inline constexpr float machine_epsilon = std::numeric_limits<float>::epsilon() * 0.5f;

// Bound on the relative error of n chained float operations.
constexpr float gamma(int n) { return (n * machine_epsilon) / (1 - n * machine_epsilon); }

inline float next_float_up(float v) {
    if (std::isinf(v) && v > 0.f) return v;
    if (v == -0.f) v = 0.f;
    uint32_t ui = std::bit_cast<uint32_t>(v);
    ui = v >= 0 ? ui + 1 : ui - 1;
    return std::bit_cast<float>(ui);
}

inline float next_float_down(float v) {
    if (std::isinf(v) && v < 0.f) return v;
    if (v == 0.f) v = -0.f;
    uint32_t ui = std::bit_cast<uint32_t>(v);
    ui = v > 0 ? ui - 1 : ui + 1;
    return std::bit_cast<float>(ui);
}

}  // namespace tessera
