#include "server/farm/tile_image_codec.h"

#include "engine/render/film_codec.h"

#include <cstdint>
#include <cstring>
#include <stdexcept>

namespace tessera::server {

namespace {

template <class T>
void put(std::string& out, const std::vector<T>& v) { put_raw(out, v); }
template <class T>
void get(const std::string& in, size_t& at, std::vector<T>& v) { get_raw(in, at, v, "tile image"); }

constexpr char kImageMagic[4] = {'T', 'T', 'I', '1'};

struct ImageHeader {
    char magic[4];
    int32_t width, height, x0, y0;
};

}  // namespace

std::string encode_tile_image(const Film& f) {
    ImageHeader h{};
    std::memcpy(h.magic, kImageMagic, 4);
    h.width = f.width;
    h.height = f.height;
    h.x0 = f.x0;
    h.y0 = f.y0;
    const Image img = f.resolve();
    std::string out(reinterpret_cast<const char*>(&h), sizeof h);
    put(out, img.rgb);
    put(out, img.sample_count);
    return out;
}

TileImage decode_tile_image(const std::string& bytes) {
    ImageHeader h;
    if (bytes.size() < sizeof h) throw std::runtime_error("tile image: truncated header");
    std::memcpy(&h, bytes.data(), sizeof h);
    if (std::memcmp(h.magic, kImageMagic, 4) != 0) throw std::runtime_error("tile image: not a tile image");
    if (h.width <= 0 || h.height <= 0 || h.width > 65536 || h.height > 65536) throw std::runtime_error("tile image: bad size");
    TileImage t;
    t.x0 = h.x0;
    t.y0 = h.y0;
    t.image = Image(h.width, h.height);
    size_t at = sizeof h;
    get(bytes, at, t.image.rgb);
    get(bytes, at, t.image.sample_count);
    if (at != bytes.size()) throw std::runtime_error("tile image: trailing bytes");
    return t;
}

void place_tile(const TileImage& t, Image& into) {
    if (t.x0 < 0 || t.y0 < 0 || t.x0 + t.image.width > into.width || t.y0 + t.image.height > into.height)
        throw std::runtime_error("tile image: outside the image");
    for (int y = 0; y < t.image.height; ++y) {
        const size_t from = size_t(y) * t.image.width, to = size_t(t.y0 + y) * into.width + t.x0;
        std::memcpy(&into.rgb[to * 3], &t.image.rgb[from * 3], size_t(t.image.width) * 3 * sizeof(float));
        std::memcpy(&into.sample_count[to], &t.image.sample_count[from], size_t(t.image.width) * sizeof(float));
    }
}

}  // namespace tessera::server
