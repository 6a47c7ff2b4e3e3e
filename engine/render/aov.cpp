#include "engine/render/aov.h"

#include <algorithm>

namespace tessera {

bool aov_named(std::string_view name, Aov& out) {
    for (const AovInfo& i : kAovInfo)
        if (name == i.name) {
            out = i.aov;
            return true;
        }
    return false;
}

std::vector<std::string> aov_names(AovSet s) {
    std::vector<std::string> names;
    for (const AovInfo& i : kAovInfo)
        if (has_aov(s, i.aov)) names.emplace_back(i.name);
    return names;
}

AovLayout::AovLayout(AovSet s) : set(s & ~kSplitHalves) {
    offset.fill(-1);
    for (const AovInfo& i : kAovInfo)
        if (has_aov(s, i.aov)) {
            offset[size_t(i.aov)] = int16_t(stride);
            stride += i.components;
        }
}

void clear_aovs(const AovLayout& layout, double* entry) {
    std::fill(entry, entry + layout.stride, 0.0);
    if (layout.has(Aov::depth)) entry[layout.offset[size_t(Aov::depth)]] = kNoDepth;
}

void add_sample_aovs(const AovLayout& layout, double* entry, const SampleAovs& s, const glm::vec3& L, bool first) {
    auto add3 = [&](Aov a, const glm::vec3& v) {
        const int o = layout.offset[size_t(a)];
        if (o < 0) return;
        entry[o] += double(v.x);
        entry[o + 1] += double(v.y);
        entry[o + 2] += double(v.z);
    };
    add3(Aov::albedo, s.albedo);
    add3(Aov::normal, s.normal);
    add3(Aov::position, s.position);
    add3(Aov::emission, s.emission);
    add3(Aov::environment, s.environment);
    add3(Aov::diffuse_direct, s.diffuse_direct);
    add3(Aov::diffuse_indirect, s.diffuse_indirect);
    add3(Aov::glossy_direct, s.glossy_direct);
    add3(Aov::glossy_indirect, s.glossy_indirect);
    if (const int o = layout.offset[size_t(Aov::variance)]; o >= 0) {
        // The second moment; the variance of the mean follows from it and the sum at resolve.
        entry[o] += double(L.x) * double(L.x);
        entry[o + 1] += double(L.y) * double(L.y);
        entry[o + 2] += double(L.z) * double(L.z);
    }
    if (const int o = layout.offset[size_t(Aov::depth)]; o >= 0 && s.depth >= 0.f) entry[o] = std::min(entry[o], double(s.depth));
    if (s.object) {
        if (const int o = layout.offset[size_t(Aov::crypto_object)]; o >= 0) add_crypto_sample(entry + o, s.object_hash);
        if (const int o = layout.offset[size_t(Aov::crypto_material)]; o >= 0) add_crypto_sample(entry + o, s.material_hash);
    }
    if (first) {
        if (const int o = layout.offset[size_t(Aov::object_id)]; o >= 0) entry[o] = double(s.object);
        if (const int o = layout.offset[size_t(Aov::material_id)]; o >= 0) entry[o] = double(s.material);
    }
}

}  // namespace tessera
