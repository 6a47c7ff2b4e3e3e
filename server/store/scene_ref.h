#pragma once
// What a farm's job names as its scene or environment map: a built-in scene, or a file by
// content hash, whose bytes are in Redis under keys::scene(hash), published by the API node that
// accepted the job. Render nodes load exactly the bytes the job named, whatever their folders.
#include <optional>
#include <string>

namespace tessera::server {

struct SceneRef {
    std::string source;  // "builtin:NAME[?params]", or the file's path on the API node
    std::string hash;    // content_hash of the file; "" for built-ins
    std::string ext;     // the file's extension, lower case (".dae", ".gltf", ".exr"), which picks the loader
    // What the job's errors, log and report call the file: its place in the API node's catalog
    // (CatalogEntry::shown). A reference an older API node wrote has none: its file name then.
    std::string name;
    std::string encode() const { return source + "\n" + hash + "\n" + ext + "\n" + name; }
    std::string shown() const;
    static SceneRef decode(const std::string& s);
};

// A content hash for scene files: "fnv1a64-<16 hex>-<size>". It names a file's bytes so a
// render node loads exactly what the job named; it is not a defence against forged files (the
// files come from the catalog and from uploads that API nodes validated).
std::string content_hash(const std::string& bytes);

// A file read whole, with its reference; nothing when it cannot be read.
struct SceneFile {
    SceneRef ref;
    std::string bytes;
};
std::optional<SceneFile> read_scene_file(const std::string& path);

}  // namespace tessera::server
