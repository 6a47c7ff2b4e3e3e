#pragma once
// A tile's film as bytes, to travel through Redis between passes and to the node that assembles
// the image: the sums are copied bit for bit (doubles stay doubles), so a farm's image equals one
// process's. Little-endian x86-64 layout; a header names the tile and the buffers present.
#include <string>

#include "engine/render/film.h"

namespace tessera::server {

std::string encode_film(const Film& film);
// Throws std::runtime_error for bytes that are not a film this build wrote.
Film decode_film(const std::string& bytes);

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
