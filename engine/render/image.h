#pragma once
#include <vector>

namespace tessera {

// Linear RGB, row 0 at the top, plus the samples each pixel received.
struct Image {
    int width = 0;
    int height = 0;
    std::vector<float> rgb;           // 3 per pixel
    std::vector<float> sample_count;  // 1 per pixel

    Image() = default;
    Image(int w, int h) : width(w), height(h), rgb(size_t(w) * h * 3, 0.f), sample_count(size_t(w) * h, 0.f) {}
    float* pixel(int x, int y) { return &rgb[(size_t(y) * width + x) * 3]; }
    const float* pixel(int x, int y) const { return &rgb[(size_t(y) * width + x) * 3]; }
};

}  // namespace tessera
