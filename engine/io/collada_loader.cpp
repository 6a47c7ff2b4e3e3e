#include "engine/io/collada_loader.h"

#include <algorithm>
#include <cfloat>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <unordered_map>
#include <utility>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <pugixml.hpp>

namespace tessera {
namespace {

using glm::dmat4;
using glm::dvec3;
using glm::dvec4;
using Node = pugi::xml_node;

// Everything one load needs. It lives on parse_collada's stack: no global state.
struct Loader {
    std::string file;
    LoadLimits limits;
    std::vector<size_t> newlines;  // offsets of '\n' in the input, for line numbers
    std::unordered_map<std::string_view, Node> ids;
    SceneDescription scene;
    std::unordered_map<const void*, int> material_index;                   // <material> -> index
    std::unordered_map<const void*, std::vector<glm::vec3>> positions;     // <source> -> local positions
    std::set<std::string> warned;
    uint64_t triangles = 0, vertices = 0;
    bool cmu462_warned = false;
    int cameras_seen = 0;
    Node camera, camera_instance;
    dmat4 camera_transform{1.0};
};

// ---- locations, errors, warnings -------------------------------------------------------------

int line_at(const Loader& L, ptrdiff_t offset) {
    if (offset < 0) return 0;
    auto it = std::upper_bound(L.newlines.begin(), L.newlines.end(), static_cast<size_t>(offset));
    return static_cast<int>(it - L.newlines.begin()) + 1;
}

int line_of(const Loader& L, Node n) {
    // Nodes whose text pugixml had to reallocate have no offset; their parent still does.
    for (; n; n = n.parent())
        if (ptrdiff_t off = n.offset_debug(); off >= 0) return line_at(L, off);
    return 1;
}

SourceLocation where(const Loader& L, Node n) { return SourceLocation{L.file, line_of(L, n), {}}; }

[[noreturn]] void fail(const Loader& L, Node n, const std::string& what) { throw SceneError(where(L, n), what); }

void warn(Loader& L, Node n, const std::string& what) {
    // A geometry instanced a thousand times should not produce a thousand identical warnings.
    std::string w = where(L, n).str() + ": " + what;
    if (L.warned.insert(w).second) L.scene.warnings.push_back(std::move(w));
}

std::string tag(Node n) { return "<" + std::string(n.name()) + ">"; }

std::string label(Node n) {
    if (*n.attribute("name").value()) return n.attribute("name").value();
    if (*n.attribute("id").value()) return n.attribute("id").value();
    return n.name();
}

std::string clip(std::string_view s) { return std::string(s.substr(0, 40)) + (s.size() > 40 ? "..." : ""); }

// ---- numbers ---------------------------------------------------------------------------------

// The text of an element together with the node it came from, so a bad token can name its line.
struct Text {
    std::string_view s;
    Node node;
};

Text text_of(Node e) {
    for (Node c : e.children())
        if (c.type() == pugi::node_pcdata || c.type() == pugi::node_cdata) return {c.value(), c};
    return {{}, e};
}

[[noreturn]] void fail_token(const Loader& L, const Text& t, size_t pos, const std::string& what) {
    // Counting newlines inside the value (not raw offsets) stays right when pugixml folded \r\n.
    int line = line_of(L, t.node) + static_cast<int>(std::count(t.s.begin(), t.s.begin() + pos, '\n'));
    throw SceneError(SourceLocation{L.file, line, {}}, what);
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

std::string_view trim(std::string_view s) {
    while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
    while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
    return s;
}

// Calls take(token, offset) for each whitespace-separated token of t.
template <class F>
void for_each_token(const Text& t, F&& take) {
    size_t i = 0, n = t.s.size();
    while (i < n) {
        while (i < n && is_space(t.s[i])) ++i;
        size_t start = i;
        while (i < n && !is_space(t.s[i])) ++i;
        if (i > start) take(t.s.substr(start, i - start), start);
    }
}

// At most this many tokens can fit in the text, whatever a count attribute claims.
size_t token_bound(const Text& t) { return t.s.size() / 2 + 1; }

double to_real(const Loader& L, const Text& t, std::string_view tok, size_t pos, Node owner) {
    std::string_view num = tok;
    if (num.size() > 1 && num[0] == '+') num.remove_prefix(1);
    double v = 0;
    auto [end, ec] = std::from_chars(num.data(), num.data() + num.size(), v);
    if (ec == std::errc::result_out_of_range && end == num.data() + num.size())
        v = std::strtod(std::string(num).c_str(), nullptr);  // underflow becomes 0, overflow inf (refused below)
    else if (ec != std::errc() || end != num.data() + num.size())
        fail_token(L, t, pos, "'" + clip(tok) + "' in " + tag(owner) + " is not a number");
    if (!std::isfinite(v) || std::abs(v) > FLT_MAX)
        fail_token(L, t, pos, "non-finite or out-of-range value '" + clip(tok) + "' in " + tag(owner));
    return v;
}

uint64_t to_uint(const Loader& L, const Text& t, std::string_view tok, size_t pos, Node owner, uint64_t max) {
    uint64_t v = 0;
    auto [end, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), v);
    if (!tok.empty() && tok[0] == '-')
        fail_token(L, t, pos, "negative value '" + clip(tok) + "' in " + tag(owner) + " where a count or index belongs");
    if (ec == std::errc::result_out_of_range || (ec == std::errc() && v > max))
        fail_token(L, t, pos, "value '" + clip(tok) + "' in " + tag(owner) + " is too large (limit " + std::to_string(max) + ")");
    if (ec != std::errc() || end != tok.data() + tok.size())
        fail_token(L, t, pos, "'" + clip(tok) + "' in " + tag(owner) + " is not a non-negative integer");
    return v;
}

// Small fixed-size lists (colours, matrices): refuse more than `max` numbers without storing them.
std::vector<double> read_reals(const Loader& L, Node e, size_t min, size_t max) {
    Text t = text_of(e);
    std::vector<double> out;
    for_each_token(t, [&](std::string_view tok, size_t pos) {
        if (out.size() == max) fail_token(L, t, pos, tag(e) + " has more than " + std::to_string(max) + " numbers");
        out.push_back(to_real(L, t, tok, pos, e));
    });
    if (out.size() < min)
        fail(L, e, tag(e) + " needs " + std::to_string(min) + " numbers, found " + std::to_string(out.size()));
    return out;
}

double read_scalar(const Loader& L, Node e) { return read_reals(L, e, 1, 1)[0]; }

// A colour or vector: three numbers, or four for RGBA colours (alpha ignored).
dvec3 read_vec3(const Loader& L, Node e) {
    auto v = read_reals(L, e, 3, 4);
    return {v[0], v[1], v[2]};
}

std::vector<uint32_t> read_uints(const Loader& L, Node e) {
    Text t = text_of(e);
    std::vector<uint32_t> out;
    out.reserve(token_bound(t));
    for_each_token(t, [&](std::string_view tok, size_t pos) {
        out.push_back(static_cast<uint32_t>(to_uint(L, t, tok, pos, e, UINT32_MAX)));
    });
    return out;
}

// An integer attribute; `fallback` when absent (negative fallback: the attribute is required).
uint64_t attr_uint(const Loader& L, Node e, const char* name, int64_t fallback, uint64_t max = UINT32_MAX) {
    pugi::xml_attribute a = e.attribute(name);
    if (!a) {
        if (fallback < 0) fail(L, e, tag(e) + " needs a '" + name + "' attribute");
        return static_cast<uint64_t>(fallback);
    }
    return to_uint(L, Text{{}, e}, trim(a.value()), 0, e, max);
}

// ---- references ------------------------------------------------------------------------------

void index_ids(Loader& L, Node root) {
    // Iterative, because a hostile file may nest elements far deeper than the stack allows.
    Node n = root;
    while (n) {
        if (n.type() == pugi::node_element)
            if (pugi::xml_attribute id = n.attribute("id")) L.ids.emplace(id.value(), n);  // first one wins
        if (n.first_child()) {
            n = n.first_child();
            continue;
        }
        while (n && n != root && !n.next_sibling()) n = n.parent();
        if (!n || n == root) break;
        n = n.next_sibling();
    }
}

// Follows a same-file reference such as url="#id" and checks what it points at.
Node resolve(const Loader& L, Node from, const char* attr, const char* expected) {
    std::string_view url = from.attribute(attr).value();
    if (url.size() < 2 || url[0] != '#')
        fail(L, from, tag(from) + " needs " + attr + "=\"#id\" naming an element of this file, got '" + clip(url) + "'");
    auto it = L.ids.find(url.substr(1));
    if (it == L.ids.end()) fail(L, from, tag(from) + " refers to '" + clip(url) + "', which this file does not define");
    if (std::string_view(it->second.name()) != expected)
        fail(L, from, tag(from) + " refers to '" + clip(url) + "', a " + tag(it->second) + " rather than a <" + expected + ">");
    return it->second;
}

// The <extra><technique profile="CGL"> of an element. CMU462 (the CMU 15-462 ancestor of the
// CS184 code) uses the same vocabulary, so it is read alike.
Node cgl_technique(Loader& L, Node e) {
    for (Node extra : e.children("extra"))
        for (Node tech : extra.children("technique")) {
            std::string_view profile = tech.attribute("profile").value();
            if (profile == "CGL") return tech;
            if (profile == "CMU462") {
                if (!std::exchange(L.cmu462_warned, true)) warn(L, tech, "profile CMU462 is read as CGL");
                return tech;
            }
        }
    return {};
}

Node first_element(Node e) {
    for (Node c : e.children())
        if (c.type() == pugi::node_element) return c;
    return {};
}

// ---- transforms ------------------------------------------------------------------------------

dmat4 axis_fix(Loader& L, Node root) {
    Node up = root.child("asset").child("up_axis");
    if (!up) {
        warn(L, root.child("asset") ? root.child("asset") : root, "no <up_axis> in <asset>; assuming Y_UP");
        return dmat4(1.0);
    }
    const std::string_view axis = trim(text_of(up).s);
    dmat4 m(1.0);  // glm is column-major: m[col][row]
    if (axis == "Y_UP") return m;
    if (axis == "Z_UP") {  // (x, y, z) -> (-x, z, y)
        m[0][0] = -1; m[1][1] = 0; m[2][1] = 1; m[1][2] = 1; m[2][2] = 0;
        return m;
    }
    if (axis == "X_UP") {  // (x, y, z) -> (y, x, -z)
        m[0][0] = 0; m[1][0] = 1; m[0][1] = 1; m[1][1] = 0; m[2][2] = -1;
        return m;
    }
    fail(L, up, "<up_axis> must be X_UP, Y_UP or Z_UP, got '" + clip(axis) + "'");
}

// A node that only holds a camera: CS184 uses its transform for nothing but the orbit direction.
bool camera_only(Node node) {
    bool camera = false;
    for (Node c : node.children()) {
        std::string_view n = c.name();
        if (n == "instance_camera") camera = true;
        else if (n == "node" || n.starts_with("instance_")) return false;
    }
    return camera;
}

// The node's own transform: its transformation elements multiplied in document order.
dmat4 local_transform(Loader& L, Node node) {
    dmat4 m(1.0);
    for (Node c : node.children()) {
        std::string_view n = c.name();
        if (n == "matrix") {
            // sky/CBgems.dae gives its camera 15 numbers; CS184's stream reads the missing one as 0
            // and renders the file, so a camera-only node is read the same way. Elsewhere it is an error.
            const bool lenient = camera_only(node);
            auto v = read_reals(L, c, lenient ? 0 : 16, 16);
            if (v.size() < 16) {
                warn(L, c, "<matrix> of camera node '" + label(node) + "' has " + std::to_string(v.size()) +
                               " numbers, not 16; the missing ones read as 0, as CS184 does");
                v.resize(16, 0.0);
            }
            dmat4 t;
            for (int r = 0; r < 4; ++r)
                for (int col = 0; col < 4; ++col) t[col][r] = v[r * 4 + col];  // file is row-major
            m = m * t;
        } else if (n == "translate") {
            auto v = read_reals(L, c, 3, 3);
            m = glm::translate(m, dvec3(v[0], v[1], v[2]));
        } else if (n == "scale") {
            auto v = read_reals(L, c, 3, 3);
            m = glm::scale(m, dvec3(v[0], v[1], v[2]));
        } else if (n == "rotate") {
            auto v = read_reals(L, c, 4, 4);
            dvec3 axis(v[0], v[1], v[2]);
            if (glm::length(axis) == 0.0) fail(L, c, "<rotate> has a zero axis");
            m = glm::rotate(m, glm::radians(v[3]), glm::normalize(axis));
        } else if (n == "lookat") {
            auto v = read_reals(L, c, 9, 9);
            dvec3 eye(v[0], v[1], v[2]), target(v[3], v[4], v[5]), up(v[6], v[7], v[8]);
            if (eye == target || glm::length(glm::cross(target - eye, up)) == 0.0)
                fail(L, c, "<lookat> has coincident eye and target or an up vector along the view");
            m = m * glm::inverse(glm::lookAt(eye, target, up));
        } else if (n == "skew") {
            warn(L, c, "<skew> in node '" + label(node) + "' is not supported and was ignored");
        }
    }
    return m;
}

glm::vec3 point(const dmat4& T, dvec3 p) { return glm::vec3(dvec3(T * dvec4(p, 1.0))); }
dvec3 dir(const dmat4& T, dvec3 d) { return dvec3(T * dvec4(d, 0.0)); }

// ---- materials -------------------------------------------------------------------------------

glm::vec3 vec3_param(const Loader& L, Node parent, const char* name, glm::vec3 fallback, bool non_negative = true) {
    Node e = parent.child(name);
    if (!e) return fallback;
    dvec3 v = read_vec3(L, e);
    if (non_negative && (v.x < 0 || v.y < 0 || v.z < 0)) fail(L, e, tag(e) + " must not be negative");
    return glm::vec3(v);
}

float scalar_param(const Loader& L, Node parent, const char* name, float fallback, bool positive = false) {
    Node e = parent.child(name);
    if (!e) return fallback;
    double v = read_scalar(L, e);
    if (v < 0 || (positive && v == 0)) fail(L, e, tag(e) + " must be " + (positive ? "positive" : "non-negative"));
    return static_cast<float>(v);
}

// One child of the CGL technique turned into a material; false when the element is not a BSDF.
bool apply_cgl(const Loader& L, Node c, MaterialDesc& m) {
    std::string_view n = c.name();
    if (n == "emission") {
        if (!c.child("radiance")) fail(L, c, "CGL <emission> needs a <radiance>");
        m.kind = MaterialKind::emission;
        m.emission = vec3_param(L, c, "radiance", {});
        m.albedo = glm::vec3(0.0f);
    } else if (n == "mirror") {
        m.kind = MaterialKind::mirror;
        m.albedo = vec3_param(L, c, "reflectance", glm::vec3(1.0f));
    } else if (n == "glass" || n == "refraction") {
        m.kind = MaterialKind::glass;
        // A pure refraction BSDF reflects nothing.
        m.albedo = n == "glass" ? vec3_param(L, c, "reflectance", glm::vec3(1.0f)) : glm::vec3(0.0f);
        m.transmittance = vec3_param(L, c, "transmittance", glm::vec3(1.0f));
        m.roughness = scalar_param(L, c, "roughness", 0.0f);
        m.ior = scalar_param(L, c, "ior", 1.5f, true);
    } else if (n == "microfacet") {
        m.kind = MaterialKind::microfacet;
        m.roughness = scalar_param(L, c, "alpha", 0.5f, true);
        m.eta = vec3_param(L, c, "eta", glm::vec3(0.0f));
        m.k = vec3_param(L, c, "k", glm::vec3(0.0f));
    } else if (n == "glossy") {
        m.kind = MaterialKind::glossy;
        m.albedo = vec3_param(L, c, "reflectance", glm::vec3(1.0f));
        m.shininess = scalar_param(L, c, "shininess", 0.0f);
    } else {
        return false;
    }
    return true;
}

MaterialDesc read_material(Loader& L, Node material) {
    MaterialDesc m;
    m.name = label(material);
    m.origin = where(L, material);
    Node inst = material.child("instance_effect");
    if (!inst) fail(L, material, "material '" + m.name + "' has no <instance_effect>");
    Node effect = resolve(L, inst, "url", "effect");

    // Lambertian base: the diffuse colour of whichever shading model Blender wrote.
    Node tech = effect.child("profile_COMMON").child("technique");
    for (const char* model : {"phong", "lambert", "blinn", "constant"}) {
        Node diffuse = tech.child(model).child("diffuse");
        if (!diffuse) continue;
        if (Node color = diffuse.child("color")) {
            m.albedo = glm::vec3(read_vec3(L, color));
            if (m.albedo.x < 0 || m.albedo.y < 0 || m.albedo.z < 0) fail(L, color, "diffuse colour must not be negative");
        } else if (diffuse.child("texture")) {
            warn(L, diffuse, "material '" + m.name + "' has a diffuse texture, which is not supported; rendered 0.5 grey");
        }
        break;
    }

    // The CS184 loader lets the last BSDF it recognises in the CGL technique decide.
    if (Node cgl = cgl_technique(L, effect)) {
        const MaterialDesc base = m;
        for (Node c : cgl.children()) {
            if (c.type() != pugi::node_element) continue;
            MaterialDesc candidate = base;
            if (apply_cgl(L, c, candidate))
                m = candidate;
            else
                warn(L, c, "material '" + m.name + "': CGL " + tag(c) + " is not a known BSDF and was ignored");
        }
    }
    return m;
}

int material_index(Loader& L, Node material) {
    auto [it, fresh] = L.material_index.try_emplace(material.internal_object(), -1);
    if (fresh) {
        MaterialDesc m = read_material(L, material);
        it->second = static_cast<int>(L.scene.materials.size());
        L.scene.materials.push_back(std::move(m));
    }
    return it->second;
}

// <bind_material>: symbol -> <material>, in document order.
using Bindings = std::vector<std::pair<std::string_view, Node>>;

Bindings read_bindings(const Loader& L, Node instance) {
    Bindings b;
    for (Node im : instance.child("bind_material").child("technique_common").children("instance_material"))
        b.emplace_back(im.attribute("symbol").value(), resolve(L, im, "target", "material"));
    return b;
}

int bound_material(Loader& L, const Bindings& b, std::string_view symbol) {
    if (b.empty()) return -1;  // unbound: the default grey
    for (const auto& [sym, mat] : b)
        if (sym == symbol) return material_index(L, mat);
    return material_index(L, b.front().second);  // as CS184: the first binding covers the geometry
}

// ---- meshes ----------------------------------------------------------------------------------

std::vector<float> read_float_array(const Loader& L, Node array) {
    Text t = text_of(array);
    const bool declared = !array.attribute("count").empty();
    const uint64_t count = attr_uint(L, array, "count", 0, UINT64_MAX);
    std::vector<float> out;
    out.reserve(declared ? std::min<uint64_t>(count, token_bound(t)) : token_bound(t));  // never trust count alone
    for_each_token(t, [&](std::string_view tok, size_t pos) {
        out.push_back(static_cast<float>(to_real(L, t, tok, pos, array)));
    });
    if (declared && out.size() != count)
        fail(L, array, "<float_array> declares count=" + std::to_string(count) + " but holds " + std::to_string(out.size()) +
                           " numbers");
    return out;
}

// The positions a <source> describes, in the geometry's own space (cached: geometries are reused).
const std::vector<glm::vec3>& read_positions(Loader& L, Node source) {
    if (auto it = L.positions.find(source.internal_object()); it != L.positions.end()) return it->second;
    Node acc = source.child("technique_common").child("accessor");
    if (!acc) fail(L, source, "<source> '" + label(source) + "' has no <technique_common><accessor>");
    const uint64_t count = attr_uint(L, acc, "count", -1);
    const uint64_t stride = attr_uint(L, acc, "stride", 1);
    const uint64_t offset = attr_uint(L, acc, "offset", 0);
    if (stride < 3 || stride > 4096) fail(L, acc, "accessor stride " + std::to_string(stride) + " cannot hold x y z positions");
    if (count > L.limits.max_vertices)
        fail(L, acc, "accessor count " + std::to_string(count) + " exceeds the vertex limit of " +
                         std::to_string(L.limits.max_vertices));
    Node array = acc.attribute("source") ? resolve(L, acc, "source", "float_array") : source.child("float_array");
    if (!array) fail(L, source, "<source> '" + label(source) + "' has no <float_array>");
    std::vector<float> values = read_float_array(L, array);
    // count and stride are bounded above, so this cannot overflow 64 bits.
    if (count > 0 && offset + (count - 1) * stride + 3 > values.size())
        fail(L, acc, "accessor reads " + std::to_string(count) + " positions of stride " + std::to_string(stride) +
                         " from a <float_array> of " + std::to_string(values.size()) + " numbers");
    std::vector<glm::vec3> out(count);
    for (uint64_t i = 0; i < count; ++i) {
        const float* p = values.data() + offset + i * stride;
        out[i] = {p[0], p[1], p[2]};
    }
    return L.positions.emplace(source.internal_object(), std::move(out)).first->second;
}

// A primitive in the common form: polygon sizes plus the interleaved index list.
struct Polygons {
    std::vector<uint32_t> sizes;
    std::vector<uint32_t> p;
    size_t stride = 1;        // indices per polygon corner
    size_t vertex_offset = 0; // which of them indexes the positions
    Node positions_source;
};

void read_inputs(const Loader& L, Node prim, Polygons& out) {
    uint64_t max_offset = 0;
    Node vertex_input;
    for (Node in : prim.children("input")) {
        uint64_t off = attr_uint(L, in, "offset", -1, 255);
        max_offset = std::max(max_offset, off);
        if (std::string_view(in.attribute("semantic").value()) == "VERTEX") {
            vertex_input = in;
            out.vertex_offset = off;
        }
    }
    if (!vertex_input) fail(L, prim, tag(prim) + " has no <input semantic=\"VERTEX\">");
    out.stride = max_offset + 1;
    Node vertices = resolve(L, vertex_input, "source", "vertices");
    for (Node in : vertices.children("input"))
        if (std::string_view(in.attribute("semantic").value()) == "POSITION") out.positions_source = resolve(L, in, "source", "source");
    if (!out.positions_source) fail(L, vertices, "<vertices> has no <input semantic=\"POSITION\">");
}

bool is_primitive(std::string_view n) {
    return n == "polylist" || n == "triangles" || n == "polygons" || n == "lines" || n == "linestrips" ||
           n == "tristrips" || n == "trifans";
}

// Reads a <polylist>, <triangles> or <polygons>; false (with a warning) for other primitives.
bool read_primitive(Loader& L, Node geometry, Node prim, Polygons& out) {
    std::string_view kind = prim.name();
    if (kind != "polylist" && kind != "triangles" && kind != "polygons") {
        warn(L, prim, tag(prim) + " primitives of geometry '" + label(geometry) + "' are not supported and were skipped");
        return false;
    }
    read_inputs(L, prim, out);
    if (kind == "polygons") {
        for (Node c : prim.children()) {
            std::string_view n = c.name();
            if (n == "ph") warn(L, c, "<ph> polygons with holes are not supported and were skipped");
            if (n != "p") continue;
            std::vector<uint32_t> p = read_uints(L, c);
            if (p.size() % out.stride != 0) fail(L, c, "<p> length is not a multiple of the " + std::to_string(out.stride) + " inputs");
            out.sizes.push_back(static_cast<uint32_t>(p.size() / out.stride));
            out.p.insert(out.p.end(), p.begin(), p.end());
        }
    } else {
        Node pe = prim.child("p");
        out.p = pe ? read_uints(L, pe) : std::vector<uint32_t>{};
        const uint64_t count = attr_uint(L, prim, "count", -1);
        if (kind == "triangles") {
            if (count * 3 * out.stride != out.p.size())
                fail(L, pe ? pe : prim, "<triangles count=\"" + std::to_string(count) + "\"> needs " +
                                            std::to_string(count * 3 * out.stride) + " indices in <p>, found " +
                                            std::to_string(out.p.size()));
            out.sizes.assign(count, 3);
        } else {
            Node vc = prim.child("vcount");
            if (!vc) fail(L, prim, "<polylist> has no <vcount>");
            out.sizes = read_uints(L, vc);
            if (out.sizes.size() != count)
                fail(L, vc, "<vcount> lists " + std::to_string(out.sizes.size()) + " polygons but <polylist count=\"" +
                                std::to_string(count) + "\">");
            uint64_t corners = 0;  // checked as it grows, so hostile counts cannot wrap around
            for (uint32_t s : out.sizes)
                if ((corners += s) * out.stride > out.p.size()) break;
            if (corners * out.stride != out.p.size())
                fail(L, pe ? pe : vc, "<vcount> and the " + std::to_string(out.stride) + " inputs need " +
                                          (corners * out.stride > out.p.size() ? "more than " : "") +
                                          std::to_string(corners * out.stride) + " indices but <p> holds " +
                                          std::to_string(out.p.size()));
        }
    }
    for (uint32_t s : out.sizes)
        if (s < 3) fail(L, prim, tag(prim) + " has a polygon with " + std::to_string(s) + " vertices");
    return true;
}

void add_mesh(Loader& L, Node geometry, Node mesh, const dmat4& T, const Bindings& bindings) {
    int part = 0;
    for (Node prim : mesh.children()) {
        Polygons poly;
        if (!is_primitive(prim.name()) || !read_primitive(L, geometry, prim, poly)) continue;
        uint64_t tris = 0;
        for (uint32_t s : poly.sizes) tris += s - 2;
        if (tris == 0) continue;  // its positions would only distort the scene bounds
        if (L.triangles + tris > L.limits.max_triangles)
            fail(L, prim, "the scene exceeds the triangle limit of " + std::to_string(L.limits.max_triangles));
        const std::vector<glm::vec3>& local = read_positions(L, poly.positions_source);
        if (L.vertices + local.size() > L.limits.max_vertices)
            fail(L, prim, "the scene exceeds the vertex limit of " + std::to_string(L.limits.max_vertices));
        L.triangles += tris;
        L.vertices += local.size();

        MeshDesc m;
        m.name = label(geometry) + (part++ ? "." + std::to_string(part - 1) : "");
        m.material = bound_material(L, bindings, prim.attribute("material").value());
        m.origin = where(L, prim);
        m.positions.reserve(local.size());
        for (const glm::vec3& p : local) m.positions.push_back(point(T, p));
        // Normals stay empty: CS184 ignores the file's and recomputes area-weighted ones.
        m.indices.reserve(tris * 3);
        size_t corner = 0;
        auto vertex = [&](size_t c) {
            uint32_t v = poly.p[c * poly.stride + poly.vertex_offset];
            if (v >= local.size())
                fail(L, prim.child("p") ? prim.child("p") : prim,
                     "vertex index " + std::to_string(v) + " is out of range (" + std::to_string(local.size()) + " positions)");
            return v;
        };
        for (uint32_t s : poly.sizes) {
            for (uint32_t k = 1; k + 1 < s; ++k) {  // fan around the first corner
                m.indices.push_back(vertex(corner));
                m.indices.push_back(vertex(corner + k));
                m.indices.push_back(vertex(corner + k + 1));
            }
            corner += s;
        }
        L.scene.meshes.push_back(std::move(m));
    }
}

// ---- scene graph -----------------------------------------------------------------------------

void add_sphere(Loader& L, Node sphere, const dmat4& T, const Bindings& bindings) {
    Node r = sphere.child("radius");
    double radius = r ? read_scalar(L, r) : 1.0;
    if (!(radius > 0)) fail(L, r ? r : sphere, "sphere radius must be positive, got " + std::to_string(radius));
    SphereDesc s;
    s.center = point(T, dvec3(0.0));
    s.radius = static_cast<float>(radius * glm::length(dir(T, dvec3(1, 0, 0))));
    s.material = bound_material(L, bindings, "");
    s.origin = where(L, sphere);
    L.scene.spheres.push_back(s);
}

void instance_geometry(Loader& L, Node inst, const dmat4& T) {
    Node geometry = resolve(L, inst, "url", "geometry");
    Bindings bindings = read_bindings(L, inst);
    if (Node mesh = geometry.child("mesh"))
        add_mesh(L, geometry, mesh, T, bindings);
    else if (Node sphere = cgl_technique(L, geometry).child("sphere"))
        add_sphere(L, sphere, T, bindings);
    else
        warn(L, geometry, "geometry '" + label(geometry) + "' has neither a <mesh> nor a CGL <sphere>; skipped");
}

void instance_light(Loader& L, Node inst, const dmat4& T) {
    Node light = resolve(L, inst, "url", "light");
    // A CGL technique overrides the standard one; its first element names the light type.
    Node type = first_element(cgl_technique(L, light));
    if (!type) type = first_element(light.child("technique_common"));
    if (!type) fail(L, light, "light '" + label(light) + "' has no <technique_common> or CGL <technique>");
    std::string_view n = type.name();
    LightDesc d;
    d.origin = where(L, type);
    if (n == "ambient") d.kind = LightKind::ambient;
    else if (n == "directional") d.kind = LightKind::directional;
    else if (n == "area") d.kind = LightKind::area;
    else if (n == "point") d.kind = LightKind::point;
    else if (n == "spot") d.kind = LightKind::spot;
    else {
        warn(L, type, "light '" + label(light) + "' of unknown type " + tag(type) + " was skipped");
        return;
    }
    Node color = type.child("color");
    if (!color) fail(L, type, "light '" + label(light) + "' " + tag(type) + " has no <color>");
    d.radiance = glm::vec3(read_vec3(L, color));
    for (const char* a : {"constant_attenuation", "linear_attenuation", "quadratic_attenuation"})
        if (Node e = type.child(a)) read_scalar(L, e);  // checked, then ignored as CS184 does

    const dvec3 position = dvec3(T * dvec4(0, 0, 0, 1));
    d.position = glm::vec3(position);
    dvec3 forward = dir(T, dvec3(0, 0, -1));
    if (d.kind == LightKind::area) {
        // CS184 reads the area light's frame through T as points, not directions.
        forward = dvec3(T * dvec4(0, 0, -1, 1)) - position;
        d.dim_y = glm::vec3(dvec3(T * dvec4(0, 1, 0, 1)) - position);
        d.dim_x = glm::vec3(dvec3(T * dvec4(-1, 0, 0, 1)) - position);
    }
    if (d.kind == LightKind::directional || d.kind == LightKind::area || d.kind == LightKind::spot) {
        if (!(glm::length(forward) > 0)) fail(L, inst, "light '" + label(light) + "' has a degenerate transform (no direction)");
        d.direction = glm::vec3(glm::normalize(forward));
    }
    if (d.kind == LightKind::spot)
        warn(L, type, "spot light '" + label(light) + "': its cone angles are not kept (LightDesc has no field for them)");
    L.scene.lights.push_back(d);
}

void visit_node(Loader& L, Node node, const dmat4& parent, int depth) {
    if (depth > L.limits.max_node_depth)
        fail(L, node, "<node> elements nest deeper than " + std::to_string(L.limits.max_node_depth) + " levels");
    const dmat4 T = parent * local_transform(L, node);
    for (Node c : node.children()) {
        std::string_view n = c.name();
        if (n == "instance_geometry") instance_geometry(L, c, T);
        else if (n == "instance_light") instance_light(L, c, T);
        else if (n == "instance_camera") {
            L.camera = resolve(L, c, "url", "camera");  // as in CS184, the last camera wins
            L.camera_instance = c;
            L.camera_transform = T;
            ++L.cameras_seen;
        } else if (n == "node") visit_node(L, c, T, depth + 1);
        else if (n == "instance_node")
            warn(L, c, "<instance_node> in node '" + label(node) + "' is not supported; the instanced node was skipped");
        else if (n == "instance_controller")
            warn(L, c, "<instance_controller> (skinned or morphed geometry) in node '" + label(node) + "' was skipped");
    }
}

// ---- camera ----------------------------------------------------------------------------------

double deg_tan_half(double deg) { return std::tan(glm::radians(deg) / 2.0); }
double deg_atan2x(double t) { return glm::degrees(2.0 * std::atan(t)); }

CameraDesc read_camera(Loader& L, Node camera, const dmat4& T) {
    CameraDesc c;
    c.origin = where(L, camera);
    double h = 50.0, v = 35.0, znear = 0.001, zfar = 1000.0;
    Node persp = camera.child("optics").child("technique_common").child("perspective");
    if (!persp)
        warn(L, camera, "camera '" + label(camera) + "' is not a <perspective> camera; using the default field of view");
    auto fov = [&](const char* name, double fallback) {
        Node e = persp.child(name);
        if (!e) return fallback;
        double d = read_scalar(L, e);
        if (!(d > 0 && d < 180)) fail(L, e, tag(e) + " must lie in (0, 180) degrees");
        return d;
    };
    h = fov("xfov", h);
    v = fov("yfov", v);
    if (!persp.child("yfov"))
        if (Node ar = persp.child("aspect_ratio")) {
            double a = read_scalar(L, ar);
            if (!(a > 0)) fail(L, ar, "<aspect_ratio> must be positive");
            v = deg_atan2x(deg_tan_half(h) / a);
        }
    if (Node e = persp.child("znear")) znear = read_scalar(L, e);
    if (Node e = persp.child("zfar")) zfar = read_scalar(L, e);
    if (!(znear >= 0 && zfar > znear)) fail(L, persp, "camera clip range must satisfy 0 <= znear < zfar");

    // CS184 fits the field of view to its 800x600 window, which fixes the focal length in pixels.
    const double ar = 800.0 / 600.0;
    if (deg_tan_half(h) / deg_tan_half(v) < ar) h = deg_atan2x(deg_tan_half(v) * ar);
    else v = deg_atan2x(deg_tan_half(h) / ar);
    c.hfov_deg = static_cast<float>(h);
    c.vfov_deg = static_cast<float>(v);
    c.focal_px = static_cast<float>(300.0 / deg_tan_half(v));
    c.znear = static_cast<float>(znear);
    c.zfar = static_cast<float>(zfar);

    // CS184 takes the point one unit ahead of the camera (not its view direction) as the orbit
    // direction; for Blender's cameras both lie on the same side of the scene.
    const dvec3 position = dvec3(T * dvec4(0, 0, 0, 1));
    dvec3 orbit = dvec3(T * dvec4(0, 0, -1, 1)), forward = dir(T, dvec3(0, 0, -1)), up = dir(T, dvec3(0, 1, 0));
    if (!(glm::length(orbit) > 0)) {
        if (!(glm::length(forward) > 0)) fail(L, L.camera_instance, "camera '" + label(camera) + "' has a degenerate transform");
        warn(L, L.camera_instance, "camera '" + label(camera) + "' is one unit from the origin looking at it; orbiting from behind it");
        orbit = -forward;
    }
    // Only a padded (short) matrix gets here with no forward or up; CS184 needs neither.
    if (!(glm::length(forward) > 0)) forward = -orbit;
    if (!(glm::length(glm::cross(forward, up)) > 0)) up = dvec3(0, 1, 0);
    c.cs184_orbit_dir = glm::vec3(glm::normalize(orbit));
    c.position = glm::vec3(position);
    c.look_at = glm::vec3(position + glm::normalize(forward));
    c.up = glm::vec3(glm::normalize(up));
    return c;
}

}  // namespace

SceneDescription parse_collada(std::string_view xml, const std::string& source_name, const LoadLimits& limits) {
    Loader L;
    L.file = source_name;
    L.limits = limits;
    if (xml.size() > limits.max_file_bytes)
        throw SceneError(SourceLocation{source_name, 0, {}}, "file of " + std::to_string(xml.size()) +
                                                                 " bytes exceeds the limit of " + std::to_string(limits.max_file_bytes));
    for (size_t i = xml.find('\n'); i != std::string_view::npos; i = xml.find('\n', i + 1)) L.newlines.push_back(i);

    pugi::xml_document doc;
    pugi::xml_parse_result parsed = doc.load_buffer(xml.data(), xml.size(), pugi::parse_default, pugi::encoding_utf8);
    if (!parsed)
        throw SceneError(SourceLocation{source_name, std::max(1, line_at(L, parsed.offset)), {}},
                         std::string("malformed XML: ") + parsed.description());
    Node root = doc.document_element();
    if (std::string_view(root.name()) != "COLLADA") fail(L, root ? root : Node(doc), "not a COLLADA document (root is " + tag(root) + ")");
    index_ids(L, root);
    L.scene.source = source_name;

    const dmat4 fix = axis_fix(L, root);
    Node ivs = root.child("scene").child("instance_visual_scene");
    if (!ivs) fail(L, root.child("scene") ? root.child("scene") : root, "no <scene><instance_visual_scene>: nothing to render");
    Node visual_scene = resolve(L, ivs, "url", "visual_scene");
    for (Node n : visual_scene.children("node")) visit_node(L, n, fix, 1);

    if (L.camera) {
        if (L.cameras_seen > 1)
            warn(L, L.camera_instance, std::to_string(L.cameras_seen) + " cameras in the scene; using the last, '" +
                                           label(L.camera) + "', as CS184 does");
        L.scene.camera = read_camera(L, L.camera, L.camera_transform);
    }
    validate(L.scene);
    return std::move(L.scene);
}

SceneDescription load_collada(const std::string& path, const LoadLimits& limits, const std::string& name) {
    const std::string& shown = name.empty() ? path : name;
    std::error_code ec;
    const auto size = std::filesystem::file_size(path, ec);
    if (ec) throw SceneError(SourceLocation{shown, 0, {}}, "cannot read the file: " + ec.message());
    if (size > limits.max_file_bytes)
        throw SceneError(SourceLocation{shown, 0, {}}, "file of " + std::to_string(size) + " bytes exceeds the limit of " +
                                                          std::to_string(limits.max_file_bytes));
    std::ifstream in(path, std::ios::binary);
    std::string data(size, '\0');
    if (!in.read(data.data(), static_cast<std::streamsize>(size)))
        throw SceneError(SourceLocation{shown, 0, {}}, "cannot read the file");
    return parse_collada(data, shown, limits);
}

}  // namespace tessera
