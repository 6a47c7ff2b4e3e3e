// Any byte string, read as .gltf text and as .glb, must either load or raise SceneError.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "engine/io/gltf_loader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    tessera::LoadLimits limits;
    limits.max_triangles = 1'000'000;
    limits.max_vertices = 1'000'000;
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    for (bool binary : {false, true}) {
        try {
            tessera::parse_gltf(bytes, binary, "", "fuzz.gltf", limits);
        } catch (const tessera::SceneError&) {
        }
    }
    return 0;
}
