#pragma once
// The two tables behind ggx_albedo.h and the quadrature that makes them. The quadrature runs at
// build time (ggx_albedo_table_gen.cpp writes the numbers into the engine as a generated
// source): at run time it took 0.4 s of two threads in every process that shaded a glTF
// material (2 s under the sanitizers), before its first pixel. The engine links the quadrature
// too, so that a test can hold the built-in numbers to it bit for bit.
#include <array>

#include "engine/material/ggx_albedo.h"

namespace tessera {
namespace ggx_albedo_detail {

// 32 values of μ from 0 to 1 and of √α from 0 to 1.
inline constexpr int kMu = 32, kRough = 32;

struct Tables {
    std::array<GgxAlbedo, kMu * kRough> e;  // E(μ_i, α_j) at e[j * kMu + i]
    std::array<GgxAlbedo, kRough> avg;      // 2∫E μ dμ at α_j
};

// The fixed stratified quadrature: the same numbers on every run, whatever the thread count.
Tables integrate();

// The built-in tables, integrated when the engine was built.
const Tables& built_in();

}  // namespace ggx_albedo_detail
}  // namespace tessera
