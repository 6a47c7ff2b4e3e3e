#include "cli/detail_mask.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace tessera {

std::vector<uint8_t> detail_mask(const float* normal, const float* depth, const float* albedo, int w, int h) {
    std::vector<uint8_t> mask(size_t(w) * h, 0);
    auto inside = [&](int x, int y) { return x >= 0 && y >= 0 && x < w && y < h; };
    auto at = [&](int x, int y) { return size_t(y) * size_t(w) + size_t(x); };
    // The step from (x, y) to (x + dx, y + dy): normal (3) and depth.
    auto step = [&](int x, int y, int dx, int dy, double* out) {
        const size_t p = at(x, y), q = at(x + dx, y + dy);
        for (int k = 0; k < 3; ++k) out[k] = double(normal[q * 3 + k]) - normal[p * 3 + k];
        out[3] = double(depth[q]) - depth[p];
    };
    auto differs = [&](int x, int y, int dx, int dy) {
        const size_t p = at(x, y), q = at(x + dx, y + dy);
        for (int k = 0; k < 3; ++k)
            if (std::abs(double(albedo[p * 3 + k]) - albedo[q * 3 + k]) > 0.04) return true;
        const double zmin = std::min(depth[p], depth[q]);
        auto big = [&](const double* v) {
            return std::abs(v[0]) + std::abs(v[1]) + std::abs(v[2]) > 0.15 || std::abs(v[3]) > 0.03 * zmin;
        };
        double s[4];
        step(x, y, dx, dy, s);
        if (!big(s)) return false;
        // Continued by the step before it (p − d to p) or the one after it (q to q + d): smooth.
        for (const int before : {1, 0}) {
            const int x0 = before ? x - dx : x + dx, y0 = before ? y - dy : y + dy;
            if (!inside(x0, y0) || !inside(x0 + dx, y0 + dy)) continue;
            double t[4];
            step(x0, y0, dx, dy, t);
            for (int k = 0; k < 4; ++k) t[k] -= s[k];
            if (!big(t)) return false;
        }
        return true;
    };
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int dy = -1; dy <= 1 && !mask[at(x, y)]; ++dy)
                for (int dx = -1; dx <= 1; ++dx)
                    if ((dx != 0 || dy != 0) && inside(x + dx, y + dy) && differs(x, y, dx, dy)) {
                        mask[at(x, y)] = 1;
                        break;
                    }
    return mask;
}

}  // namespace tessera
