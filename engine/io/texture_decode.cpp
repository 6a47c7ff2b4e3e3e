#include "engine/io/texture_decode.h"

#include <limits>
#include <stdexcept>

#include <stb_image.h>

namespace tessera {

std::shared_ptr<const TextureImage> decode_texture(std::span<const uint8_t> bytes, const LoadLimits& limits,
                                                   uint64_t& budget) {
    if (bytes.size() > size_t(std::numeric_limits<int>::max())) throw std::runtime_error("image data of 2 GiB or more");
    const bool png = bytes.size() >= 8 && bytes[0] == 0x89 && bytes[1] == 'P' && bytes[2] == 'N' && bytes[3] == 'G';
    const bool jpeg = bytes.size() >= 3 && bytes[0] == 0xFF && bytes[1] == 0xD8 && bytes[2] == 0xFF;
    if (!png && !jpeg) throw std::runtime_error("not a PNG or JPEG image (glTF's image formats)");
    int w = 0, h = 0, channels = 0;
    const int len = int(bytes.size());
    if (!stbi_info_from_memory(bytes.data(), len, &w, &h, &channels))
        throw std::runtime_error(std::string("unreadable image header (corrupt, or over stb_image's bound of 2^30 bytes): ") +
                                 stbi_failure_reason());
    if (w <= 0 || h <= 0 || w > limits.max_texture_size || h > limits.max_texture_size)
        throw std::runtime_error("image of " + std::to_string(w) + "x" + std::to_string(h) + " texels; the limit is " +
                                 std::to_string(limits.max_texture_size) + " on a side");
    const uint64_t need = 4ull * uint64_t(w) * uint64_t(h);
    // While it decodes, stb_image holds the inflated rows and its output (and a conversion to
    // four channels for RGB), and the result is copied once more: up to 2.5 times the texels
    // for an 8-bit PNG; a 16-bit PNG (a second conversion, to 8 bits) and a JPEG (coefficients
    // and planes) take up to 3.5 times. That peak is what must fit in what is left, so the
    // budget bounds memory, not only texels.
    const bool wide = jpeg || stbi_is_16_bit_from_memory(bytes.data(), len);
    const uint64_t peak = wide ? need * 7 / 2 : need * 5 / 2;
    if (peak > budget)
        throw std::runtime_error("image of " + std::to_string(w) + "x" + std::to_string(h) + " texels needs " +
                                 std::to_string(need) + " bytes (" + std::to_string(peak) + " while it decodes); " +
                                 std::to_string(budget) + " are left of the texture budget (" +
                                 std::to_string(limits.max_texture_bytes) + " bytes)");
    int dw = 0, dh = 0;
    stbi_uc* px = stbi_load_from_memory(bytes.data(), len, &dw, &dh, &channels, 4);
    if (!px) throw std::runtime_error(std::string("corrupt image: ") + stbi_failure_reason());
    auto img = std::make_shared<TextureImage>();
    if (dw != w || dh != h) {
        stbi_image_free(px);
        throw std::runtime_error("the image decodes to another size than its header states");
    }
    img->width = w;
    img->height = h;
    img->rgba.assign(px, px + need);
    stbi_image_free(px);
    budget -= need;
    return img;
}

}  // namespace tessera
