// glTF 2.0 -> SceneDescription. tinygltf parses the JSON and decodes buffers; everything it does
// not check (accessor bounds, index ranges, the node graph, external paths) is checked here,
// before anything is allocated, because glTF files come from users and fuzzers.
#include "engine/io/gltf_loader.h"

#include "engine/io/gltf_animation_reader.h"
#include "engine/io/gltf_context.h"

#include <nlohmann/json.hpp>

#include "engine/io/json_depth.h"
#include "engine/io/texture_decode.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <optional>

namespace tessera {
namespace {

using namespace gltf;
namespace fs = std::filesystem;
static_assert(std::endian::native == std::endian::little, "glTF buffers are little-endian and read by memcpy");

// tinygltf copies `extras` and `extensions` into its Value tree recursively, so a deeply nested
// document would overflow the stack there. Real files nest fewer than ten levels.
// Extensions whose content is read; anything else in extensionsRequired is refused.
constexpr const char* kSupportedExtensions[] = {"KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_materials_ior",
                                                "KHR_materials_specular", "KHR_texture_transform"};

constexpr const char* kVerticesLeft = "vertices left under LoadLimits::max_vertices";

void check_json_depth(std::string_view json, const std::string& file, int max_depth) {
    if (json_nesting_depth(json, max_depth) > max_depth)
        fail(file, "", "JSON nests deeper than " + str(max_depth) + " levels, the limit for a scene's JSON");
}

uint32_t read_u32(std::string_view b, size_t at) {
    uint32_t v;
    std::memcpy(&v, b.data() + at, 4);
    return v;
}

// Checks the GLB container before tinygltf reads it: tinygltf 2.7 accepts a BIN chunk whose
// declared length runs up to 8 bytes past the end (it forgets the chunk header) and then copies
// from beyond the input. Returns the JSON chunk; the file's declared length goes to `length`.
std::string_view check_glb(std::string_view b, const std::string& file, size_t& length) {
    if (b.size() < 20)
        fail(file, "", "truncated GLB: " + str(b.size()) + " bytes, the headers alone need 20");
    if (b.substr(0, 4) != "glTF") fail(file, "", "not a GLB file (the magic is not 'glTF')");
    if (read_u32(b, 4) != 2) fail(file, "", "GLB container version " + str(read_u32(b, 4)) + " is not supported (need 2)");
    length = read_u32(b, 8);
    if (length > b.size())
        fail(file, "", "GLB header declares " + str(length) + " bytes but there are only " + str(b.size()));
    if (length < 20) fail(file, "", "GLB header declares only " + str(length) + " bytes");
    const uint64_t json_len = read_u32(b, 12);
    if (read_u32(b, 16) != 0x4E4F534Au) fail(file, "", "the first GLB chunk is not JSON");
    if (json_len > length - 20)
        fail(file, "", "GLB JSON chunk of " + str(json_len) + " bytes runs past the end of the file");
    const uint64_t bin_at = 20 + json_len;
    if (bin_at < length) {
        if (length - bin_at < 8) fail(file, "", "truncated GLB: incomplete BIN chunk header");
        const uint64_t bin_len = read_u32(b, bin_at);
        if (bin_len > length - bin_at - 8)
            fail(file, "", "GLB BIN chunk of " + str(bin_len) + " bytes runs past the end of the file");
    }
    return b.substr(20, json_len);
}

// tinygltf 2.7 hands image loaders &buffer.data[bufferView.byteOffset] without checking the
// offset: undefined behaviour for a hostile offset (an abort under _GLIBCXX_ASSERTIONS), although
// the bytes are never read. Images are the only such place, so their bufferViews are checked first against
// the declared buffer sizes (tinygltf makes decoded buffers exactly that long). This parses the
// JSON a second time, hence only when there are images, keeping only the three arrays involved.
void check_image_views(std::string_view text, const std::string& file) {
    using nlohmann::json;
    if (text.find("\"images\"") == std::string_view::npos) return;
    const json::parser_callback_t keep = [](int depth, json::parse_event_t event, json& parsed) {
        if (event != json::parse_event_t::key) return true;
        const auto& key = parsed.get_ref<const std::string&>();
        if (depth == 1) return key == "images" || key == "bufferViews" || key == "buffers";
        return key == "bufferView" || key == "buffer" || key == "byteOffset" || key == "byteLength";
    };
    const json doc = json::parse(text.begin(), text.end(), keep, /*allow_exceptions=*/false);
    if (!doc.is_object() || !doc.contains("images") || !doc["images"].is_array()) return;  // tinygltf reports it
    auto index = [](const json& o, const char* key) -> std::optional<uint64_t> {
        if (!o.is_object() || !o.contains(key) || !o[key].is_number_unsigned()) return std::nullopt;
        return o[key].get<uint64_t>();
    };
    static const json none;
    const json& views = doc.contains("bufferViews") ? doc["bufferViews"] : none;
    const json& buffers = doc.contains("buffers") ? doc["buffers"] : none;
    for (const json& image : doc["images"]) {
        const auto v = index(image, "bufferView");
        if (!v || !views.is_array() || *v >= views.size()) continue;
        const json& view = views[*v];
        const auto b = index(view, "buffer");
        if (!b || !buffers.is_array() || *b >= buffers.size()) continue;
        const uint64_t offset = index(view, "byteOffset").value_or(0), length = index(view, "byteLength").value_or(0);
        const uint64_t size = index(buffers[*b], "byteLength").value_or(0);
        if (offset > size || length > size - offset)
            fail(file, "/bufferViews/" + str(*v), "byteOffset " + str(offset) + " + byteLength " + str(length) +
                                                      " exceeds buffer " + str(*b) + " of " + str(size) + " bytes");
    }
}

// --- external files -------------------------------------------------------------------------
// tinygltf joins base_dir and the (URL-decoded) URI itself, then also tries the working
// directory, and names the joined path in its messages ("File is empty : <path>"). We hand it
// the folder as the file is shown (its name's folder, so its messages name a file as the
// server's clients know it, never the server's folders), recover the URI from the joined path,
// refuse anything that is absolute, has a scheme or resolves outside the scene's folder, and
// read the rest from the real folder.
struct FileGuard {
    std::string prefix;  // the folder as shown + '/' ("./" for none); empty = no external files at all
    fs::path root;       // the real folder, canonical
    uint64_t max_bytes = 0;
    std::string refusal;  // why a file was refused, for the error message
    std::vector<std::string> read;  // the files read, by their real paths
};

bool guard_exists(const std::string& path, void* user) {
    const auto* g = static_cast<const FileGuard*>(user);
    // Say yes to the scene-folder candidate (or to anything when files are forbidden) so that
    // guard_read gets to refuse it with a reason; never to the working-directory candidate.
    return g->prefix.empty() || path.starts_with(g->prefix);
}

std::string guard_expand(const std::string& path, void*) { return path; }

bool guard_read(std::vector<unsigned char>* out, std::string* err, const std::string& path, void* user) {
    auto* g = static_cast<FileGuard*>(user);
    auto refuse = [&](const std::string& uri, const std::string& why) {
        g->refusal = "external file '" + uri + "' refused: " + why;
        if (err) *err += g->refusal;
        return false;
    };
    if (g->prefix.empty() || !path.starts_with(g->prefix))
        return refuse(path, "this input may not reference external files (only data: URIs)");
    const std::string uri = path.substr(g->prefix.size());
    if (uri.empty() || uri[0] == '/' || uri[0] == '\\') return refuse(uri, "absolute paths are not allowed");
    for (char c : uri)
        if (static_cast<unsigned char>(c) < 0x20) return refuse(uri, "control characters in the URI");
    const size_t colon = uri.find(':');
    if (colon != std::string::npos && uri.find('/') > colon)
        return refuse(uri, "only relative paths and data: URIs are supported");
    std::error_code ec;
    const fs::path target = fs::weakly_canonical(g->root / uri, ec);
    const fs::path rel = ec ? fs::path() : target.lexically_relative(g->root);
    if (rel.empty() || *rel.begin() == "..") return refuse(uri, "it resolves outside the scene's folder");
    if (!fs::is_regular_file(target, ec)) return refuse(uri, "not a readable file");
    const uint64_t size = fs::file_size(target, ec);
    if (ec) return refuse(uri, ec.message());
    if (size > g->max_bytes) return refuse(uri, str(size) + " bytes is above the limit of " + str(g->max_bytes));
    std::ifstream in(target, std::ios::binary);
    out->resize(size);
    if (!in.read(reinterpret_cast<char*>(out->data()), static_cast<std::streamsize>(size)))
        return refuse(uri, "read error");
    if (std::find(g->read.begin(), g->read.end(), target.string()) == g->read.end()) g->read.push_back(target.string());
    return true;
}

bool decode_image(tinygltf::Image*, const int index, std::string*, std::string*, int, int, const unsigned char* bytes,
                  int size, void* user) {
    auto* d = static_cast<DecodedImages*>(user);
    if (index < 0) return true;
    const size_t i = size_t(index);
    if (d->images.size() <= i) d->images.resize(i + 1), d->errors.resize(i + 1);
    try {
        d->images[i] = decode_texture({bytes, size_t(std::max(size, 0))}, *d->limits, d->budget);
    } catch (const std::exception& e) {
        d->errors[i] = e.what();
    }
    return true;
}

void add_lines(std::vector<std::string>& to, const std::string& text) {
    size_t start = 0, lines = 0;
    while (start < text.size()) {
        size_t end = text.find('\n', start);
        if (end == std::string::npos) end = text.size();
        if (end > start && ++lines <= 20) to.push_back("glTF: " + clip(text.substr(start, end - start)));
        start = end + 1;
    }
    if (lines > 20) to.push_back("glTF: " + str(lines - 20) + " more messages");
}

tinygltf::Model read_model(std::string_view bytes, bool binary, const std::string& base_dir, const std::string& file,
                           const LoadLimits& limits, std::vector<std::string>& warnings, DecodedImages& images,
                           std::vector<std::string>& files_read) {
    if (bytes.size() > limits.max_file_bytes)
        fail(file, "", "input of " + str(bytes.size()) + " bytes is above the limit of " + str(limits.max_file_bytes));
    if (bytes.size() >= std::numeric_limits<uint32_t>::max()) fail(file, "", "inputs of 4 GiB or more are not supported");
    size_t length = bytes.size();
    std::string_view json = binary ? check_glb(bytes, file, length) : bytes;
    if (!binary && bytes.starts_with("glTF")) fail(file, "", "binary glTF (GLB) data where a text .gltf was expected");
    check_json_depth(json, file, limits.max_json_depth);
    check_image_views(json, file);

    FileGuard guard;
    guard.max_bytes = limits.max_file_bytes;
    if (!base_dir.empty()) {
        std::error_code ec;
        guard.root = fs::weakly_canonical(fs::absolute(base_dir, ec).lexically_normal(), ec);
        guard.prefix = fs::path(file).parent_path().generic_string();
        if (guard.prefix.empty()) guard.prefix = ".";
        if (guard.prefix.back() != '/') guard.prefix += '/';
    }
    tinygltf::TinyGLTF reader;
    images.limits = &limits;
    images.budget = limits.max_texture_bytes;
    reader.SetImageLoader(decode_image, &images);
    reader.SetFsCallbacks({guard_exists, guard_expand, guard_read, nullptr, &guard});

    tinygltf::Model model;
    std::string err, warn;
    bool ok = false;
    try {
        const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
        ok = binary ? reader.LoadBinaryFromMemory(&model, &err, &warn, data, static_cast<unsigned>(length), guard.prefix)
                    : reader.LoadASCIIFromString(&model, &err, &warn, bytes.data(), static_cast<unsigned>(length),
                                                 guard.prefix);
    } catch (const std::exception& e) {  // tinygltf 2.7 throws std::out_of_range for a GLB buffer of 0 bytes
        ok = false;
        err = e.what();
    }
    if (!guard.refusal.empty()) fail(file, "", guard.refusal);
    if (!ok) fail(file, "", "invalid glTF: " + clip(err.empty() ? "unknown tinygltf error" : err));
    add_lines(warnings, err);  // tinygltf reports some problems it then works around
    add_lines(warnings, warn);
    files_read = std::move(guard.read);
    return model;
}

// --- conversion -----------------------------------------------------------------------------

// An optional per-vertex attribute of `components` numbers per element (texture coordinates,
// colours, tangents), checked against POSITION's count and for finite values.
template <class Vec>
std::vector<Vec> read_attribute(Ctx& c, const tinygltf::Primitive& prim, const char* name, const std::string& pp,
                                size_t vertices, std::initializer_list<int> types, std::initializer_list<int> components) {
    const auto it = prim.attributes.find(name);
    if (it == prim.attributes.end()) return {};
    const std::string ref = pp + "/attributes/" + name;
    const int index = it->second;
    if (index < 0 || static_cast<size_t>(index) >= c.m.accessors.size())
        fail(c, ref, "refers to accessor " + std::to_string(index) + ", but the file has " + str(c.m.accessors.size()));
    const tinygltf::Accessor& a = c.m.accessors[static_cast<size_t>(index)];
    int type = *types.begin();
    for (int t : types)
        if (a.type == t) type = t;
    const AccessorView v = view_accessor(c, index, ref, name, type, components, vertices, kVerticesLeft);
    if (v.count != vertices)
        fail(c, ref, std::string(name) + " has " + str(v.count) + " elements but POSITION has " + str(vertices));
    if (v.component_type != TINYGLTF_COMPONENT_TYPE_FLOAT && !a.normalized)
        fail(c, "/accessors/" + std::to_string(index), std::string(name) + " with integer components must be normalized");
    const int n = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(type));
    std::vector<Vec> out(vertices, Vec(1.f));
    for (size_t k = 0; k < vertices; ++k) {
        for (int j = 0; j < n && j < Vec::length(); ++j) {
            const float x = read_component(v, k, j);
            if (!std::isfinite(x))
                fail(c, "/accessors/" + std::to_string(index), std::string(name) + " element " + str(k) + " is not finite");
            out[k][j] = x;
        }
    }
    return out;
}

// How a primitive's vertices leave their bind shape: morph weights (one per target) and a skin's
// joint matrices (the joint's world transform times its inverse bind matrix).
struct Deform {
    const std::vector<double>* weights = nullptr;
    const std::vector<glm::dmat4>* joints = nullptr;
};

// Adds each morph target's POSITION or NORMAL displacement, times its weight, to `v`.
void apply_morph(Ctx& c, const tinygltf::Primitive& prim, const std::string& pp, const std::vector<double>& weights,
                 const char* attribute, std::vector<glm::dvec3>& v) {
    for (size_t k = 0; k < prim.targets.size() && k < weights.size(); ++k) {
        if (weights[k] == 0.0) continue;
        const auto it = prim.targets[k].find(attribute);
        if (it == prim.targets[k].end()) continue;
        const std::string ref = pp + "/targets/" + str(k) + "/" + attribute;
        const AccessorView d = view_accessor(c, it->second, ref, attribute, TINYGLTF_TYPE_VEC3,
                                             {TINYGLTF_COMPONENT_TYPE_FLOAT}, v.size(), "vertices of the primitive");
        if (d.count != v.size())
            fail(c, ref, std::string("morph target has ") + str(d.count) + " elements but POSITION has " + str(v.size()));
        for (size_t i = 0; i < v.size(); ++i) {
            const glm::dvec3 delta = read_vec3(d, i);
            if (!finite(delta)) fail(c, "/accessors/" + std::to_string(it->second), "morph target element " + str(i) + " is not finite");
            v[i] += weights[k] * delta;
        }
    }
}

// Each vertex's skinning matrix: the weighted sum of its joints' matrices over every
// JOINTS_n/WEIGHTS_n pair; a vertex with no weight keeps the mesh node's own transform.
std::vector<glm::dmat4> skin_matrices(Ctx& c, const tinygltf::Primitive& prim, const std::string& pp, size_t vertices,
                                      const std::vector<glm::dmat4>& joints, const glm::dmat4& node_world) {
    std::vector<glm::dmat4> m(vertices, glm::dmat4(0.0));
    std::vector<double> total(vertices, 0.0);
    constexpr auto kFloat = TINYGLTF_COMPONENT_TYPE_FLOAT, kU8 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                   kU16 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    for (int set = 0;; ++set) {
        const std::string jn = "JOINTS_" + std::to_string(set), wn = "WEIGHTS_" + std::to_string(set);
        const auto ji = prim.attributes.find(jn), wi = prim.attributes.find(wn);
        if (ji == prim.attributes.end() && wi == prim.attributes.end()) break;
        if (ji == prim.attributes.end() || wi == prim.attributes.end())
            fail(c, pp + "/attributes", jn + " and " + wn + " must come together");
        const AccessorView jv = view_accessor(c, ji->second, pp + "/attributes/" + jn, jn.c_str(), TINYGLTF_TYPE_VEC4,
                                              {kU8, kU16}, vertices, "vertices of the primitive");
        const std::vector<glm::vec4> w =
            read_attribute<glm::vec4>(c, prim, wn.c_str(), pp, vertices, {TINYGLTF_TYPE_VEC4}, {kFloat, kU8, kU16});
        if (jv.count != vertices) fail(c, pp + "/attributes/" + jn, jn + " has " + str(jv.count) + " elements but POSITION has " + str(vertices));
        for (size_t v = 0; v < vertices; ++v) {
            for (int j = 0; j < 4; ++j) {
                const double wj = w[v][j];
                if (wj == 0.0) continue;
                if (wj < 0.0) fail(c, pp + "/attributes/" + wn, wn + " element " + str(v) + " is negative");
                const unsigned char* p = jv.data + v * jv.stride;
                uint32_t joint = p[j];
                if (jv.component_type == kU16) {
                    uint16_t u;
                    std::memcpy(&u, p + 2 * j, 2);
                    joint = u;
                }
                if (joint >= joints.size())
                    fail(c, pp + "/attributes/" + jn, jn + " element " + str(v) + " names joint " + str(joint) + ", but the skin has " +
                                                          str(joints.size()));
                m[v] += wj * joints[joint];
                total[v] += wj;
            }
        }
    }
    for (size_t v = 0; v < vertices; ++v) m[v] = total[v] > 0 ? m[v] * (1.0 / total[v]) : node_world;
    return m;
}

void emit_primitive(Ctx& c, size_t mi, size_t pi, const glm::dmat4& world, const Deform& deform = {}) {
    const tinygltf::Mesh& mesh = c.m.meshes[mi];
    const tinygltf::Primitive& prim = mesh.primitives[pi];
    const std::string pp = "/meshes/" + str(mi) + "/primitives/" + str(pi);
    const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode < TINYGLTF_MODE_TRIANGLES) {
        ++c.points_lines;
        return;
    }
    if (mode > TINYGLTF_MODE_TRIANGLE_FAN) fail(c, pp + "/mode", "unknown primitive mode " + std::to_string(mode));
    const auto pos_it = prim.attributes.find("POSITION");
    if (pos_it == prim.attributes.end()) {
        ++c.no_position;
        return;
    }
    if (prim.material < -1 || prim.material >= static_cast<int>(c.out.materials.size()))
        fail(c, pp + "/material", "refers to material " + std::to_string(prim.material) + ", but the file has " +
                                      str(c.out.materials.size()));

    const AccessorView pos = view_accessor(c, pos_it->second, pp + "/attributes/POSITION", "POSITION", TINYGLTF_TYPE_VEC3,
                                           {TINYGLTF_COMPONENT_TYPE_FLOAT}, left(c.limits.max_vertices, c.vertices), kVerticesLeft);
    AccessorView nrm;
    const auto nrm_it = prim.attributes.find("NORMAL");
    if (nrm_it != prim.attributes.end()) {
        nrm = view_accessor(c, nrm_it->second, pp + "/attributes/NORMAL", "NORMAL", TINYGLTF_TYPE_VEC3,
                            {TINYGLTF_COMPONENT_TYPE_FLOAT}, left(c.limits.max_vertices, c.vertices), kVerticesLeft);
        if (nrm.count != pos.count)
            fail(c, pp + "/attributes/NORMAL", "NORMAL has " + str(nrm.count) + " elements but POSITION has " + str(pos.count));
    }
    const bool indexed = prim.indices >= 0;
    const uint64_t tri_budget = left(c.limits.max_triangles, c.triangles);
    const uint64_t corner_budget = tri_budget > (std::numeric_limits<uint64_t>::max() - 2) / 3 ? tri_budget : 3 * tri_budget + 2;
    AccessorView idx;
    if (indexed)
        idx = view_accessor(c, prim.indices, pp + "/indices", "indices", TINYGLTF_TYPE_SCALAR,
                            {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                             TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT},
                            corner_budget, "indices left under LoadLimits::max_triangles");
    if (pos.count > std::numeric_limits<uint32_t>::max())  // MeshDesc indices are 32-bit
        fail(c, pp + "/attributes/POSITION", "more than 2^32 vertices in one primitive");
    const size_t corners = indexed ? idx.count : pos.count;
    const std::string corner_ptr = indexed ? pp + "/indices" : pp + "/attributes/POSITION";
    if (mode == TINYGLTF_MODE_TRIANGLES && corners % 3 != 0)
        fail(c, corner_ptr, str(corners) + " vertices do not make whole triangles");
    const size_t tris = mode == TINYGLTF_MODE_TRIANGLES ? corners / 3 : (corners >= 3 ? corners - 2 : 0);
    if (tris > tri_budget)
        fail(c, pp, str(tris) + " triangles exceed the triangle limit (" + str(c.limits.max_triangles) + " in all)");
    if (tris == 0) return;
    if (c.out.meshes.size() + c.out.instances.size() >= c.limits.max_instances)
        fail(c, pp, "more than " + str(c.limits.max_instances) + " mesh primitive instances in the scene (the instance limit)");

    MeshDesc out;
    out.name = mesh.name.empty() ? "mesh " + str(mi) : clip(mesh.name, 200);
    if (mesh.primitives.size() > 1) out.name += " [primitive " + str(pi) + "]";
    out.material = prim.material;
    out.flat_normals = true;  // glTF: without NORMAL, shade with face normals
    out.origin = at(c.file, pp);

    std::vector<glm::dvec3> bind(pos.count), bind_normals(nrm.count);
    for (size_t k = 0; k < pos.count; ++k) {
        bind[k] = read_vec3(pos, k);
        if (!finite(bind[k]))
            fail(c, "/accessors/" + std::to_string(pos_it->second),
                 "POSITION element " + str(k) + " is not finite (used by " + pp + ")");
    }
    for (size_t k = 0; k < nrm.count; ++k) {
        bind_normals[k] = read_vec3(nrm, k);
        if (!finite(bind_normals[k]))
            fail(c, "/accessors/" + std::to_string(nrm_it->second),
                 "NORMAL element " + str(k) + " is not finite (used by " + pp + ")");
    }
    if (deform.weights) {
        apply_morph(c, prim, pp, *deform.weights, "POSITION", bind);
        apply_morph(c, prim, pp, *deform.weights, "NORMAL", bind_normals);
    }
    // One matrix for a rigid primitive, one per vertex for a skinned one.
    const std::vector<glm::dmat4> skin =
        deform.joints ? skin_matrices(c, prim, pp, pos.count, *deform.joints, world) : std::vector<glm::dmat4>{};
    auto matrix_of = [&](size_t k) -> const glm::dmat4& { return skin.empty() ? world : skin[k]; };
    out.positions.resize(pos.count);
    for (size_t k = 0; k < pos.count; ++k) out.positions[k] = glm::vec3(matrix_of(k) * glm::dvec4(bind[k], 1.0));
    if (nrm.count > 0) {
        const glm::dmat3 rigid_normal_matrix = glm::transpose(glm::inverse(glm::dmat3(world)));
        out.normals.resize(nrm.count);
        for (size_t k = 0; k < nrm.count && !out.normals.empty(); ++k) {
            const glm::dvec3 w = (skin.empty() ? rigid_normal_matrix : glm::transpose(glm::inverse(glm::dmat3(skin[k])))) * bind_normals[k];
            const double len = glm::length(w);
            if (!(len > 1e-30) || !std::isfinite(len)) {
                out.normals.clear();  // the renderer falls back to geometric normals
                if (c.dropped_normals++ == 0) c.first_dropped = out.name;
            } else {
                out.normals[k] = glm::vec3(w / len);
            }
        }
    }

    // What the material reads (and COLOR_0, which always multiplies the base colour).
    const MaterialDesc* md = prim.material >= 0 ? &c.out.materials[static_cast<size_t>(prim.material)] : nullptr;
    constexpr auto kFloat = TINYGLTF_COMPONENT_TYPE_FLOAT, kU8 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                   kU16 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    if (md && md->textured()) {
        bool set_used[2] = {false, false};
        for (const TextureSlot* t : {&md->base_color_tex, &md->metallic_roughness_tex, &md->emissive_tex, &md->normal_tex})
            if (t->used()) set_used[t->texcoord] = true;
        for (int set = 0; set < 2; ++set) {
            if (!set_used[set]) continue;
            const std::string name = "TEXCOORD_" + std::to_string(set);
            out.uv[set] = read_attribute<glm::vec2>(c, prim, name.c_str(), pp, pos.count, {TINYGLTF_TYPE_VEC2}, {kFloat, kU8, kU16});
            if (out.uv[set].empty()) ++c.missing_uv;
        }
        if (md->normal_tex.used()) {
            out.tangents = read_attribute<glm::vec4>(c, prim, "TANGENT", pp, pos.count, {TINYGLTF_TYPE_VEC4}, {kFloat});
            for (size_t k = 0; k < out.tangents.size(); ++k) {
                glm::vec4& t = out.tangents[k];
                const glm::dmat3 m3(matrix_of(k));
                const glm::dvec3 w = m3 * glm::dvec3(t.x, t.y, t.z);
                const double len = glm::length(w);
                // Mirroring flips the bitangent's side (the faces were re-wound above).
                const float sign = (t.w < 0.f ? -1.f : 1.f) * (glm::determinant(m3) < 0 ? -1.f : 1.f);
                t = len > 1e-30 && std::isfinite(len) ? glm::vec4(glm::vec3(w / len), sign) : glm::vec4(0.f);
            }
        }
    }
    out.colors = read_attribute<glm::vec4>(c, prim, "COLOR_0", pp, pos.count, {TINYGLTF_TYPE_VEC3, TINYGLTF_TYPE_VEC4},
                                           {kFloat, kU8, kU16});

    std::vector<uint32_t> corner(corners);
    for (size_t k = 0; k < corners; ++k) {
        corner[k] = indexed ? read_index(idx, k) : static_cast<uint32_t>(k);
        if (corner[k] >= pos.count)
            fail(c, pp + "/indices", "index " + str(k) + " = " + str(corner[k]) + " is out of range (" + str(pos.count) +
                                         " vertices)");
    }
    // A mirroring transform turns counter-clockwise (front) faces clockwise; swap to keep them front.
    const bool mirrored = glm::determinant(glm::dmat3(matrix_of(0))) < 0;
    out.indices.reserve(3 * tris);
    for (size_t t = 0; t < tris; ++t) {
        uint32_t a, b, d;
        if (mode == TINYGLTF_MODE_TRIANGLES) a = corner[3 * t], b = corner[3 * t + 1], d = corner[3 * t + 2];
        else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) a = corner[t], b = corner[t + 1 + t % 2], d = corner[t + 2 - t % 2];
        else a = corner[t + 1], b = corner[t + 2], d = corner[0];
        if (mirrored) std::swap(b, d);
        out.indices.insert(out.indices.end(), {a, b, d});
    }
    c.vertices += pos.count;
    c.triangles += tris;
    c.out.meshes.push_back(std::move(out));
}

glm::dmat4 local_matrix(const Ctx& c, size_t ni) {
    const tinygltf::Node& n = c.m.nodes[ni];
    const std::string np = "/nodes/" + str(ni);
    auto check = [&](const std::vector<double>& v, size_t size, const char* name) {
        const bool ok = v.size() == size && std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
        if (!v.empty() && !ok) fail(c, np + "/" + name, std::string(name) + " must hold " + str(size) + " finite numbers");
    };
    check(n.matrix, 16, "matrix");
    check(n.translation, 3, "translation");
    check(n.rotation, 4, "rotation");
    check(n.scale, 3, "scale");
    glm::dmat4 m(1.0);
    if (!n.matrix.empty()) {  // column-major, like glm; never animated (checked with the animations)
        for (int col = 0; col < 4; ++col)
            for (int row = 0; row < 4; ++row) m[col][row] = n.matrix[static_cast<size_t>(4 * col + row)];
        return m;
    }
    const NodeState* st = ni < c.state.size() ? &c.state[ni] : nullptr;
    std::optional<glm::dvec3> scale, translation;
    std::optional<glm::dvec4> rotation;
    if (st && st->has_s) scale = st->s;
    else if (!n.scale.empty()) scale = glm::dvec3(n.scale[0], n.scale[1], n.scale[2]);
    if (st && st->has_r) rotation = st->r;
    else if (!n.rotation.empty()) rotation = glm::dvec4(n.rotation[0], n.rotation[1], n.rotation[2], n.rotation[3]);
    if (st && st->has_t) translation = st->t;
    else if (!n.translation.empty()) translation = glm::dvec3(n.translation[0], n.translation[1], n.translation[2]);
    if (scale) m = glm::dmat4(glm::dmat3((*scale)[0], 0, 0, 0, (*scale)[1], 0, 0, 0, (*scale)[2]));
    if (rotation) {
        double x = (*rotation)[0], y = (*rotation)[1], z = (*rotation)[2], w = (*rotation)[3];
        const double len = std::sqrt(x * x + y * y + z * z + w * w);
        if (!(len > 1e-12)) fail(c, np + "/rotation", "rotation quaternion has zero length");
        x /= len, y /= len, z /= len, w /= len;
        const glm::dmat3 r(1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w),   // column 0
                           2 * (x * y - z * w), 1 - 2 * (x * x + z * z), 2 * (y * z + x * w),   // column 1
                           2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y));  // column 2
        m = glm::dmat4(r) * m;
    }
    if (translation) m[3] = glm::dvec4(*translation, 1.0);
    return m;  // T * R * S: the translation column is untouched by R * S
}

glm::vec3 direction_of(const Ctx& c, const glm::dmat4& world, const glm::dvec3& local, const std::string& np) {
    const glm::dvec3 d(world * glm::dvec4(local, 0.0));
    const double len = glm::length(d);
    if (!(len > 1e-30) || !std::isfinite(len)) fail(c, np, "node transform is degenerate (a zero or non-finite axis)");
    return glm::vec3(d / len);
}

void add_camera(Ctx& c, size_t ni, const glm::dmat4& world) {
    const tinygltf::Node& n = c.m.nodes[ni];
    const std::string np = "/nodes/" + str(ni);
    if (n.camera < 0 || static_cast<size_t>(n.camera) >= c.m.cameras.size())
        fail(c, np + "/camera", "refers to camera " + std::to_string(n.camera) + ", but the file has " + str(c.m.cameras.size()));
    const tinygltf::Camera& cam = c.m.cameras[static_cast<size_t>(n.camera)];
    const std::string cp = "/cameras/" + std::to_string(n.camera);
    if (cam.type != "perspective") {
        c.out.warnings.push_back("orthographic camera " + std::to_string(n.camera) + " (" + np +
                                 ") is not supported and is ignored");
        return;
    }
    if (c.out.camera) {
        ++c.extra_cameras;
        return;
    }
    const tinygltf::PerspectiveCamera& p = cam.perspective;
    if (!(p.yfov > 0 && p.yfov < std::numbers::pi)) fail(c, cp + "/perspective/yfov", "yfov must lie in (0, pi)");
    if (!(p.aspectRatio >= 0 && std::isfinite(p.aspectRatio)))
        fail(c, cp + "/perspective/aspectRatio", "aspectRatio must be positive");
    if (!(p.znear >= 0 && std::isfinite(p.znear))) fail(c, cp + "/perspective/znear", "znear must be positive");
    CameraDesc d;
    const glm::dvec3 pos(world * glm::dvec4(0, 0, 0, 1));
    d.position = glm::vec3(pos);
    d.look_at = glm::vec3(pos + glm::dvec3(direction_of(c, world, {0, 0, -1}, np)));
    d.up = direction_of(c, world, {0, 1, 0}, np);
    d.vfov_deg = static_cast<float>(glm::degrees(p.yfov));
    // Without aspectRatio the image's aspect decides (focal_px = 0); 4:3 only fills hfov_deg.
    const double aspect = p.aspectRatio > 0 ? p.aspectRatio : 4.0 / 3.0;
    d.hfov_deg = static_cast<float>(glm::degrees(2 * std::atan(std::tan(p.yfov / 2) * aspect)));
    d.znear = static_cast<float>(p.znear);
    d.zfar = p.zfar > 0 ? static_cast<float>(p.zfar) : std::max(1000.0f, 1000.0f * d.znear);  // absent = infinite
    d.focal_px = 0.0f;
    d.origin = at(c.file, np);
    c.out.camera = d;
}

// KHR_lights_punctual intensities are photometric (point/spot: candela, directional: lux). They
// are used as radiometric numbers unchanged: 1 cd -> 1 W/sr, 1 lux -> 1 W/m^2 (no 683 lm/W).
void add_light(Ctx& c, size_t ni, const glm::dmat4& world) {
    const tinygltf::Node& n = c.m.nodes[ni];
    const auto ext = n.extensions.find("KHR_lights_punctual");
    if (ext == n.extensions.end()) return;
    const std::string np = "/nodes/" + str(ni);
    const std::string lp = np + "/extensions/KHR_lights_punctual";
    const tinygltf::Value& v = ext->second;
    if (!v.IsObject() || !v.Has("light") || !v.Get("light").IsNumber())
        fail(c, lp, "needs a numeric 'light' index");
    const double li = v.Get("light").GetNumberAsDouble();
    if (!(li >= 0 && li < static_cast<double>(c.m.lights.size())) || li != std::floor(li))
        fail(c, lp + "/light", "refers to light " + num(li) + ", but the file has " + str(c.m.lights.size()));
    const tinygltf::Light& l = c.m.lights[static_cast<size_t>(li)];
    const std::string dp = "/extensions/KHR_lights_punctual/lights/" + str(static_cast<size_t>(li));
    glm::dvec3 color(1.0);
    if (!l.color.empty()) {
        if (l.color.size() != 3) fail(c, dp + "/color", "color must hold 3 numbers");
        color = {l.color[0], l.color[1], l.color[2]};
    }
    LightDesc d;
    d.radiance = glm::vec3(color * l.intensity);
    d.origin = at(c.file, np);
    if (l.type == "point" || l.type == "spot") d.position = glm::vec3(world * glm::dvec4(0, 0, 0, 1));
    if (l.type == "directional" || l.type == "spot") d.direction = direction_of(c, world, {0, 0, -1}, np);
    if (l.type == "point") d.kind = LightKind::point;
    else if (l.type == "directional") d.kind = LightKind::directional;
    else if (l.type == "spot") {
        d.kind = LightKind::spot;
        ++c.spots;
    } else {
        fail(c, dp + "/type", "unknown light type '" + clip(l.type) + "'");
    }
    c.out.lights.push_back(d);
}

// The node's morph weights: animated, else the node's, else the mesh's defaults, else zero.
// Empty when its mesh has no morph targets.
std::vector<double> morph_weights(const Ctx& c, size_t ni) {
    const tinygltf::Node& n = c.m.nodes[ni];
    const tinygltf::Mesh& mesh = c.m.meshes[static_cast<size_t>(n.mesh)];
    size_t targets = 0;
    for (const auto& prim : mesh.primitives) targets = std::max(targets, prim.targets.size());
    if (targets == 0) return {};
    const std::string np = "/nodes/" + str(ni);
    if (ni < c.state.size() && c.state[ni].has_weights) return c.state[ni].weights;
    const std::vector<double>& given = !n.weights.empty() ? n.weights : mesh.weights;
    if (given.empty()) return std::vector<double>(targets, 0.0);
    if (given.size() != targets)
        fail(c, !n.weights.empty() ? np + "/weights" : "/meshes/" + std::to_string(n.mesh) + "/weights",
             "holds " + str(given.size()) + " weights for " + str(targets) + " morph targets");
    for (double w : given)
        if (!std::isfinite(w)) fail(c, np, "morph weights must be finite");
    return given;
}

// Places a mesh that several nodes use, or that an animation moves: each primitive is converted
// once, in the mesh's own space (a prototype), and this node adds an instance of it.
void place_instances(Ctx& c, size_t mi, size_t ni, const glm::dmat4& world) {
    if (c.prototype_of.size() != c.m.meshes.size()) c.prototype_of.assign(c.m.meshes.size(), {});
    std::vector<int>& slots = c.prototype_of[mi];
    if (slots.empty()) slots.assign(c.m.meshes[mi].primitives.size(), -1);
    for (size_t pi = 0; pi < slots.size(); ++pi) {
        if (slots[pi] == -1) {
            const size_t before = c.out.meshes.size();
            emit_primitive(c, mi, pi, glm::dmat4(1.0));
            if (c.out.meshes.size() == before) {
                slots[pi] = -2;
            } else {
                slots[pi] = static_cast<int>(c.out.prototypes.size());
                c.out.prototypes.push_back(std::move(c.out.meshes.back()));
                c.out.meshes.pop_back();
            }
        }
        if (slots[pi] < 0) continue;
        if (c.out.meshes.size() + c.out.instances.size() >= c.limits.max_instances)
            fail(c, "/nodes/" + str(ni), "more than " + str(c.limits.max_instances) +
                                             " mesh primitive instances in the scene (the instance limit)");
        c.out.instances.push_back({static_cast<uint32_t>(slots[pi]), glm::mat4(world), at(c.file, "/nodes/" + str(ni))});
    }
}

// Whether a node's transform can place an instance: invertible in single precision (a zero
// scale, which glTF allows for hiding, or a projection onto a plane is drawn flat instead).
bool placeable(const glm::dmat4& world) {
    const glm::dmat3 l(world);
    const double det = glm::determinant(l);
    if (!(std::abs(det) > 0.0) || !std::isfinite(det)) return false;
    const glm::dmat3 inv = glm::inverse(l);
    for (int col = 0; col < 3; ++col)
        for (int row = 0; row < 3; ++row)
            if (!(std::abs(inv[col][row]) < 1e30) || !(std::abs(l[col][row]) < 1e30)) return false;
    return world[0][3] == 0.0 && world[1][3] == 0.0 && world[2][3] == 0.0 && world[3][3] == 1.0;
}

void emit_mesh(Ctx& c, size_t ni, const glm::dmat4& world, const std::vector<glm::dmat4>* joints) {
    const size_t mi = static_cast<size_t>(c.m.nodes[ni].mesh);
    const std::vector<double> weights = morph_weights(c, ni);
    const bool shared = mi < c.mesh_placements.size() && c.mesh_placements[mi] > 1;
    const bool moving = ni < c.moving.size() && c.moving[ni];
    if (!joints && weights.empty() && (shared || moving) && placeable(world)) {
        place_instances(c, mi, ni, world);
        return;
    }
    const Deform deform{weights.empty() ? nullptr : &weights, joints};
    for (size_t pi = 0; pi < c.m.meshes[mi].primitives.size(); ++pi) emit_primitive(c, mi, pi, world, deform);
}

// A skinned mesh, once every node's world matrix is known: each joint's matrix is its world
// transform times its inverse bind matrix (the mesh node's own transform does not apply).
void emit_skinned(Ctx& c, size_t ni) {
    const tinygltf::Node& n = c.m.nodes[ni];
    const std::string np = "/nodes/" + str(ni);
    if (n.skin < 0 || static_cast<size_t>(n.skin) >= c.m.skins.size())
        fail(c, np + "/skin", "refers to skin " + std::to_string(n.skin) + ", but the file has " + str(c.m.skins.size()));
    const tinygltf::Skin& skin = c.m.skins[static_cast<size_t>(n.skin)];
    const std::string sp = "/skins/" + std::to_string(n.skin);
    if (skin.joints.empty()) fail(c, sp + "/joints", "a skin needs at least one joint");
    AccessorView ibm;
    if (skin.inverseBindMatrices >= 0) {
        ibm = view_accessor(c, skin.inverseBindMatrices, sp + "/inverseBindMatrices", "inverseBindMatrices", TINYGLTF_TYPE_MAT4,
                            {TINYGLTF_COMPONENT_TYPE_FLOAT}, skin.joints.size(), "joints of the skin");
        if (ibm.count != skin.joints.size())
            fail(c, sp + "/inverseBindMatrices", "holds " + str(ibm.count) + " matrices for " + str(skin.joints.size()) + " joints");
    }
    std::vector<glm::dmat4> joints(skin.joints.size());
    for (size_t j = 0; j < skin.joints.size(); ++j) {
        const int node = skin.joints[j];
        if (node < 0 || static_cast<size_t>(node) >= c.m.nodes.size() || !c.visited[static_cast<size_t>(node)])
            fail(c, sp + "/joints/" + str(j), "joint node " + std::to_string(node) + " is not a node of the scene");
        glm::dmat4 inverse_bind(1.0);
        if (ibm.count) {
            float f[16];
            std::memcpy(f, ibm.data + j * ibm.stride, sizeof f);
            for (int k = 0; k < 16; ++k) {
                if (!std::isfinite(f[k])) fail(c, sp + "/inverseBindMatrices", "matrix " + str(j) + " is not finite");
                inverse_bind[k / 4][k % 4] = f[k];
            }
        }
        joints[j] = c.world[static_cast<size_t>(node)] * inverse_bind;
    }
    emit_mesh(c, ni, c.world[ni], &joints);
}

void visit(Ctx& c, int node, const glm::dmat4& parent, int depth, const std::string& ref, bool parent_moves = false) {
    if (node < 0 || static_cast<size_t>(node) >= c.m.nodes.size())
        fail(c, ref, "refers to node " + std::to_string(node) + ", but the file has " + str(c.m.nodes.size()));
    const size_t ni = static_cast<size_t>(node);
    const std::string np = "/nodes/" + str(ni);
    if (c.on_path[ni]) fail(c, ref, "node cycle: node " + str(ni) + " is its own ancestor");
    if (c.visited[ni]) fail(c, ref, "node " + str(ni) + " is reached twice; glTF node hierarchies must be trees");
    // The limit also bounds this recursion.
    if (depth > c.limits.max_node_depth)
        fail(c, np, "node hierarchy is deeper than " + std::to_string(c.limits.max_node_depth) + " levels");
    c.on_path[ni] = c.visited[ni] = 1;
    const tinygltf::Node& n = c.m.nodes[ni];
    const glm::dmat4 world = parent * local_matrix(c, ni);
    c.world[ni] = world;
    const bool moves = parent_moves || (ni < c.animated.size() && c.animated[ni]);
    if (c.moving.size() != c.m.nodes.size()) c.moving.assign(c.m.nodes.size(), 0);
    c.moving[ni] = moves;
    if (n.mesh != -1) {
        if (n.mesh < 0 || static_cast<size_t>(n.mesh) >= c.m.meshes.size())
            fail(c, np + "/mesh", "refers to mesh " + std::to_string(n.mesh) + ", but the file has " + str(c.m.meshes.size()));
        if (n.skin >= 0) c.skinned.push_back(ni);  // its joints may lie anywhere in the tree
        else emit_mesh(c, ni, world, nullptr);
    }
    if (n.camera != -1) add_camera(c, ni, world);
    add_light(c, ni, world);
    for (size_t k = 0; k < n.children.size(); ++k) visit(c, n.children[k], world, depth + 1, np + "/children/" + str(k), moves);
    c.on_path[ni] = 0;
}

Wrap wrap_mode(const Ctx& c, int mode, const std::string& ref) {
    switch (mode) {
        case TINYGLTF_TEXTURE_WRAP_REPEAT: return Wrap::repeat;
        case TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE: return Wrap::clamp;
        case TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT: return Wrap::mirror;
        default: fail(c, ref, "unknown wrap mode " + std::to_string(mode));
    }
}

// The SceneDescription texture of glTF texture `ti`, converted (and its image taken) on first use.
int use_texture(Ctx& c, int ti, const std::string& ref) {
    if (ti < 0 || static_cast<size_t>(ti) >= c.m.textures.size())
        fail(c, ref, "refers to texture " + std::to_string(ti) + ", but the file has " + str(c.m.textures.size()));
    int& slot = c.texture_index[static_cast<size_t>(ti)];
    if (slot >= 0) return slot;
    const tinygltf::Texture& t = c.m.textures[static_cast<size_t>(ti)];
    const std::string tp = "/textures/" + std::to_string(ti);
    if (t.source < 0 || static_cast<size_t>(t.source) >= c.m.images.size())
        fail(c, tp, "has no image in PNG or JPEG (source " + std::to_string(t.source) + "; image extensions such as "
                    "KHR_texture_basisu and EXT_texture_webp are not supported)");
    const size_t ii = static_cast<size_t>(t.source);
    int& image = c.image_index[ii];
    if (image < 0) {
        const bool have = ii < c.decoded.images.size() && c.decoded.images[ii];
        if (!have) {
            const std::string why = ii < c.decoded.errors.size() && !c.decoded.errors[ii].empty() ? c.decoded.errors[ii]
                                                                                                   : "it has no data";
            fail(c, "/images/" + str(ii), "cannot be used as a texture: " + clip(why));
        }
        image = static_cast<int>(c.out.images.size());
        c.out.images.push_back(c.decoded.images[ii]);
    }
    Texture tex;
    tex.image = static_cast<uint32_t>(image);
    if (t.sampler >= 0) {
        if (static_cast<size_t>(t.sampler) >= c.m.samplers.size())
            fail(c, tp + "/sampler", "refers to sampler " + std::to_string(t.sampler) + ", but the file has " + str(c.m.samplers.size()));
        const tinygltf::Sampler& smp = c.m.samplers[static_cast<size_t>(t.sampler)];
        const std::string sp = "/samplers/" + std::to_string(t.sampler);
        tex.wrap_s = wrap_mode(c, smp.wrapS, sp + "/wrapS");
        tex.wrap_t = wrap_mode(c, smp.wrapT, sp + "/wrapT");
        tex.nearest = smp.magFilter == TINYGLTF_TEXTURE_FILTER_NEAREST;
    }
    slot = static_cast<int>(c.out.textures.size());
    c.out.textures.push_back(tex);
    return slot;
}

// A material's textureInfo: the texture, its coordinate set and KHR_texture_transform.
TextureSlot read_slot(Ctx& c, int index, int texcoord, const tinygltf::ExtensionMap& ext, const std::string& ref) {
    TextureSlot slot;
    if (index < 0) return slot;
    slot.texture = use_texture(c, index, ref + "/index");
    const auto tt = ext.find("KHR_texture_transform");
    if (tt != ext.end() && tt->second.IsObject()) {
        const tinygltf::Value& v = tt->second;
        const std::string xp = ref + "/extensions/KHR_texture_transform";
        auto pair = [&](const char* key, glm::vec2 fallback) {
            if (!v.Has(key)) return fallback;
            const tinygltf::Value& a = v.Get(key);
            if (!a.IsArray() || a.ArrayLen() != 2 || !a.Get(0).IsNumber() || !a.Get(1).IsNumber())
                fail(c, xp + "/" + key, "must hold 2 numbers");
            const glm::dvec2 d(a.Get(0).GetNumberAsDouble(), a.Get(1).GetNumberAsDouble());
            if (!std::isfinite(d.x) || !std::isfinite(d.y) || std::abs(d.x) > 1e9 || std::abs(d.y) > 1e9)
                fail(c, xp + "/" + key, "must hold 2 finite numbers of magnitude at most 1e9");
            return glm::vec2(d);
        };
        double rotation = 0.0;
        if (v.Has("rotation")) {
            const tinygltf::Value& r = v.Get("rotation");
            if (!r.IsNumber() || !std::isfinite(r.GetNumberAsDouble()) || std::abs(r.GetNumberAsDouble()) > 1e6)
                fail(c, xp + "/rotation", "must be a finite number of radians");
            rotation = r.GetNumberAsDouble();
        }
        set_texture_transform(slot, pair("offset", glm::vec2(0.f)), static_cast<float>(rotation), pair("scale", glm::vec2(1.f)));
        if (v.Has("texCoord") && v.Get("texCoord").IsNumber()) texcoord = static_cast<int>(v.Get("texCoord").GetNumberAsDouble());
    }
    if (texcoord < 0 || texcoord > 1) {
        ++c.uv_sets_above_1;
        texcoord = 0;
    }
    slot.texcoord = static_cast<uint8_t>(texcoord);
    return slot;
}

void convert_materials(Ctx& c) {
    c.texture_index.assign(c.m.textures.size(), -1);
    c.image_index.assign(c.m.images.size(), -1);
    std::vector<std::string> occluded;
    for (size_t i = 0; i < c.m.materials.size(); ++i) {
        const tinygltf::Material& mat = c.m.materials[i];
        const std::string mp = "/materials/" + str(i);
        MaterialDesc d;
        d.name = mat.name.empty() ? "material " + str(i) : clip(mat.name, 200);
        d.origin = at(c.file, mp);
        const auto& pbr = mat.pbrMetallicRoughness;
        if (pbr.baseColorFactor.size() >= 3) d.albedo = glm::vec3(glm::dvec3(pbr.baseColorFactor[0], pbr.baseColorFactor[1], pbr.baseColorFactor[2]));
        if (pbr.baseColorFactor.size() == 4) d.alpha = static_cast<float>(pbr.baseColorFactor[3]);
        auto unit = [&](double v, const char* name) {
            if (!(v >= 0.0 && v <= 1.0)) fail(c, mp + "/pbrMetallicRoughness/" + name, "must be a number in [0, 1]");
            return static_cast<float>(v);
        };
        d.metallic = unit(pbr.metallicFactor, "metallicFactor");
        d.roughness = unit(pbr.roughnessFactor, "roughnessFactor");
        // A number read from an extension object, or `fallback` when it is absent.
        auto ext_number = [&](const char* ext, const char* field, double fallback, double lo, double hi) {
            const auto e = mat.extensions.find(ext);
            if (e == mat.extensions.end() || !e->second.Has(field)) return fallback;
            const tinygltf::Value& v = e->second.Get(field);
            if (!v.IsNumber() || !(v.GetNumberAsDouble() >= lo && v.GetNumberAsDouble() <= hi))
                fail(c, mp + "/extensions/" + ext + "/" + field,
                     "must be a number in [" + std::to_string(lo) + ", " + (std::isinf(hi) ? "inf" : std::to_string(hi)) + "]");
            return v.GetNumberAsDouble();
        };
        const double strength = ext_number("KHR_materials_emissive_strength", "emissiveStrength", 1.0, 0.0, INFINITY);
        d.ior = static_cast<float>(ext_number("KHR_materials_ior", "ior", 1.5, 1.0, 10.0));
        d.specular = static_cast<float>(ext_number("KHR_materials_specular", "specularFactor", 1.0, 0.0, 1.0));
        const auto& e = mat.emissiveFactor;
        if (e.size() == 3) d.emission = glm::vec3(glm::dvec3(e[0], e[1], e[2]) * strength);
        // A base with no specular layer and no metal is Lambertian (our own scenes write
        // KHR_materials_specular 0 to say so): no microfacet lobe is evaluated for it.
        if (d.metallic > 0.f || d.specular > 0.f) d.kind = MaterialKind::metallic_roughness;
        else d.kind = d.emits() ? MaterialKind::emission : MaterialKind::diffuse;
        d.double_sided = mat.doubleSided;
        d.base_color_tex = read_slot(c, pbr.baseColorTexture.index, pbr.baseColorTexture.texCoord, pbr.baseColorTexture.extensions,
                                     mp + "/pbrMetallicRoughness/baseColorTexture");
        d.metallic_roughness_tex = read_slot(c, pbr.metallicRoughnessTexture.index, pbr.metallicRoughnessTexture.texCoord,
                                             pbr.metallicRoughnessTexture.extensions, mp + "/pbrMetallicRoughness/metallicRoughnessTexture");
        // Emissive texels only scale an emission the factors already give (black stays black).
        if (d.emits())
            d.emissive_tex = read_slot(c, mat.emissiveTexture.index, mat.emissiveTexture.texCoord, mat.emissiveTexture.extensions,
                                       mp + "/emissiveTexture");
        d.normal_tex = read_slot(c, mat.normalTexture.index, mat.normalTexture.texCoord, mat.normalTexture.extensions,
                                 mp + "/normalTexture");
        if (d.normal_tex.used()) {
            if (!std::isfinite(mat.normalTexture.scale)) fail(c, mp + "/normalTexture/scale", "must be a finite number");
            d.normal_tex.scale = static_cast<float>(mat.normalTexture.scale);
        }
        if (mat.alphaMode == "MASK") d.alpha_mode = AlphaMode::mask;
        else if (mat.alphaMode == "BLEND") d.alpha_mode = AlphaMode::blend;
        else if (!mat.alphaMode.empty() && mat.alphaMode != "OPAQUE")
            fail(c, mp + "/alphaMode", "unknown alpha mode '" + clip(mat.alphaMode) + "' (OPAQUE, MASK or BLEND)");
        if (!(mat.alphaCutoff >= 0.0) || !std::isfinite(mat.alphaCutoff)) fail(c, mp + "/alphaCutoff", "must be a number >= 0");
        d.alpha_cutoff = static_cast<float>(mat.alphaCutoff);
        if (!(d.alpha >= 0.f && d.alpha <= 1.f)) fail(c, mp + "/pbrMetallicRoughness/baseColorFactor", "alpha must lie in [0, 1]");
        if (mat.occlusionTexture.index >= 0) occluded.push_back("'" + d.name + "'");
        c.out.materials.push_back(std::move(d));
    }
    if (!occluded.empty()) {
        std::string names;
        for (size_t i = 0; i < occluded.size() && i < 5; ++i) names += (i ? ", " : "") + occluded[i];
        if (occluded.size() > 5) names += " and " + str(occluded.size() - 5) + " more";
        c.out.warnings.push_back("occlusion textures are not used (path tracing computes occlusion): material" +
                                 std::string(occluded.size() > 1 ? "s " : " ") + names);
    }
}

void check_extensions(Ctx& c) {
    auto supported = [](const std::string& e) {
        return std::find(std::begin(kSupportedExtensions), std::end(kSupportedExtensions), e) != std::end(kSupportedExtensions);
    };
    for (size_t i = 0; i < c.m.extensionsRequired.size(); ++i)
        if (!supported(c.m.extensionsRequired[i]))
            fail(c, "/extensionsRequired/" + str(i),
                 "required extension '" + clip(c.m.extensionsRequired[i]) + "' is not supported");
    std::string ignored;
    for (const std::string& e : c.m.extensionsUsed)
        if (!supported(e)) ignored += (ignored.empty() ? "" : ", ") + clip(e);
    if (!ignored.empty()) c.out.warnings.push_back("glTF extensions used by the file are ignored: " + ignored);
}

void traverse_scene(Ctx& c) {
    c.mesh_placements.assign(c.m.meshes.size(), 0);
    for (const tinygltf::Node& n : c.m.nodes)
        if (n.mesh >= 0 && static_cast<size_t>(n.mesh) < c.m.meshes.size() && n.skin < 0) ++c.mesh_placements[static_cast<size_t>(n.mesh)];
    std::vector<int> roots;
    std::string roots_ptr;
    const int nscenes = static_cast<int>(c.m.scenes.size());
    int s = c.m.defaultScene;
    if (s != -1 && (s < 0 || s >= nscenes))
        fail(c, "/scene", "refers to scene " + std::to_string(s) + ", but the file has " + std::to_string(nscenes));
    if (s == -1 && nscenes > 0) s = 0;
    if (s >= 0) {
        roots = c.m.scenes[static_cast<size_t>(s)].nodes;
        roots_ptr = "/scenes/" + std::to_string(s) + "/nodes/";
    } else {  // no scenes: every node that is nobody's child is a root
        std::vector<char> child(c.m.nodes.size(), 0);
        for (const auto& n : c.m.nodes)
            for (int k : n.children)
                if (k >= 0 && static_cast<size_t>(k) < child.size()) child[static_cast<size_t>(k)] = 1;
        for (size_t i = 0; i < child.size(); ++i)
            if (!child[i]) roots.push_back(static_cast<int>(i));
        roots_ptr = "/nodes/";
    }
    c.on_path.assign(c.m.nodes.size(), 0);
    c.visited.assign(c.m.nodes.size(), 0);
    c.world.assign(c.m.nodes.size(), glm::dmat4(1.0));
    for (size_t k = 0; k < roots.size(); ++k)
        visit(c, roots[k], glm::dmat4(1.0), 1, roots_ptr + (s >= 0 ? str(k) : str(static_cast<size_t>(roots[k]))));
    for (size_t ni : c.skinned) emit_skinned(c, ni);
}

void summarise(Ctx& c) {
    auto& w = c.out.warnings;
    if (c.points_lines) w.push_back(str(static_cast<size_t>(c.points_lines)) + " point/line primitive(s) skipped: only triangles are rendered");
    if (c.no_position) w.push_back(str(static_cast<size_t>(c.no_position)) + " primitive(s) without POSITION skipped");
    if (c.dropped_normals)
        w.push_back("zero-length normals or a singular transform: normals of mesh '" + c.first_dropped + "'" +
                    (c.dropped_normals > 1 ? " and " + str(static_cast<size_t>(c.dropped_normals) - 1) + " more" : "") +
                    " are dropped");
    if (c.missing_uv)
        w.push_back(str(static_cast<size_t>(c.missing_uv)) + " textured primitive(s) lack the texture coordinates their "
                    "material reads: they are textured at coordinate (0, 0)");
    if (c.uv_sets_above_1)
        w.push_back(str(static_cast<size_t>(c.uv_sets_above_1)) + " texture(s) read coordinate sets above 1, which are not "
                    "supported: set 0 is used");
    if (c.spots) w.push_back("spot lights are rendered as point lights for now (cone angles are ignored)");
    if (c.extra_cameras)
        w.push_back("the scene has " + str(static_cast<size_t>(c.extra_cameras) + 1) + " perspective cameras; the first is used");
    if (!c.m.animations.empty() && c.state.empty())
        w.push_back("the file has " + str(c.m.animations.size()) + " animation(s); a still renders it at rest (a job's frames play them)");
    if (c.out.meshes.empty()) w.push_back("the scene has no triangle geometry");
    const bool emitter = std::any_of(c.out.meshes.begin(), c.out.meshes.end(), [&](const MeshDesc& m) {
        return m.material >= 0 && c.out.materials[static_cast<size_t>(m.material)].emits();
    });
    if (c.out.lights.empty() && !emitter)
        w.push_back("the scene has no lights or emissive materials; a path-traced render will be black");
}

}  // namespace

struct GltfDocument::Impl {
    std::string source;
    LoadLimits limits;
    std::vector<std::string> read_warnings;  // tinygltf's, once
    std::vector<std::string> files_read;     // external files, once
    tinygltf::Model model;
    DecodedImages images;
    ReadAnimations animations;

    SceneDescription flatten(const ScenePose* pose) const {
        SceneDescription scene;
        scene.source = source;
        scene.warnings = read_warnings;
        scene.files_read = files_read;
        Ctx c{model, source, limits, scene, images};
        if (pose) c.state = pose_nodes(c, animations, *pose);
        c.animated.assign(model.nodes.size(), 0);
        for (const Animation& a : animations.list)
            for (const AnimationChannel& ch : a.channels)
                if (ch.property != AnimatedProperty::weights && ch.node >= 0 && static_cast<size_t>(ch.node) < c.animated.size())
                    c.animated[static_cast<size_t>(ch.node)] = 1;
        check_extensions(c);
        convert_materials(c);
        traverse_scene(c);
        summarise(c);
        for (const Animation& a : animations.list)
            scene.animations.push_back({a.name, a.start_s, a.end_s, static_cast<int>(a.channels.size())});
        validate(scene);
        return scene;
    }
};

GltfDocument::GltfDocument(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
GltfDocument::~GltfDocument() = default;

std::shared_ptr<const GltfDocument> GltfDocument::parse(std::string_view bytes, bool binary, const std::string& base_dir,
                                                        const std::string& source_name, const LoadLimits& limits) {
    auto impl = std::make_unique<Impl>();
    impl->source = source_name;
    impl->limits = limits;
    impl->model = read_model(bytes, binary, base_dir, source_name, impl->limits, impl->read_warnings, impl->images, impl->files_read);
    impl->images.limits = nullptr;  // only decoding read them
    SceneDescription unused;
    Ctx c{impl->model, impl->source, impl->limits, unused, impl->images};
    impl->animations = read_animations(c);
    return std::shared_ptr<const GltfDocument>(new GltfDocument(std::move(impl)));
}

std::shared_ptr<const GltfDocument> GltfDocument::load(const std::string& path, const LoadLimits& limits, const std::string& name) {
    const std::string& shown = name.empty() ? path : name;
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) fail(shown, "", "not a readable file");
    const uint64_t size = fs::file_size(path, ec);
    if (ec) fail(shown, "", "cannot read: " + ec.message());
    if (size > limits.max_file_bytes)
        fail(shown, "", "file of " + str(size) + " bytes is above the limit of " + str(limits.max_file_bytes));
    std::string bytes(static_cast<size_t>(size), '\0');
    std::ifstream in(path, std::ios::binary);
    if (!in.read(bytes.data(), static_cast<std::streamsize>(size))) fail(shown, "", "cannot read the file");
    std::string ext = fs::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
    const bool binary = ext == ".glb" || std::string_view(bytes).starts_with("glTF");
    fs::path dir = fs::path(path).parent_path();
    if (dir.empty()) dir = ".";
    return parse(bytes, binary, dir.string(), shown, limits);
}

SceneDescription GltfDocument::rest() const { return impl_->flatten(nullptr); }
SceneDescription GltfDocument::pose(const ScenePose& pose) const { return impl_->flatten(&pose); }
const std::vector<Animation>& GltfDocument::animations() const { return impl_->animations.list; }

SceneDescription load_gltf(const std::string& path, const LoadLimits& limits, const std::string& name) {
    return GltfDocument::load(path, limits, name)->rest();
}

SceneDescription parse_gltf(std::string_view bytes, bool binary, const std::string& base_dir,
                            const std::string& source_name, const LoadLimits& limits) {
    return GltfDocument::parse(bytes, binary, base_dir, source_name, limits)->rest();
}

}  // namespace tessera
