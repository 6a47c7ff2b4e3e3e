#pragma once
// A render node's prepared scenes: loaded and built once, then reused by every tile and every
// job that names the same scene bytes with the same build options. Least recently used scenes
// go first when the estimated memory passes the bound (a scene in use stays alive until its
// tiles finish: entries are shared pointers).
#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <string>

#include "engine/io/scene_loader.h"
#include "engine/scene/render_scene.h"
#include "server/redis_client.h"

namespace tessera::server {

// What a farm's job names: a built-in scene, or a scene file by content hash (its bytes are in
// Redis under keys::scene(hash), published by the API node that accepted the job).
struct SceneRef {
    std::string source;  // "builtin:NAME[?params]", or the file's path on the API node
    std::string hash;    // content_hash of the file; "" for built-ins
    std::string ext;     // the file's extension (".dae", ".gltf", ".glb"), which picks the loader
    std::string encode() const { return source + "\n" + hash + "\n" + ext; }
    static SceneRef decode(const std::string& s);
};

struct PreparedScene {
    RenderScene scene;
    double load_s = 0, build_s = 0;
    size_t bytes = 0;  // estimated memory
};

class SceneCache {
public:
    SceneCache(std::string dir, int64_t max_bytes, LoadLimits limits);
    // Throws SceneError (a broken file) or std::runtime_error (its bytes are gone from Redis).
    std::shared_ptr<const PreparedScene> get(Redis& redis, const SceneRef& ref, const RenderSceneOptions& options);
    // The job's scene as a file on this node (a built-in's name as is); throws std::runtime_error.
    std::string file_for(Redis& redis, const SceneRef& ref);
    uint64_t hits() const { return hits_; }
    uint64_t misses() const { return misses_; }

private:
    struct Entry {
        std::string key;
        std::shared_ptr<const PreparedScene> scene;
    };
    std::string dir_;
    int64_t max_bytes_;
    LoadLimits limits_;
    std::mutex mu_;
    std::list<Entry> lru_;  // most recent first
    uint64_t hits_ = 0, misses_ = 0;
};

}  // namespace tessera::server
