// Any byte string must either load or raise SceneError: no crash, no other exception.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "engine/io/collada_loader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    tessera::LoadLimits limits;
    limits.max_triangles = 1'000'000;
    limits.max_vertices = 1'000'000;
    try {
        tessera::parse_collada(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.dae", limits);
    } catch (const tessera::SceneError&) {
    }
    return 0;
}
