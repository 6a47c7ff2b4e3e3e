#include "engine/render/checkpoint.h"

#include <cstring>
#include <stdexcept>
#include <string_view>
#include <type_traits>

#include "engine/render/film_codec.h"

namespace tessera {

namespace {

constexpr char kMagic[4] = {'T', 'C', 'K', '1'};
static_assert(std::is_trivially_copyable_v<ConvergencePoint>);

// FNV-1a over the bytes: a damaged file is refused rather than resumed into a wrong image.
constexpr uint64_t kChecksumSeed = 1469598103934665603ull;
uint64_t checksum(const char* p, size_t n, uint64_t h = kChecksumSeed) {
    for (size_t i = 0; i < n; ++i) h = (h ^ uint8_t(p[i])) * 1099511628211ull;
    return h;
}

template <class T>
void put(const ByteSink& out, const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    out(reinterpret_cast<const char*>(&v), sizeof v);
}

struct Reader {
    std::string_view in;
    size_t at = 0;
    template <class T>
    T get() {
        T v;
        if (in.size() - at < sizeof v) throw std::runtime_error("checkpoint: truncated");
        std::memcpy(static_cast<void*>(&v), in.data() + at, sizeof v);
        at += sizeof v;
        return v;
    }
    // A count of n items of `size` bytes that the rest of the bytes can hold.
    size_t count(size_t size) {
        const uint64_t n = get<uint64_t>();
        if (n > (in.size() - at) / size) throw std::runtime_error("checkpoint: truncated");
        return size_t(n);
    }
};

}  // namespace

uint64_t RenderCheckpoint::film_samples() const {
    uint64_t n = 0;
    for (uint32_t c : film.count) n += c;
    return n;
}

void encode_checkpoint(const RenderCheckpoint& c, const ByteSink& sink) {
    // Everything before the checksum passes through it on its way out.
    uint64_t sum = kChecksumSeed;
    const ByteSink out = [&](const char* p, size_t n) {
        sum = checksum(p, n, sum);
        sink(p, n);
    };
    out(kMagic, 4);
    put(out, int32_t(c.pass));
    put(out, int32_t(c.target));
    put(out, c.samples);
    put(out, c.seconds);
    put(out, uint64_t(c.tiles_done.size()));
    if (!c.tiles_done.empty()) out(reinterpret_cast<const char*>(c.tiles_done.data()), c.tiles_done.size());
    put(out, uint64_t(c.points.size()));
    for (const ConvergencePoint& p : c.points) put(out, p);
    RenderStats stats = c.stats;
    for_each_counter([&](const char*, uint64_t& v) { put(out, v); }, stats);
    put(out, c.stats.max_sample);
    put(out, uint64_t(encoded_film_size(c.film)));
    encode_film(c.film, out);
    put(sink, sum);
}

std::string encode_checkpoint(const RenderCheckpoint& c) {
    std::string out;
    encode_checkpoint(c, [&](const char* p, size_t n) { out.append(p, n); });
    return out;
}

RenderCheckpoint decode_checkpoint(std::string_view bytes) {
    if (bytes.size() < 4 + sizeof(uint64_t) || std::memcmp(bytes.data(), kMagic, 4) != 0)
        throw std::runtime_error("checkpoint: not a checkpoint");
    uint64_t sum;
    std::memcpy(&sum, bytes.data() + bytes.size() - sizeof sum, sizeof sum);
    if (sum != checksum(bytes.data(), bytes.size() - sizeof sum)) throw std::runtime_error("checkpoint: damaged (checksum)");
    const std::string_view body = bytes.substr(0, bytes.size() - sizeof sum);  // a view: no copy of the film's bytes
    Reader r{body, 4};
    RenderCheckpoint c;
    c.pass = r.get<int32_t>();
    c.target = r.get<int32_t>();
    c.samples = r.get<uint64_t>();
    c.seconds = r.get<double>();
    if (c.pass < 0 || c.target < 0 || !(c.seconds >= 0)) throw std::runtime_error("checkpoint: bad pass");
    c.tiles_done.resize(r.count(1));
    for (uint8_t& t : c.tiles_done) t = r.get<uint8_t>();
    c.points.resize(r.count(sizeof(ConvergencePoint)));
    for (ConvergencePoint& p : c.points) p = r.get<ConvergencePoint>();
    for_each_counter([&](const char*, uint64_t& v) { v = r.get<uint64_t>(); }, c.stats);
    c.stats.max_sample = r.get<float>();
    const size_t film = r.count(1);
    c.film = decode_film(body.substr(r.at, film));
    if (r.at + film != body.size()) throw std::runtime_error("checkpoint: trailing bytes");
    return c;
}

bool fits(const RenderCheckpoint& c, int width, int height, bool half_buffer, bool adaptive, AovSet aovs, size_t tiles) {
    const Film& f = c.film;
    return f.width == width && f.height == height && f.x0 == 0 && f.y0 == 0 && f.sum_half.empty() != half_buffer &&
           f.stats.empty() != adaptive && (f.aov_layout.set | (f.sum_odd.empty() ? 0 : kSplitHalves)) == aovs &&
           c.tiles_done.size() == tiles && c.target > 0;
}

}  // namespace tessera
