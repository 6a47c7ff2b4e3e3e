#pragma once
// Decoding a texture's PNG or JPEG bytes (glTF's two image formats) into 8-bit RGBA, with
// stb_image from Debian's libstb: the size is read from the header and checked against the
// limits before any texel is allocated.
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "engine/material/texture.h"
#include "engine/scene/scene_description.h"

namespace tessera {

// Throws std::runtime_error saying why (not an image, corrupt, too large). `budget` is what is
// left of LoadLimits::max_texture_bytes: the peak of decoding (2.5 times the texel bytes for an
// 8-bit PNG, 3.5 for a 16-bit PNG or a JPEG) must fit in it, and it is lowered by the image's
// texel bytes.
std::shared_ptr<const TextureImage> decode_texture(std::span<const uint8_t> bytes, const LoadLimits& limits,
                                                   uint64_t& budget);

}  // namespace tessera
