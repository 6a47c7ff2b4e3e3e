// The OpenImageIO calls, built as a module that image_io.cpp loads when an image is first read
// or written (oiio_module.h says why).
#include "engine/io/oiio_module.h"

#include <memory>
#include <stdexcept>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

namespace tessera::oiio_module {
namespace {

void write(const std::string& path, const Pixels& px, const std::vector<std::pair<std::string, std::string>>& meta,
           std::vector<unsigned char>* memory) {
    const OIIO::TypeDesc type = px.float_pixels ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8;
    OIIO::ImageSpec spec(px.width, px.height, px.channels, type);
    if (px.names) {
        spec.channelnames = *px.names;
        spec.alpha_channel = -1;  // the fourth channel is data (a sample count), not coverage
        spec.z_channel = -1;
    }
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
    if (!out->write_image(type, px.data)) throw std::runtime_error(path + ": " + out->geterror());
    if (!out->close()) throw std::runtime_error(path + ": " + out->geterror());
}

ReadPixels read(const std::string& path, int min_channels, int max_channels, int64_t max_pixels) {
    auto in = OIIO::ImageInput::open(path);
    if (!in) throw std::runtime_error(path + ": " + OIIO::geterror());
    const OIIO::ImageSpec& spec = in->spec();
    if (spec.width <= 0 || spec.height <= 0 || spec.nchannels < min_channels || spec.nchannels > max_channels ||
        int64_t(spec.width) * spec.height > max_pixels)
        throw std::runtime_error(path + (min_channels >= 3 ? ": not an RGB image of a sensible size" : ": not an image of a sensible size"));
    ReadPixels r;
    r.width = spec.width;
    r.height = spec.height;
    r.names = spec.channelnames;
    r.names.resize(size_t(spec.nchannels));  // a name for every channel: the names are the data's stride
    r.data.resize(size_t(spec.width) * size_t(spec.height) * size_t(spec.nchannels));
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, r.data.data())) throw std::runtime_error(path + ": " + in->geterror());
    in->close();
    return r;
}

const Api kApi{kApiVersion, &write, &read};

}  // namespace
}  // namespace tessera::oiio_module

extern "C" const tessera::oiio_module::Api* tessera_oiio_module_api() { return &tessera::oiio_module::kApi; }
