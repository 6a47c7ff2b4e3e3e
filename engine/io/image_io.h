#pragma once
// Writing images through OpenImageIO (a module loaded on first use): PNG (sRGB-encoded, clamped, 8 bit) and EXR (linear
// float RGB plus the per-pixel sample count, with metadata).
#include <string>
#include <utility>
#include <vector>

#include "engine/render/aov.h"
#include "engine/render/image.h"

namespace tessera {

enum class ToneCurve {
    srgb,   // the sRGB transfer function
    cs184,  // the CS184 app: clamp((√2·L)^(1/2.2))
};

using Metadata = std::vector<std::pair<std::string, std::string>>;

// `meta` then `more` (a writer's own attributes before the caller's).
inline Metadata with(Metadata meta, const Metadata& more) {
    meta.insert(meta.end(), more.begin(), more.end());
    return meta;
}

// Each throws std::runtime_error naming the path when the file cannot be written.
void write_png(const std::string& path, const Image& image, ToneCurve curve = ToneCurve::srgb, const Metadata& meta = {});
void write_exr(const std::string& path, const Image& image, const Metadata& meta = {});
// A multilayer OpenEXR: the image (R, G, B, samples) and each AOV under the channel names
// compositors read (albedo.R, N.X, Z, …; engine/render/aov.h), all 32-bit float. A plane whose
// components or values are not its pass's for every pixel throws std::invalid_argument, and
// nothing is written (so does write_aov_exr).
void write_layers_exr(const std::string& path, const Image& image, const std::vector<AovPlane>& aovs, const Metadata& meta = {});
// One AOV alone (its channels as in the multilayer file).
void write_aov_exr(const std::string& path, int width, int height, const AovPlane& aov, const Metadata& meta = {});
// The channel names of an AOV in those files.
std::vector<std::string> aov_channel_names(Aov aov);
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

// Every channel of an image file as float, by name (a multilayer EXR's passes); throws on failure.
struct ChannelImage {
    int width = 0, height = 0;
    std::vector<std::string> names;
    std::vector<float> data;  // names.size() per pixel
    // The channel's values, one per pixel; throws if there is no such channel.
    std::vector<float> channel(const std::string& name) const;
};
ChannelImage read_channels(const std::string& path);

// Reads a float RGB image (EXR or anything OIIO reads) as linear RGB; throws on failure.
Image read_image(const std::string& path);

// Image files are read and written by OpenImageIO in a module loaded on first use
// (engine/io/oiio_module.h says why). A server loads it at start, so that a missing module
// stops it there rather than failing its first job; throws std::runtime_error saying where it
// looked.
void load_image_io();

}  // namespace tessera
