#pragma once
// Small glTF files built in a test: buffers as base64 data URIs, GLB containers, and one
// triangle to hang nodes, skins, morph targets and animations on.
#include <cstdint>
#include <initializer_list>
#include <string>
#include <string_view>
#include <utility>

#include <gtest/gtest.h>

#include "engine/io/gltf_loader.h"

namespace tessera::test::gltf {

inline std::string base64(std::string_view in) {
    static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    for (size_t i = 0; i < in.size(); i += 3) {
        uint32_t n = static_cast<uint8_t>(in[i]) << 16;
        if (i + 1 < in.size()) n |= static_cast<uint8_t>(in[i + 1]) << 8;
        if (i + 2 < in.size()) n |= static_cast<uint8_t>(in[i + 2]);
        out += k[(n >> 18) & 63];
        out += k[(n >> 12) & 63];
        out += i + 1 < in.size() ? k[(n >> 6) & 63] : '=';
        out += i + 2 < in.size() ? k[n & 63] : '=';
    }
    return out;
}

// A binary buffer assembled piece by piece; each piece starts 4-aligned, as glTF requires.
struct Blob {
    std::string bytes;
    template <class T>
    size_t add(std::initializer_list<T> values) {
        bytes.resize((bytes.size() + 3) / 4 * 4, '\0');
        const size_t at = bytes.size();
        bytes.append(reinterpret_cast<const char*>(std::data(values)), values.size() * sizeof(T));
        return at;
    }
    std::string uri() const { return "data:application/octet-stream;base64," + base64(bytes); }
};

inline std::string replace_all(std::string s, std::initializer_list<std::pair<std::string, std::string>> subs) {
    for (const auto& [from, to] : subs)
        for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) s.replace(at, from.size(), to);
    return s;
}

inline SceneDescription parse(const std::string& json, const LoadLimits& limits = {}) {
    return parse_gltf(json, false, "", "inline.gltf", limits);
}

inline std::string glb(std::string json, const std::string& bin) {
    json.resize((json.size() + 3) / 4 * 4, ' ');
    std::string bin_padded = bin;
    bin_padded.resize((bin.size() + 3) / 4 * 4, '\0');
    auto u32 = [](uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
    const uint32_t total = static_cast<uint32_t>(12 + 8 + json.size() + (bin.empty() ? 0 : 8 + bin_padded.size()));
    std::string out = "glTF" + u32(2) + u32(total) + u32(static_cast<uint32_t>(json.size())) + u32(0x4E4F534A) + json;
    if (!bin.empty()) out += u32(static_cast<uint32_t>(bin_padded.size())) + u32(0x004E4942) + bin_padded;
    return out;
}

inline const Blob& triangle_blob() {
    static const Blob b = [] {
        Blob blob;
        blob.add<float>({0, 0, 0, 1, 0, 0, 0, 1, 0});
        return blob;
    }();
    return b;
}

// One triangle (0,0,0) (1,0,0) (0,1,0) in mesh 0; the caller supplies nodes, scenes and extras.
inline std::string triangle_file(const std::string& nodes, const std::string& more = "",
                          const std::string& scenes = R"([{"nodes":[0]}])", const std::string& primitive_extra = "") {
    return replace_all(R"({"asset":{"version":"2.0"},"scenes":$SCENES,"nodes":$NODES,
        "meshes":[{"primitives":[{"attributes":{"POSITION":0}$PRIM}]}],
        "buffers":[{"byteLength":36,"uri":"$URI"}],"bufferViews":[{"buffer":0,"byteLength":36}],
        "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}]$MORE})",
                       {{"$SCENES", scenes}, {"$NODES", nodes}, {"$PRIM", primitive_extra}, {"$URI", triangle_blob().uri()},
                        {"$MORE", more.empty() ? "" : "," + more}});
}

inline void expect_near(const glm::vec3& a, const glm::vec3& b, float eps = 1e-5f) {
    EXPECT_NEAR(a.x, b.x, eps);
    EXPECT_NEAR(a.y, b.y, eps);
    EXPECT_NEAR(a.z, b.z, eps);
}

// Runs `f`, expects a SceneError, returns it.
template <class F>
SceneError error_of(F&& f) {
    try {
        f();
    } catch (const SceneError& e) {
        return e;
    }
    ADD_FAILURE() << "no SceneError";
    return SceneError(SourceLocation{}, "none");
}

}  // namespace tessera::test::gltf
