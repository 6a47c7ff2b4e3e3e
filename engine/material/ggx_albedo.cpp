#include "engine/material/ggx_albedo.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "engine/material/ggx_albedo_tables.h"

namespace tessera {
namespace ggx_albedo_detail {

// Written by ggx_albedo_table_gen at build time: `constexpr Tables kBuiltIn`.
#include "engine/material/ggx_albedo_table.inc"

const Tables& built_in() { return kBuiltIn; }

}  // namespace ggx_albedo_detail

namespace {

using ggx_albedo_detail::kMu;
using ggx_albedo_detail::kRough;
using Tables = ggx_albedo_detail::Tables;

const Tables& tables() { return ggx_albedo_detail::kBuiltIn; }

// The table's coordinate along √α, as (index, weight of index + 1).
std::pair<int, float> rough_coord(float alpha) {
    // Written so that NaN reads the first entry (std::clamp and std::max pass NaN on, and int(NaN)
    // indexes anywhere): a lookup never leaves its table, whatever direction it is asked about.
    const float x = std::min(std::sqrt(alpha > 0.f ? alpha : 0.f), 1.f) * float(kRough - 1);
    const int j = std::min(int(x), kRough - 2);
    return {j, x - float(j)};
}

GgxAlbedo lerp(const GgxAlbedo& p, const GgxAlbedo& q, float w) { return {p.a + (q.a - p.a) * w, p.b + (q.b - p.b) * w}; }

}  // namespace

GgxAlbedo ggx_albedo(float mu, float alpha) {
    const Tables& t = tables();
    const auto [j, wj] = rough_coord(alpha);
    const float x = (mu > 0.f ? std::min(mu, 1.f) : 0.f) * float(kMu - 1);  // NaN: 0, as in rough_coord
    const int i = std::min(int(x), kMu - 2);
    const float wi = x - float(i);
    const GgxAlbedo lo = lerp(t.e[j * kMu + i], t.e[j * kMu + i + 1], wi);
    const GgxAlbedo hi = lerp(t.e[(j + 1) * kMu + i], t.e[(j + 1) * kMu + i + 1], wi);
    return lerp(lo, hi, wj);
}

GgxAlbedo ggx_albedo_average(float alpha) {
    const auto [j, wj] = rough_coord(alpha);
    return lerp(tables().avg[j], tables().avg[j + 1], wj);
}

}  // namespace tessera
