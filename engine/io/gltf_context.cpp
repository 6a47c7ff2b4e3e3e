#include "engine/io/gltf_context.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace tessera::gltf {
namespace {

const char* type_name(int type) {
    switch (type) {
        case TINYGLTF_TYPE_SCALAR: return "SCALAR";
        case TINYGLTF_TYPE_VEC2: return "VEC2";
        case TINYGLTF_TYPE_VEC3: return "VEC3";
        case TINYGLTF_TYPE_VEC4: return "VEC4";
        case TINYGLTF_TYPE_MAT2: return "MAT2";
        case TINYGLTF_TYPE_MAT3: return "MAT3";
        case TINYGLTF_TYPE_MAT4: return "MAT4";
        default: return "unknown type";
    }
}

// True when `count` elements of `elem` bytes, `stride` apart, starting at `offset`, end within
// `length` bytes. Written so that no intermediate value can overflow.
bool fits(uint64_t offset, uint64_t stride, uint64_t count, uint64_t elem, uint64_t length) {
    if (count == 0) return offset <= length;
    if (offset > length || elem > length - offset) return false;
    return (count - 1) <= (length - offset - elem) / stride;
}

}  // namespace

SourceLocation at(const std::string& file, const std::string& pointer) { return {file, 0, pointer}; }

[[noreturn]] void fail(const std::string& file, const std::string& pointer, const std::string& what) {
    throw SceneError(at(file, pointer), what);
}

std::string str(uint64_t v) { return std::to_string(v); }
std::string num(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%g", v);
    return b;
}

std::string clip(std::string s, size_t max) {
    while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
    if (s.size() > max) s = s.substr(0, max) + "...";
    return s;
}

uint64_t left(uint64_t limit, uint64_t used) { return used >= limit ? 0 : limit - used; }

[[noreturn]] void fail(const Ctx& c, const std::string& pointer, const std::string& what) { fail(c.file, pointer, what); }

AccessorView view_accessor(const Ctx& c, int index, const std::string& ref, const char* role, int want_type,
                           std::initializer_list<int> want_components, uint64_t max_count, const char* what_is_left) {
    if (index < 0 || static_cast<size_t>(index) >= c.m.accessors.size())
        fail(c, ref, "refers to accessor " + std::to_string(index) + ", but the file has " + str(c.m.accessors.size()));
    const tinygltf::Accessor& a = c.m.accessors[static_cast<size_t>(index)];
    const std::string ap = "/accessors/" + str(static_cast<size_t>(index));
    if (a.sparse.isSparse) fail(c, ap, std::string("sparse accessors are not supported (used as ") + role + ")");
    if (a.type != want_type ||
        std::find(want_components.begin(), want_components.end(), a.componentType) == want_components.end())
        fail(c, ap, std::string(role) + " accessor has type " + type_name(a.type) + " with componentType " +
                        std::to_string(a.componentType) + ", which is not allowed here (see " + ref + ")");
    if (a.count > max_count)
        fail(c, ap, "count " + str(a.count) + " exceeds the " + str(max_count) + " " + what_is_left);
    if (a.bufferView < 0)
        fail(c, ap, "accessor without a bufferView (all zeros) is not supported for " + std::string(role));
    if (static_cast<size_t>(a.bufferView) >= c.m.bufferViews.size())
        fail(c, ap, "refers to bufferView " + std::to_string(a.bufferView) + ", but the file has " +
                        str(c.m.bufferViews.size()));
    const tinygltf::BufferView& bv = c.m.bufferViews[static_cast<size_t>(a.bufferView)];
    const std::string bp = "/bufferViews/" + std::to_string(a.bufferView);
    if (bv.buffer < 0 || static_cast<size_t>(bv.buffer) >= c.m.buffers.size())
        fail(c, bp, "refers to buffer " + std::to_string(bv.buffer) + ", but the file has " + str(c.m.buffers.size()));
    const std::vector<unsigned char>& buf = c.m.buffers[static_cast<size_t>(bv.buffer)].data;
    if (!fits(bv.byteOffset, 1, 1, bv.byteLength, buf.size()))
        fail(c, bp, "byteOffset " + str(bv.byteOffset) + " + byteLength " + str(bv.byteLength) + " exceeds buffer " +
                        std::to_string(bv.buffer) + " of " + str(buf.size()) + " bytes");
    const uint64_t elem = static_cast<uint64_t>(tinygltf::GetComponentSizeInBytes(a.componentType)) *
                          static_cast<uint64_t>(tinygltf::GetNumComponentsInType(a.type));
    const uint64_t stride = bv.byteStride ? bv.byteStride : elem;
    if (stride < elem)
        fail(c, bp, "byteStride " + str(stride) + " is smaller than the " + str(elem) + "-byte elements of accessor " +
                        std::to_string(index));
    if (!fits(a.byteOffset, stride, a.count, elem, bv.byteLength))
        fail(c, ap, "byteOffset " + str(a.byteOffset) + " + " + str(a.count) + " elements of " + str(elem) +
                        " bytes, stride " + str(stride) + ", exceed bufferView " + std::to_string(a.bufferView) +
                        " of " + str(bv.byteLength) + " bytes");
    if (a.count == 0) return {};
    return {buf.data() + bv.byteOffset + a.byteOffset, static_cast<size_t>(stride), a.count, a.componentType};
}

glm::vec3 read_vec3(const AccessorView& v, size_t k) {
    float f[3];
    std::memcpy(f, v.data + k * v.stride, sizeof f);
    return {f[0], f[1], f[2]};
}

uint32_t read_index(const AccessorView& v, size_t k) {
    const unsigned char* p = v.data + k * v.stride;
    if (v.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) return p[0];
    if (v.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) {
        uint16_t s;
        std::memcpy(&s, p, 2);
        return s;
    }
    uint32_t u;
    std::memcpy(&u, p, 4);
    return u;
}

bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

float read_component(const AccessorView& v, size_t k, int j) {
    const unsigned char* p = v.data + k * v.stride;
    switch (v.component_type) {
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return p[j] / 255.f;
        case TINYGLTF_COMPONENT_TYPE_BYTE: return std::max(static_cast<signed char>(p[j]) / 127.f, -1.f);
        case TINYGLTF_COMPONENT_TYPE_SHORT: {
            int16_t i;
            std::memcpy(&i, p + 2 * j, 2);
            return std::max(i / 32767.f, -1.f);
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
            uint16_t u;
            std::memcpy(&u, p + 2 * j, 2);
            return u / 65535.f;
        }
        default: {
            float f;
            std::memcpy(&f, p + 4 * j, 4);
            return f;
        }
    }
}

}  // namespace tessera::gltf
