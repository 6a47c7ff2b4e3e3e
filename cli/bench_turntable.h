#pragma once
// The benchmarks' animated scene: a turntable of a displaced sphere on a ground plane, written
// as one self-contained glTF file (`tessera bench shot`, and the farm's shot in `bench cluster`).
#include <cstdint>
#include <filesystem>
#include <string>

namespace tessera::cli {

// Writes turntable.gltf into `dir`: the sphere (`triangles` of it) turns once about y in
// `seconds`, LINEAR keys every quarter turn. `deform`: it does not turn but deforms, a morph
// target (a twist about y and a ripple) weighted 0 → 1 → 0 over `seconds`, so it is a
// world-space mesh whose tree each frame must refit or rebuild. Returns the file's path.
std::string write_turntable(const std::filesystem::path& dir, uint64_t triangles, double seconds, bool deform = false);

}  // namespace tessera::cli
