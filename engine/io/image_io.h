#pragma once
// Writing images through OpenImageIO: PNG (sRGB-encoded, clamped, 8 bit) and EXR (linear
// float RGB plus the per-pixel sample count, with metadata).
#include <string>
#include <utility>
#include <vector>

#include "engine/render/image.h"

namespace tessera {

enum class ToneCurve {
    srgb,   // the sRGB transfer function
    cs184,  // the CS184 app: clamp((√2·L)^(1/2.2))
};

using Metadata = std::vector<std::pair<std::string, std::string>>;

// Each throws std::runtime_error naming the path when the file cannot be written.
void write_png(const std::string& path, const Image& image, ToneCurve curve = ToneCurve::srgb, const Metadata& meta = {});
void write_exr(const std::string& path, const Image& image, const Metadata& meta = {});
// Writes by extension (.png or .exr); anything else is an error.
void write_image(const std::string& path, const Image& image, const Metadata& meta = {});
// The sample-rate heatmap: samples ÷ max_spp from blue (0) through green (0.5) to red (1), the
// CS184 colours; the scale is stated in the file's metadata.
void write_rate_png(const std::string& path, const Image& image, int max_spp, const Metadata& meta = {});

// The same encodings in memory (a server answering with a running job's latest pass, or a
// finished one at another exposure): `exposure_ev` scales the linear values by 2^EV first.
std::vector<unsigned char> png_bytes(const Image& image, float exposure_ev = 0.f);
std::vector<unsigned char> exr_bytes(const Image& image);
std::vector<unsigned char> rate_png_bytes(const Image& image, int max_spp);

// 8-bit encodings, exposed for tests and the server; `gain` multiplies the linear values.
std::vector<unsigned char> encode_srgb8(const Image& image, ToneCurve curve, float gain = 1.f);
std::vector<unsigned char> rate_colors8(const Image& image, int max_spp);

// Reads a float RGB image (EXR or anything OIIO reads) as linear RGB; throws on failure.
Image read_image(const std::string& path);

}  // namespace tessera
