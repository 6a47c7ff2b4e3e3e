#pragma once
// A film (a whole image's or one tile's) as bytes: a render farm's tiles travel so through Redis
// between passes and to the node that assembles the image, and a checkpoint keeps a render's
// film so (checkpoint.h). The sums are copied bit for bit (doubles stay doubles), so a farm's
// image, or a resumed render's, equals one uninterrupted process's. Little-endian x86-64 layout;
// a header names the tile and the buffers present.
#include <string>

#include "engine/render/film.h"

namespace tessera {

std::string encode_film(const Film& film);
// Throws std::runtime_error for bytes that are not a film this build wrote.
Film decode_film(const std::string& bytes);

}  // namespace tessera
