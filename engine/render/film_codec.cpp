#include "engine/render/film_codec.h"

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <type_traits>

namespace tessera {

namespace {

constexpr char kMagic[4] = {'T', 'F', 'L', '4'};  // 2: the error estimate's prefix sums; 3: AOVs; 4: seen light's halves

struct Header {
    char magic[4];
    int32_t width, height, x0, y0;
    // guided: per-pixel targets follow the counts; rays: the rays traced per pixel follow the
    // seen light's halves (both 0 in films written before them)
    uint8_t half_buffer, adaptive, guided, rays;
    uint32_t aovs;  // AovSet: the AOV entries follow the rest
};

static_assert(std::is_trivially_copyable_v<glm::dvec3> && sizeof(glm::dvec3) == 24);
static_assert(std::is_trivially_copyable_v<RunningStats>);

template <class T>
void put(const ByteSink& out, const std::vector<T>& v) {
    if (!v.empty()) out(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}
template <class T>
void get(std::string_view in, size_t& at, std::vector<T>& v) { get_raw(in, at, v, "tile film"); }

}  // namespace

void encode_film(const Film& f, const ByteSink& out) {
    Header h{};
    std::memcpy(h.magic, kMagic, 4);
    h.width = f.width;
    h.height = f.height;
    h.x0 = f.x0;
    h.y0 = f.y0;
    h.half_buffer = !f.sum_half.empty();
    h.adaptive = !f.stats.empty();
    h.guided = !f.goal.empty();
    h.rays = !f.rays.empty();
    h.aovs = f.aov_layout.set | (f.sum_odd.empty() ? 0 : kSplitHalves);
    out(reinterpret_cast<const char*>(&h), sizeof h);
    put(out, f.sum);
    put(out, f.count);
    put(out, f.goal);
    if (h.half_buffer) {
        put(out, f.sum_half);
        put(out, f.sum_quarter);
        put(out, f.sum_eighth);
    }
    if (h.adaptive) {
        put(out, f.stats);
        put(out, f.done);
    }
    put(out, f.sum_odd);
    put(out, f.seen);
    put(out, f.seen_odd);
    put(out, f.rays);
    put(out, f.aov);
}

size_t encoded_film_size(const Film& f) {
    size_t n = 0;
    encode_film(f, [&](const char*, size_t k) { n += k; });
    return n;
}

std::string encode_film(const Film& f) {
    std::string out;
    out.reserve(encoded_film_size(f));
    encode_film(f, [&](const char* p, size_t k) { out.append(p, k); });
    return out;
}

Film decode_film(std::string_view bytes) {
    Header h;
    if (bytes.size() < sizeof h) throw std::runtime_error("tile film: truncated header");
    std::memcpy(&h, bytes.data(), sizeof h);
    if (std::memcmp(h.magic, kMagic, 4) != 0) throw std::runtime_error("tile film: not a film");
    if (h.width <= 0 || h.height <= 0 || h.width > 65536 || h.height > 65536) throw std::runtime_error("tile film: bad size");
    if ((h.aovs & ~kSplitHalves) >= (AovSet(1) << kAovCount)) throw std::runtime_error("tile film: unknown AOVs");
    Film f = Film::tile(h.x0, h.y0, h.width, h.height, h.half_buffer != 0, h.adaptive != 0, h.aovs);
    size_t at = sizeof h;
    get(bytes, at, f.sum);
    get(bytes, at, f.count);
    if (h.guided) {
        f.goal.resize(f.count.size());
        get(bytes, at, f.goal);
    }
    if (h.half_buffer) {
        get(bytes, at, f.sum_half);
        get(bytes, at, f.sum_quarter);
        get(bytes, at, f.sum_eighth);
    }
    if (h.adaptive) {
        get(bytes, at, f.stats);
        get(bytes, at, f.done);
    }
    get(bytes, at, f.sum_odd);
    get(bytes, at, f.seen);
    get(bytes, at, f.seen_odd);
    f.rays.resize(h.rays ? f.count.size() : 0);
    get(bytes, at, f.rays);
    get(bytes, at, f.aov);
    if (at != bytes.size()) throw std::runtime_error("tile film: trailing bytes");
    return f;
}

}  // namespace tessera
