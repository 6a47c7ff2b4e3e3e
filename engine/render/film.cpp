#include "engine/render/film.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace tessera {

void Film::resolve_aov(Aov a, float* out) const {
    if (!aov_layout.has(a)) throw std::logic_error("the film keeps no " + std::string(aov_info(a).name) + " pass");
    const AovInfo& info = aov_info(a);
    const size_t n = size_t(width) * size_t(height), stride = size_t(aov_layout.stride);
    const size_t o = size_t(aov_layout.offset[size_t(a)]);
    for (size_t p = 0; p < n; ++p, out += info.components) {
        const double* e = &aov[p * stride + o];
        const double c = double(count[p]);
        if (a == Aov::variance) {
            // Of the mean: (E[L²] − E[L]²)/(n − 1), none below two samples.
            for (int k = 0; k < 3; ++k) {
                const double mean = sum[p][k] / std::max(c, 1.0);
                out[k] = c > 1 ? float(std::max(0.0, e[k] / c - mean * mean) / (c - 1.0)) : 0.f;
            }
            continue;
        }
        if (info.merge == AovMerge::ranked) {
            resolve_crypto(e, c, out);
            continue;
        }
        const double scale = info.merge == AovMerge::mean ? (c > 0 ? 1.0 / c : 0.0) : 1.0;
        for (int k = 0; k < info.components; ++k) out[k] = float(e[k] * scale);
    }
}

std::vector<AovPlane> Film::resolve_aovs(AovSet which) const {
    std::vector<AovPlane> planes;
    const size_t n = size_t(width) * size_t(height);
    for (const AovInfo& info : kAovInfo) {
        if (!has_aov(which, info.aov) || !aov_layout.has(info.aov)) continue;
        AovPlane plane{info.aov, info.components, std::vector<float>(n * size_t(info.components), 0.f)};
        resolve_aov(info.aov, plane.values.data());
        planes.push_back(std::move(plane));
    }
    return planes;
}

}  // namespace tessera
