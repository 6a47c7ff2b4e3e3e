#include "engine/io/image_io.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

namespace tessera {
namespace {

float srgb_encode(float v) {
    v = std::clamp(v, 0.f, 1.f);
    return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.f / 2.4f) - 0.055f;
}

float cs184_encode(float v) { return std::clamp(std::pow(std::max(0.f, std::sqrt(2.f) * v), 1.f / 2.2f), 0.f, 1.f); }

// Writes a file, or into `memory` through an I/O proxy (`path` then only names the format).
void write(const std::string& path, OIIO::ImageSpec spec, OIIO::TypeDesc type, const void* data, const Metadata& meta,
           std::vector<unsigned char>* memory = nullptr) {
    for (const auto& [k, v] : meta) spec.attribute(k, v);
    // Before the writer: it is destroyed after it, so a writer closing on an error path never
    // writes through a freed proxy.
    std::unique_ptr<OIIO::Filesystem::IOVecOutput> proxy;
    auto out = OIIO::ImageOutput::create(path);
    if (!out) throw std::runtime_error(path + ": cannot create an image writer: " + OIIO::geterror());
    if (memory) {
        proxy = std::make_unique<OIIO::Filesystem::IOVecOutput>(*memory);
        if (!out->supports("ioproxy") || !out->set_ioproxy(proxy.get()))
            throw std::runtime_error(path + ": the writer cannot encode into memory");
    }
    if (!out->open(path, spec)) throw std::runtime_error(path + ": " + out->geterror());
    if (!out->write_image(type, data)) throw std::runtime_error(path + ": " + out->geterror());
    if (!out->close()) throw std::runtime_error(path + ": " + out->geterror());
}

bool ends_with(const std::string& s, const std::string& suffix) {
    if (s.size() < suffix.size()) return false;
    return std::equal(suffix.rbegin(), suffix.rend(), s.rbegin(),
                      [](char a, char b) { return std::tolower(a) == std::tolower(b); });
}

}  // namespace

std::vector<unsigned char> encode_srgb8(const Image& image, ToneCurve curve, float gain) {
    std::vector<unsigned char> px(image.rgb.size());
    for (size_t i = 0; i < px.size(); ++i) {
        const float x = image.rgb[i] * gain;
        const float v = curve == ToneCurve::srgb ? srgb_encode(x) : cs184_encode(x);
        px[i] = static_cast<unsigned char>(std::lround(v * 255.f));
    }
    return px;
}

std::vector<unsigned char> rate_colors8(const Image& image, int max_spp) {
    std::vector<unsigned char> px(image.sample_count.size() * 3);
    for (size_t i = 0; i < image.sample_count.size(); ++i) {
        const float r = max_spp > 0 ? std::clamp(image.sample_count[i] / float(max_spp), 0.f, 1.f) : 0.f;
        float c[3];
        if (r < 0.5f) { const float t = 2.f * r; c[0] = 0; c[1] = t; c[2] = 1 - t; }
        else { const float t = 2.f * r - 1.f; c[0] = t; c[1] = 1 - t; c[2] = 0; }
        for (int k = 0; k < 3; ++k) px[i * 3 + k] = static_cast<unsigned char>(std::lround(c[k] * 255.f));
    }
    return px;
}

// PNG, or any 8-bit format OIIO picks by the extension (the docs' figures are JPEG).
namespace {

void png_out(const std::string& path, const Image& image, ToneCurve curve, float gain, const Metadata& meta,
             std::vector<unsigned char>* memory) {
    const auto px = encode_srgb8(image, curve, gain);
    OIIO::ImageSpec spec(image.width, image.height, 3, OIIO::TypeDesc::UINT8);
    spec.attribute("oiio:ColorSpace", curve == ToneCurve::srgb ? "sRGB" : "CS184 gamma 2.2 with sqrt(2) exposure");
    write(path, spec, OIIO::TypeDesc::UINT8, px.data(), meta, memory);
}

void exr_out(const std::string& path, const Image& image, const Metadata& meta, std::vector<unsigned char>* memory) {
    const size_t n = size_t(image.width) * image.height;
    std::vector<float> data(n * 4);
    for (size_t i = 0; i < n; ++i) {
        for (int k = 0; k < 3; ++k) data[i * 4 + k] = image.rgb[i * 3 + k];
        data[i * 4 + 3] = image.sample_count.empty() ? 0.f : image.sample_count[i];
    }
    OIIO::ImageSpec spec(image.width, image.height, 4, OIIO::TypeDesc::FLOAT);
    spec.channelnames = {"R", "G", "B", "samples"};
    spec.alpha_channel = -1;  // the fourth channel is data, not coverage
    spec.attribute("oiio:ColorSpace", "Linear");
    spec.attribute("compression", "zip");
    write(path, spec, OIIO::TypeDesc::FLOAT, data.data(), meta, memory);
}

void layers_out(const std::string& path, int width, int height, const Image* image, const std::vector<AovPlane>& aovs,
                const Metadata& meta) {
    std::vector<std::string> names;
    if (image) names = {"R", "G", "B", "samples"};
    const size_t n = size_t(width) * height;
    for (const AovPlane& a : aovs) {
        const std::vector<std::string> ch = aov_channel_names(a.aov);
        // A plane that holds other than its pass's channels for every pixel would write zeros or
        // another pass's values under its names.
        if (size_t(a.components) != ch.size() || a.values.size() != n * ch.size())
            throw std::invalid_argument(path + ": the " + std::string(aov_info(a.aov).name) + " plane holds " +
                                        std::to_string(a.values.size()) + " values in " + std::to_string(a.components) +
                                        " components, not " + std::to_string(ch.size()) + " for each of " + std::to_string(n) + " pixels");
        for (const std::string& c : ch) names.push_back(c);
    }
    const size_t nc = names.size();
    std::vector<float> data(n * nc);
    for (size_t i = 0; i < n; ++i) {
        float* px = &data[i * nc];
        if (image) {
            for (int k = 0; k < 3; ++k) *px++ = image->rgb[i * 3 + k];
            *px++ = image->sample_count.empty() ? 0.f : image->sample_count[i];
        }
        for (const AovPlane& a : aovs)
            for (int k = 0; k < a.components; ++k) *px++ = a.values[i * size_t(a.components) + size_t(k)];
    }
    OIIO::ImageSpec spec(width, height, int(nc), OIIO::TypeDesc::FLOAT);
    spec.channelnames = names;
    spec.alpha_channel = -1;
    spec.z_channel = -1;
    spec.attribute("oiio:ColorSpace", "Linear");
    spec.attribute("compression", "zip");
    write(path, spec, OIIO::TypeDesc::FLOAT, data.data(), meta);
}

void rate_out(const std::string& path, const Image& image, int max_spp, const Metadata& meta, std::vector<unsigned char>* memory) {
    const auto px = rate_colors8(image, max_spp);
    OIIO::ImageSpec spec(image.width, image.height, 3, OIIO::TypeDesc::UINT8);
    spec.attribute("tessera:rate_scale", "blue = 0, green = 0.5, red = 1 x " + std::to_string(max_spp) + " samples per pixel");
    write(path, spec, OIIO::TypeDesc::UINT8, px.data(), meta, memory);
}

}  // namespace

void write_png(const std::string& path, const Image& image, ToneCurve curve, const Metadata& meta) {
    png_out(path, image, curve, 1.f, meta, nullptr);
}

void write_exr(const std::string& path, const Image& image, const Metadata& meta) { exr_out(path, image, meta, nullptr); }

std::vector<unsigned char> png_bytes(const Image& image, float exposure_ev) {
    std::vector<unsigned char> bytes;
    png_out("image.png", image, ToneCurve::srgb, std::exp2(exposure_ev), {}, &bytes);
    return bytes;
}

std::vector<unsigned char> exr_bytes(const Image& image) {
    std::vector<unsigned char> bytes;
    exr_out("image.exr", image, {}, &bytes);
    return bytes;
}

std::vector<unsigned char> rate_png_bytes(const Image& image, int max_spp) {
    std::vector<unsigned char> bytes;
    rate_out("rate.png", image, max_spp, {}, &bytes);
    return bytes;
}

void write_image(const std::string& path, const Image& image, const Metadata& meta) {
    if (ends_with(path, ".png") || ends_with(path, ".jpg")) write_png(path, image, ToneCurve::srgb, meta);
    else if (ends_with(path, ".exr")) write_exr(path, image, meta);
    else throw std::runtime_error(path + ": unknown image format (use .png or .exr)");
}

void write_rate_png(const std::string& path, const Image& image, int max_spp, const Metadata& meta) {
    rate_out(path, image, max_spp, meta, nullptr);
}

std::vector<std::string> aov_channel_names(Aov aov) {
    const AovInfo& info = aov_info(aov);
    std::vector<std::string> names;
    const std::string suffixes = info.suffixes;
    if (info.merge == AovMerge::ranked) {
        for (int r = 0; r < info.components; ++r) {
            char layer[64];
            std::snprintf(layer, sizeof layer, "%s%02d.%c", info.layer, r / 4, suffixes[size_t(r % 4)]);
            names.emplace_back(layer);
        }
        return names;
    }
    if (suffixes.empty()) names.emplace_back(info.layer);
    for (char c : suffixes) names.push_back(std::string(info.layer) + "." + c);
    return names;
}

void write_layers_exr(const std::string& path, const Image& image, const std::vector<AovPlane>& aovs, const Metadata& meta) {
    layers_out(path, image.width, image.height, &image, aovs, meta);
}

void write_aov_exr(const std::string& path, int width, int height, const AovPlane& aov, const Metadata& meta) {
    layers_out(path, width, height, nullptr, {aov}, meta);
}

ChannelImage read_channels(const std::string& path) {
    auto in = OIIO::ImageInput::open(path);
    if (!in) throw std::runtime_error(path + ": " + OIIO::geterror());
    const OIIO::ImageSpec& spec = in->spec();
    if (spec.width <= 0 || spec.height <= 0 || spec.nchannels < 1 || spec.nchannels > 256 || int64_t(spec.width) * spec.height > (1ll << 26))
        throw std::runtime_error(path + ": not an image of a sensible size");
    ChannelImage c;
    c.width = spec.width;
    c.height = spec.height;
    c.names = spec.channelnames;
    c.data.resize(size_t(spec.width) * spec.height * size_t(spec.nchannels));
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, c.data.data())) throw std::runtime_error(path + ": " + in->geterror());
    in->close();
    return c;
}

std::vector<float> ChannelImage::channel(const std::string& name) const {
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end()) throw std::runtime_error("no channel " + name);
    const size_t k = size_t(it - names.begin()), nc = names.size(), n = size_t(width) * size_t(height);
    std::vector<float> v(n);
    for (size_t i = 0; i < n; ++i) v[i] = data[i * nc + k];
    return v;
}

Image read_image(const std::string& path) {
    auto in = OIIO::ImageInput::open(path);
    if (!in) throw std::runtime_error(path + ": " + OIIO::geterror());
    const OIIO::ImageSpec& spec = in->spec();
    if (spec.width <= 0 || spec.height <= 0 || spec.nchannels < 3 || spec.nchannels > 64 || int64_t(spec.width) * spec.height > (1ll << 28))
        throw std::runtime_error(path + ": not an RGB image of a sensible size");
    std::vector<float> all(size_t(spec.width) * spec.height * spec.nchannels);
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, all.data()))
        throw std::runtime_error(path + ": " + in->geterror());
    Image img(spec.width, spec.height);
    for (size_t i = 0; i < size_t(spec.width) * spec.height; ++i)
        for (int k = 0; k < 3; ++k) img.rgb[i * 3 + k] = all[i * spec.nchannels + k];
    int samples = -1;
    for (int c = 0; c < spec.nchannels; ++c) if (spec.channelnames[c] == "samples") samples = c;
    if (samples >= 0)
        for (size_t i = 0; i < size_t(spec.width) * spec.height; ++i) img.sample_count[i] = all[i * spec.nchannels + samples];
    in->close();
    return img;
}

}  // namespace tessera
