#pragma once
// The boundary between image_io.cpp and the OpenImageIO module (oiio_module.cpp), which is
// loaded on the first image read or written, not at start-up: Debian's OpenImageIO brings 260
// shared libraries (codecs, OpenCV, DICOM, video), and loading them took 0.4-0.6 s of every
// process that linked it, whether or not it touched an image: each `tessera` command, each of
// the test suites' processes (docs/benchmarks.md, "OpenImageIO, loaded when first used").
// Plain standard types only: the module is built from the same compiler and flags as the
// program, and kApiVersion, this header's hash (engine/CMakeLists.txt), guards against a
// stale one.
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace tessera::oiio_module {

#ifndef TESSERA_OIIO_API
#error "TESSERA_OIIO_API is defined by engine/CMakeLists.txt from this header's hash"
#endif
inline constexpr int kApiVersion = TESSERA_OIIO_API;

struct Pixels {
    int width = 0, height = 0, channels = 0;
    bool float_pixels = false;                     // 32-bit float, else 8-bit unsigned
    const void* data = nullptr;                    // interleaved, channels per pixel
    const std::vector<std::string>* names = nullptr;  // channel names (then no alpha or depth channel is implied)
};

struct ReadPixels {
    int width = 0, height = 0;
    std::vector<std::string> names;  // one per channel ("" where the file names none)
    std::vector<float> data;         // names.size() per pixel
};

struct Api {
    int version = kApiVersion;
    // Writes `pixels` with string attributes `meta` to `path`, or into `memory` when it is not
    // null (`path` then only names the format); throws std::runtime_error naming the path.
    void (*write)(const std::string& path, const Pixels& pixels, const std::vector<std::pair<std::string, std::string>>& meta,
                  std::vector<unsigned char>* memory);
    // Reads every channel as float; throws std::runtime_error naming the path, also when the
    // image has fewer than `min_channels` or more than `max_channels` channels or more than
    // `max_pixels` pixels (before anything is allocated for them).
    ReadPixels (*read)(const std::string& path, int min_channels, int max_channels, int64_t max_pixels);
};

}  // namespace tessera::oiio_module

// The module's one exported symbol.
extern "C" const tessera::oiio_module::Api* tessera_oiio_module_api();
