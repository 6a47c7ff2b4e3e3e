#include "engine/io/image_io.h"

#include <dlfcn.h>
#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>

#include "engine/io/oiio_module.h"

namespace tessera {
namespace {

float srgb_encode(float v) {
    v = std::clamp(v, 0.f, 1.f);
    return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.f / 2.4f) - 0.055f;
}

float cs184_encode(float v) { return std::clamp(std::pow(std::max(0.f, std::sqrt(2.f) * v), 1.f / 2.2f), 0.f, 1.f); }

// Where the OpenImageIO module may be: named by TESSERA_OIIO_MODULE (a binary copied away from
// its build), installed beside the program (lib/tessera/ next to its bin/, as in the container
// image), or in the build tree that built it (engine/ beside tests/ and cli/, two up from
// tests/fuzz/). Relative to the program, so no absolute path is compiled in.
std::vector<std::string> module_candidates() {
    std::vector<std::string> paths;
    if (const char* env = std::getenv("TESSERA_OIIO_MODULE"); env && *env) paths.emplace_back(env);
    char exe[PATH_MAX];
    const ssize_t n = ::readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n > 0) {
        exe[n] = '\0';
        const std::filesystem::path dir = std::filesystem::path(exe).parent_path();
        paths.push_back((dir.parent_path() / "lib" / "tessera" / "libtessera_oiio.so").string());
        paths.push_back((dir.parent_path() / "engine" / "libtessera_oiio.so").string());
        paths.push_back((dir.parent_path().parent_path() / "engine" / "libtessera_oiio.so").string());
    }
    return paths;
}

const oiio_module::Api* load_module() {
    std::string tried;
    for (const std::string& path : module_candidates()) {
        std::error_code ec;
        if (!std::filesystem::exists(path, ec)) {
            tried += "\n  " + path + ": no such file";
            continue;
        }
        // RTLD_LOCAL: OpenImageIO's libraries stay out of the program's symbol lookups.
        void* h = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
        if (!h) {
            tried += "\n  " + path + ": " + ::dlerror();
            continue;
        }
        using Entry = const oiio_module::Api* (*)();
        const auto entry = reinterpret_cast<Entry>(::dlsym(h, "tessera_oiio_module_api"));
        const oiio_module::Api* api = entry ? entry() : nullptr;
        if (api && api->version == oiio_module::kApiVersion) return api;
        ::dlclose(h);
        tried += "\n  " + path + ": not this build's module (rebuild it)";
    }
    throw std::runtime_error("image files need the OpenImageIO module libtessera_oiio.so, and none could be loaded:" + tried);
}

// Loaded once, by the first thread that reads or writes an image (a failure is retried).
const oiio_module::Api& oiio() {
    static const oiio_module::Api* api = load_module();
    return *api;
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
    oiio().write(path, {image.width, image.height, 3, false, px.data(), nullptr},
                 with({{"oiio:ColorSpace", curve == ToneCurve::srgb ? "sRGB" : "CS184 gamma 2.2 with sqrt(2) exposure"}}, meta), memory);
}

void exr_out(const std::string& path, const Image& image, const Metadata& meta, std::vector<unsigned char>* memory) {
    const size_t n = size_t(image.width) * image.height;
    std::vector<float> data(n * 4);
    for (size_t i = 0; i < n; ++i) {
        for (int k = 0; k < 3; ++k) data[i * 4 + k] = image.rgb[i * 3 + k];
        data[i * 4 + 3] = image.sample_count.empty() ? 0.f : image.sample_count[i];
    }
    const std::vector<std::string> names = {"R", "G", "B", "samples"};
    oiio().write(path, {image.width, image.height, 4, true, data.data(), &names},
                 with({{"oiio:ColorSpace", "Linear"}, {"compression", "zip"}}, meta), memory);
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
    oiio().write(path, {width, height, int(nc), true, data.data(), &names},
                 with({{"oiio:ColorSpace", "Linear"}, {"compression", "zip"}}, meta), nullptr);
}

void rate_out(const std::string& path, const Image& image, int max_spp, const Metadata& meta, std::vector<unsigned char>* memory) {
    const auto px = rate_colors8(image, max_spp);
    oiio().write(path, {image.width, image.height, 3, false, px.data(), nullptr},
                 with({{"tessera:rate_scale", "blue = 0, green = 0.5, red = 1 x " + std::to_string(max_spp) + " samples per pixel"}}, meta),
                 memory);
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
    oiio_module::ReadPixels r = oiio().read(path, 1, 256, int64_t(1) << 26);
    ChannelImage c;
    c.width = r.width;
    c.height = r.height;
    c.names = std::move(r.names);
    c.data = std::move(r.data);
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
    const oiio_module::ReadPixels r = oiio().read(path, 3, 64, int64_t(1) << 28);
    const size_t nc = r.names.size(), n = size_t(r.width) * size_t(r.height);
    Image img(r.width, r.height);
    for (size_t i = 0; i < n; ++i)
        for (size_t k = 0; k < 3; ++k) img.rgb[i * 3 + k] = r.data[i * nc + k];
    const auto samples = std::find(r.names.begin(), r.names.end(), "samples");
    if (samples != r.names.end()) {
        const size_t k = size_t(samples - r.names.begin());
        for (size_t i = 0; i < n; ++i) img.sample_count[i] = r.data[i * nc + k];
    }
    return img;
}

void load_image_io() { oiio(); }

}  // namespace tessera
