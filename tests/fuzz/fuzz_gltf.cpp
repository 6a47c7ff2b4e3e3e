// Any byte string, read as .gltf text and as .glb, must either load (and pose at any time) or
// raise SceneError.
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
            // At rest, and posed inside, between and outside the keys of every animation at once.
            const auto doc = tessera::GltfDocument::parse(bytes, binary, "", "fuzz.gltf", limits);
            doc->rest();
            for (const auto& a : doc->animations())
                for (double t : {a.start_s - 1, 0.5 * (a.start_s + a.end_s), a.end_s + 1}) doc->pose({t, ""});
        } catch (const tessera::SceneError&) {
        }
    }
    return 0;
}
