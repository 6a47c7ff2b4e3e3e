#pragma once
// A small film with every buffer filled with values that bits must carry (denormals, huge and
// negative zero), for the codecs' round-trip tests.
#include "engine/render/film.h"

namespace tessera::test {

inline Film sample_film(bool half, bool adaptive) {
    Film f = Film::tile(32, 16, 5, 3, half, adaptive);
    for (size_t i = 0; i < f.sum.size(); ++i) {
        f.sum[i] = glm::dvec3(0.1 * double(i), 1.0 / 3.0, -0.0);
        f.count[i] = uint32_t(i * 7);
        if (half) {
            f.sum_half[i] = glm::dvec3(1e-300, 1e300, double(i));
            f.sum_quarter[i] = glm::dvec3(-1e-310, 2.0, double(i) / 3.0);
            f.sum_eighth[i] = glm::dvec3(0.25, -7.0, double(i) / 7.0);
        }
        if (adaptive) {
            f.stats[i].add(double(i));
            f.stats[i].add(0.5);
            f.done[i] = uint8_t(i & 1);
        }
    }
    return f;
}

}  // namespace tessera::test
