#pragma once
// Arbitrary output variables (render passes for compositing): what a path adds besides its
// radiance, accumulated per sample beside the image in the same film, so that tiles, render
// passes and farm nodes split and merge them as they do the image. ("Pass" already names a
// round of samples in this engine, so the compositing kind is an AOV here and `passes` only in
// the job's JSON.) Only the AOVs a render asks for have room in the film.
#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "engine/render/cryptomatte.h"

namespace tessera {

enum class Aov : uint8_t {
    albedo,            // first non-specular hit's reflectance, texture included (through mirrors and glass)
    normal,            // first hit's shading normal, world space, normal map included
    depth,             // camera distance of the first hit (the pixel's nearest sample)
    position,          // first hit, world space
    object_id,         // the first sample's object (placement or mesh), 0 for none
    material_id,       // the first sample's material, 0 for none
    emission,          // emitters seen directly
    environment,       // the sky and environment seen directly
    diffuse_direct,    // light reaching the first hit straight from a light, reflected diffusely
    diffuse_indirect,  // ... after more bounces
    glossy_direct,     // the same through glossy and specular lobes (mirrors and glass included)
    glossy_indirect,
    variance,          // variance of the pixel's mean, from its samples' second moment
    crypto_object,     // Cryptomatte: the objects the pixel's samples hit, ranked by coverage
    crypto_material,   // ... their materials
    count_
};
inline constexpr int kAovCount = int(Aov::count_);

// How an AOV's samples make its pixel: their mean, their minimum, the first sample's, or
// Cryptomatte's ranks (cryptomatte.h).
enum class AovMerge : uint8_t { mean, min, first, ranked };

struct AovInfo {
    Aov aov;
    const char* name;                      // in the job's `passes` and file names
    int components;                        // 1 or 3; ranked: two per rank (id, coverage)
    AovMerge merge;
    // EXR channel names: layer.R/G/B, layer.X/Y/Z, or the layer alone; ranked: layer00.R/G/B/A,
    // layer01.R/G/B/A, ... (two ranks to a layer, as Cryptomatte names them).
    const char* layer;
    const char* suffixes;                  // "RGB", "XYZ", "" or ranked "RGBA"
};

inline constexpr std::array<AovInfo, kAovCount> kAovInfo{{
    {Aov::albedo, "albedo", 3, AovMerge::mean, "albedo", "RGB"},
    {Aov::normal, "normal", 3, AovMerge::mean, "N", "XYZ"},
    {Aov::depth, "depth", 1, AovMerge::min, "Z", ""},
    {Aov::position, "position", 3, AovMerge::mean, "P", "XYZ"},
    {Aov::object_id, "object_id", 1, AovMerge::first, "object_id", ""},
    {Aov::material_id, "material_id", 1, AovMerge::first, "material_id", ""},
    {Aov::emission, "emission", 3, AovMerge::mean, "emission", "RGB"},
    {Aov::environment, "environment", 3, AovMerge::mean, "environment", "RGB"},
    {Aov::diffuse_direct, "diffuse_direct", 3, AovMerge::mean, "diffuse_direct", "RGB"},
    {Aov::diffuse_indirect, "diffuse_indirect", 3, AovMerge::mean, "diffuse_indirect", "RGB"},
    {Aov::glossy_direct, "glossy_direct", 3, AovMerge::mean, "glossy_direct", "RGB"},
    {Aov::glossy_indirect, "glossy_indirect", 3, AovMerge::mean, "glossy_indirect", "RGB"},
    {Aov::variance, "variance", 3, AovMerge::mean, "variance", "RGB"},
    {Aov::crypto_object, "crypto_object", 2 * kCryptoRanks, AovMerge::ranked, "CryptoObject", "RGBA"},
    {Aov::crypto_material, "crypto_material", 2 * kCryptoRanks, AovMerge::ranked, "CryptoMaterial", "RGBA"},
}};

inline const AovInfo& aov_info(Aov a) { return kAovInfo[size_t(a)]; }

// A set of AOVs as bits, in kAovInfo's order.
using AovSet = uint32_t;
inline constexpr AovSet aov_bit(Aov a) { return AovSet(1) << unsigned(a); }
inline constexpr bool has_aov(AovSet s, Aov a) { return (s & aov_bit(a)) != 0; }
// The light split: the six sum to the image.
inline constexpr AovSet kLightAovs = aov_bit(Aov::emission) | aov_bit(Aov::environment) | aov_bit(Aov::diffuse_direct) |
                                     aov_bit(Aov::diffuse_indirect) | aov_bit(Aov::glossy_direct) | aov_bit(Aov::glossy_indirect);
// Not an AOV: the film keeps its odd samples' sum apart (Film::sum_odd), whose samples come
// from a second, independent scramble (denoise.h: two independent halves).
inline constexpr AovSet kSplitHalves = AovSet(1) << 31;
// What the denoiser reads besides the image.
inline constexpr AovSet kDenoiseAovs =
    aov_bit(Aov::albedo) | aov_bit(Aov::normal) | aov_bit(Aov::depth) | aov_bit(Aov::variance) | kSplitHalves;

// An AOV by its job name; false if there is none.
bool aov_named(std::string_view name, Aov& out);
std::vector<std::string> aov_names(AovSet s);

// Where each AOV of a set lies in a pixel's entry of the film (doubles), and the entry's size.
struct AovLayout {
    AovSet set = 0;
    int stride = 0;
    std::array<int16_t, kAovCount> offset{};  // -1: not kept
    explicit AovLayout(AovSet s = 0);
    bool has(Aov a) const { return offset[size_t(a)] >= 0; }
};

// What one camera sample adds to the AOVs; the integrator fills it beside the radiance.
struct SampleAovs {
    glm::vec3 albedo{0.f}, normal{0.f}, position{0.f};
    float depth = -1.f;  // negative: the camera ray left the scene
    uint32_t object = 0, material = 0;
    uint32_t object_hash = 0, material_hash = 0;  // Cryptomatte: their names' hashes
    glm::vec3 emission{0.f}, environment{0.f}, diffuse_direct{0.f}, diffuse_indirect{0.f}, glossy_direct{0.f}, glossy_indirect{0.f};
};

// One AOV resolved: `components` floats per pixel, row 0 at the top.
struct AovPlane {
    Aov aov;
    int components = 0;
    std::vector<float> values;
};

// Depth where a pixel saw nothing, as Blender writes it.
inline constexpr double kNoDepth = 1e10;

// Adds a sample (radiance L, its AOVs) to a pixel's entry; `first` for its first sample.
void add_sample_aovs(const AovLayout& layout, double* entry, const SampleAovs& s, const glm::vec3& L, bool first);
// Clears an entry to its empty value (depth: none yet).
void clear_aovs(const AovLayout& layout, double* entry);

}  // namespace tessera
