#pragma once
// What the glTF loader's parts share while they convert one file (internal to engine/io): the
// parsed model, the scene being filled and the limits (Ctx), and bounds-checked reads of
// accessors. Every error is a SceneError naming the file and a JSON pointer.
#ifndef TINYGLTF_NO_STB_IMAGE
// Must match engine/io/tinygltf_impl.cpp: these switches change TinyGLTF's inline constructor,
// which would otherwise refer to stb image functions that are not compiled.
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#endif
#include <tiny_gltf.h>

#include <cstdint>
#include <initializer_list>
#include <memory>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "engine/scene/scene_description.h"

namespace tessera::gltf {

SourceLocation at(const std::string& file, const std::string& pointer);
[[noreturn]] void fail(const std::string& file, const std::string& pointer, const std::string& what);
std::string str(uint64_t v);
std::string num(double v);
// tinygltf quotes whole data URIs in some messages, and names are copied per instance: keep
// both bounded.
std::string clip(std::string s, size_t max = 400);
// What is left of `limit` after `used` (0, not a wrap-around).
uint64_t left(uint64_t limit, uint64_t used);

// Each image decoded as tinygltf reaches it, into our own list (tinygltf's Image keeps nothing).
// A failure is kept, not raised: it matters only if a material uses the image, and then the
// error names it.
struct DecodedImages {
    const LoadLimits* limits = nullptr;
    uint64_t budget = 0;
    std::vector<std::shared_ptr<const TextureImage>> images;
    std::vector<std::string> errors;
};

// A node's animated values at the pose being flattened; unset ones keep the node's own.
struct NodeState {
    bool has_t = false, has_r = false, has_s = false, has_weights = false;
    glm::dvec3 t{0.0}, s{1.0};
    glm::dvec4 r{0, 0, 0, 1};  // x y z w
    std::vector<double> weights;
};

struct Ctx {
    const tinygltf::Model& m;
    const std::string& file;
    const LoadLimits& limits;
    SceneDescription& out;
    const DecodedImages& decoded;
    std::vector<NodeState> state{};     // per node; empty: at rest
    std::vector<glm::dmat4> world{};    // per node, once visited
    std::vector<size_t> skinned{};      // nodes whose meshes wait for every joint's world matrix
    std::vector<int> texture_index{};  // glTF texture -> SceneDescription::textures, -1 before use
    std::vector<int> image_index{};    // glTF image -> SceneDescription::images
    int uv_sets_above_1 = 0, missing_uv = 0;
    uint64_t vertices = 0, triangles = 0;
    std::vector<char> on_path{}, visited{};
    int points_lines = 0, no_position = 0, spots = 0, extra_cameras = 0, dropped_normals = 0;
    std::string first_dropped{};
    // Instancing: how many rigid nodes place each mesh (those placed twice or more are stored
    // once, as prototypes), and each primitive's prototype (-1 not yet made, -2 none: no triangles).
    std::vector<uint32_t> mesh_placements{};
    std::vector<std::vector<int>> prototype_of{};
    // Nodes an animation moves (a translation, rotation or scale channel targets them), and
    // those that move with them (their descendants): a rigid mesh there is placed as an
    // instance, so a shot moves it without building its tree again.
    std::vector<char> animated{}, moving{};
};

[[noreturn]] void fail(const Ctx& c, const std::string& pointer, const std::string& what);

// A bounds-checked window onto an accessor: element k starts at data + k * stride.
struct AccessorView {
    const unsigned char* data = nullptr;
    size_t stride = 0;
    size_t count = 0;
    int component_type = 0;
};

// `ref` is the JSON pointer of the reference (e.g. "/meshes/0/primitives/1/indices"); errors
// about the accessor itself point at "/accessors/N". `max_count` is checked before the caller
// allocates anything.
AccessorView view_accessor(const Ctx& c, int index, const std::string& ref, const char* role, int want_type,
                           std::initializer_list<int> want_components, uint64_t max_count, const char* what_is_left);

glm::vec3 read_vec3(const AccessorView& v, size_t k);
uint32_t read_index(const AccessorView& v, size_t k);
bool finite(const glm::dvec3& v);
// Component j of element k: a float, or a normalized byte or short (unsigned for texture
// coordinates and colours; signed too for rotations and morph weights), as glTF allows.
float read_component(const AccessorView& v, size_t k, int j);

}  // namespace tessera::gltf
