#include "engine/material/texture.h"

#include <algorithm>

namespace tessera {
namespace {

std::array<float, 256> srgb_table() {
    std::array<float, 256> t{};
    for (int i = 0; i < 256; ++i) {
        const double c = i / 255.0;
        t[size_t(i)] = float(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
    }
    return t;
}

// A coordinate in texels, its wrap applied in floating point first so that any finite input
// (1e30 included) lands in a small range before it becomes an integer.
float reduce(float u, Wrap w) {
    if (!std::isfinite(u)) return 0.f;
    switch (w) {
        case Wrap::repeat: return u - std::floor(u);
        case Wrap::mirror: return u - 2.f * std::floor(0.5f * u);  // [0, 2)
        case Wrap::clamp: break;
    }
    return std::clamp(u, 0.f, 1.f);
}

// Texel index i (may be one outside [0, n) after the half-texel shift) under the wrap.
int wrap_index(int i, int n, Wrap w) {
    switch (w) {
        case Wrap::repeat: return ((i % n) + n) % n;
        case Wrap::mirror: {
            const int m = ((i % (2 * n)) + 2 * n) % (2 * n);
            return m < n ? m : 2 * n - 1 - m;
        }
        case Wrap::clamp: break;
    }
    return std::clamp(i, 0, n - 1);
}

glm::vec4 texel(const TextureImage& img, int x, int y, bool srgb) {
    const uint8_t* p = &img.rgba[4 * (size_t(y) * size_t(img.width) + size_t(x))];
    constexpr float k = 1.f / 255.f;
    if (srgb) return {kSrgbToLinear[p[0]], kSrgbToLinear[p[1]], kSrgbToLinear[p[2]], p[3] * k};
    return {p[0] * k, p[1] * k, p[2] * k, p[3] * k};
}

}  // namespace

const std::array<float, 256> kSrgbToLinear = srgb_table();

void set_texture_transform(TextureSlot& slot, glm::vec2 offset, float rotation, glm::vec2 scale) {
    const float c = std::cos(rotation), s = std::sin(rotation);
    slot.row_u = {c * scale.x, s * scale.y, offset.x};
    slot.row_v = {-s * scale.x, c * scale.y, offset.y};
}

glm::vec4 texture_lookup(const TextureImage& img, const Texture& t, glm::vec2 uv, bool srgb) {
    if (img.width <= 0 || img.height <= 0) return glm::vec4(1.f);
    const float x = reduce(uv.x, t.wrap_s) * float(img.width), y = reduce(uv.y, t.wrap_t) * float(img.height);
    if (t.nearest) {
        const int ix = wrap_index(int(std::floor(x)), img.width, t.wrap_s);
        const int iy = wrap_index(int(std::floor(y)), img.height, t.wrap_t);
        return texel(img, ix, iy, srgb);
    }
    // Texel centres sit at half-integers.
    const float fx = x - 0.5f, fy = y - 0.5f;
    const float x0 = std::floor(fx), y0 = std::floor(fy);
    const float ax = fx - x0, ay = fy - y0;
    const int ix0 = wrap_index(int(x0), img.width, t.wrap_s), ix1 = wrap_index(int(x0) + 1, img.width, t.wrap_s);
    const int iy0 = wrap_index(int(y0), img.height, t.wrap_t), iy1 = wrap_index(int(y0) + 1, img.height, t.wrap_t);
    const glm::vec4 top = glm::mix(texel(img, ix0, iy0, srgb), texel(img, ix1, iy0, srgb), ax);
    const glm::vec4 bottom = glm::mix(texel(img, ix0, iy1, srgb), texel(img, ix1, iy1, srgb), ax);
    return glm::mix(top, bottom, ay);
}

glm::vec3 texture_mean(const TextureImage& img, bool srgb) {
    glm::dvec3 sum(0.0);
    const size_t n = size_t(img.width) * size_t(img.height);
    for (size_t i = 0; i < n; ++i) {
        const uint8_t* p = &img.rgba[4 * i];
        for (int c = 0; c < 3; ++c) sum[c] += srgb ? kSrgbToLinear[p[c]] : p[c] / 255.0;
    }
    return n ? glm::vec3(sum / double(n)) : glm::vec3(0.f);
}

}  // namespace tessera
