#pragma once
// A finished tile as the image needs it, as bytes for a render farm (the film itself travels as
// engine/render/film_codec.h writes it).
#include <string>

#include "engine/render/film.h"
#include "engine/render/image.h"

namespace tessera::server {

// A finished tile as the image needs it: each pixel resolved to float RGB and its sample count
// (16 bytes a pixel against the film's 52 with the error estimate on). A job rendered straight
// through ships this instead of its film: resolving is per pixel, so the node's resolve equals
// the assembler's bit for bit.
struct TileImage {
    int x0 = 0, y0 = 0;
    Image image;
};
std::string encode_tile_image(const Film& film);
// Throws std::runtime_error for bytes that are not a tile image this build wrote.
TileImage decode_tile_image(const std::string& bytes);
// Copies a tile's pixels into the image at its place.
void place_tile(const TileImage& tile, Image& into);

}  // namespace tessera::server
