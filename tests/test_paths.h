#pragma once
// Where tests find the shared scene folders: the CMake cache path, overridable by environment
// (TESSERA_CS184_DIR, TESSERA_GLTF_SAMPLES_DIR, TESSERA_GLTF_PBR_DIR, TESSERA_GLTF_ANIM_DIR). A test that needs them skips, saying why,
// when the folder is absent (a user's fresh clone); .ci/run insists that they are present.
#include "build_paths.h"
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>

namespace tessera::test {

inline std::optional<std::string> shared_dir(const char* env, const char* configured) {
    const char* e = std::getenv(env);
    std::string dir = (e && *e) ? e : configured;
    if (std::filesystem::is_directory(dir)) return dir;
    return std::nullopt;
}

inline std::optional<std::string> cs184_dir() {
    return shared_dir("TESSERA_CS184_DIR", TESSERA_CS184_DIR);
}
inline std::optional<std::string> gltf_samples_dir() {
    return shared_dir("TESSERA_GLTF_SAMPLES_DIR", TESSERA_GLTF_SAMPLES_DIR);
}
inline std::optional<std::string> gltf_pbr_dir() {
    return shared_dir("TESSERA_GLTF_PBR_DIR", TESSERA_GLTF_PBR_DIR);
}
inline std::optional<std::string> gltf_anim_dir() {
    return shared_dir("TESSERA_GLTF_ANIM_DIR", TESSERA_GLTF_ANIM_DIR);
}

// CI sets TESSERA_REQUIRE_SHARED=1: there a missing folder fails the test instead of skipping it.
inline bool shared_required() {
    const char* e = std::getenv("TESSERA_REQUIRE_SHARED");
    return e && *e && std::string(e) != "0";
}

}  // namespace tessera::test

// Use at the top of a test: binds `dir`, or skips (fails in CI) with the reason.
#define TESSERA_REQUIRE_SHARED_DIR(dir, finder, what)                                          \
    auto dir##_opt = ::tessera::test::finder();                                                 \
    if (!dir##_opt) {                                                                           \
        if (::tessera::test::shared_required()) FAIL() << "needs " what "; not found";          \
        GTEST_SKIP() << "needs " what "; not found";                                            \
    }                                                                                           \
    const std::string dir = *dir##_opt
#define TESSERA_REQUIRE_CS184(dir) \
    TESSERA_REQUIRE_SHARED_DIR(dir, cs184_dir, "the CS184 scenes (../shared/scenes/cs184 or TESSERA_CS184_DIR)")
#define TESSERA_REQUIRE_GLTF_SAMPLES(dir)        \
    TESSERA_REQUIRE_SHARED_DIR(dir, gltf_samples_dir, \
                               "the glTF samples (../shared/scenes/gltf-samples or TESSERA_GLTF_SAMPLES_DIR)")
