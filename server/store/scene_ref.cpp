#include "server/store/scene_ref.h"

#include <cctype>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

namespace tessera::server {

SceneRef SceneRef::decode(const std::string& s) {
    SceneRef r;
    std::istringstream in(s);
    std::getline(in, r.source);
    std::getline(in, r.hash);
    std::getline(in, r.ext);
    std::getline(in, r.name);
    return r;
}

std::string SceneRef::shown() const {
    if (!name.empty()) return name;
    return hash.empty() ? source : std::filesystem::path(source).filename().string();  // a built-in: its name
}

std::string content_hash(const std::string& bytes) {
    uint64_t h = 1469598103934665603ull;
    for (unsigned char c : bytes) {
        h ^= c;
        h *= 1099511628211ull;
    }
    char buf[64];
    std::snprintf(buf, sizeof buf, "fnv1a64-%016llx-%zu", static_cast<unsigned long long>(h), bytes.size());
    return buf;
}

std::optional<SceneFile> read_scene_file(const std::string& path) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) return std::nullopt;  // a folder opens, then throws on read
    std::ifstream in(path, std::ios::binary);
    if (!in) return std::nullopt;
    SceneFile f;
    try {
        f.bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    } catch (const std::exception&) {
        return std::nullopt;  // a read error (EIO, a file replaced by a folder meanwhile)
    }
    if (!in.good() && !in.eof()) return std::nullopt;
    f.ref.source = path;
    f.ref.hash = content_hash(f.bytes);
    f.ref.ext = std::filesystem::path(path).extension().string();
    for (char& c : f.ref.ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    return f;
}

}  // namespace tessera::server
