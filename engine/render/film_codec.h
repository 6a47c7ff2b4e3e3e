#pragma once
// A film (a whole image's or one tile's) as bytes: a render farm's tiles travel so through Redis
// between passes and to the node that assembles the image, and a checkpoint keeps a render's
// film so (checkpoint.h). The sums are copied bit for bit (doubles stay doubles), so a farm's
// image, or a resumed render's, equals one uninterrupted process's. Little-endian x86-64 layout;
// a header names the tile and the buffers present.
#include <cstring>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "engine/render/film.h"

namespace tessera {

// A vector's elements as raw bytes, and back (the film's codec and a farm's tile images).
template <class T>
void put_raw(std::string& out, const std::vector<T>& v) {
    out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}
// Fills `v` (sized already) from in[at...], moving `at`; throws std::runtime_error("<what>: truncated").
template <class T>
void get_raw(std::string_view in, size_t& at, std::vector<T>& v, const char* what) {
    const size_t bytes = v.size() * sizeof(T);
    if (bytes == 0) return;
    if (in.size() - at < bytes) throw std::runtime_error(std::string(what) + ": truncated");
    std::memcpy(static_cast<void*>(v.data()), in.data() + at, bytes);
    at += bytes;
}

// Where encoded bytes go, piece by piece: a string, a file, a count. A checkpoint of a large
// film streams to its file, so that writing it costs no copy of the film's bytes in memory.
using ByteSink = std::function<void(const char* bytes, size_t n)>;

void encode_film(const Film& film, const ByteSink& out);
std::string encode_film(const Film& film);
size_t encoded_film_size(const Film& film);
// Throws std::runtime_error for bytes that are not a film this build wrote.
Film decode_film(std::string_view bytes);

}  // namespace tessera
