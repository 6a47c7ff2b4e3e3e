#pragma once
// Prepared scenes, loaded and built once, then reused by every job (and a render node's every
// tile) that names the same scene bytes with the same build options: a render node's, and the
// one-process server's. Least recently used scenes go first when the estimated memory passes
// the bound (a scene in use stays alive until its jobs finish: entries are shared pointers).
#include <atomic>
#include <chrono>
#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "api/job_runner.h"
#include "engine/io/scene_loader.h"
#include "engine/scene/render_scene.h"
#include "server/store/redis_client.h"
#include "server/store/scene_ref.h"

namespace tessera::server {

using api::PreparedScene;

class SceneCache {
public:
    // Entries unused for `idle_s` seconds are dropped (at the next use of the cache, or by
    // drop_idle()): an idle server gives a large scene's memory back.
    SceneCache(std::string dir, int64_t max_bytes, LoadLimits limits, double idle_s = 30);
    // Throws SceneError (a broken file) or std::runtime_error (its bytes are gone from Redis).
    std::shared_ptr<const PreparedScene> get(Redis& redis, const SceneRef& ref, const RenderSceneOptions& options);
    // The job's scene as a file on this node (a built-in's name as is); throws std::runtime_error.
    std::string file_for(Redis& redis, const SceneRef& ref);
    // `text` (a job's error) with this node's copies of the job's files (`refs`: its scene, its
    // environment map) named as the job's files are named (SceneRef::shown). Another copy in the
    // folder is named by its file name alone. A node's own folders are not its clients' business.
    std::string as_published(std::string text, const std::vector<SceneRef>& refs) const;
    // A scene this process reads itself: a file path (keyed by its identity, so an edited or
    // replaced file is a new scene) or builtin:NAME[?params], called `name` in what it reports.
    // Throws SceneError. The second value says whether it was prepared before.
    std::pair<std::shared_ptr<const PreparedScene>, bool> get_local(const std::string& source, const std::string& name,
                                                                    const RenderSceneOptions& options);
    void drop_idle();
    uint64_t hits() const { return hits_; }
    uint64_t misses() const { return misses_; }

private:
    std::shared_ptr<const PreparedScene> find(const std::string& key);
    std::vector<std::string> read_beside(const std::string& source);
    std::shared_ptr<const PreparedScene> keep(const std::string& key, std::shared_ptr<const PreparedScene> scene);
    void drop_idle_locked();
    struct Entry {
        std::string key;
        std::shared_ptr<const PreparedScene> scene;
        std::chrono::steady_clock::time_point used;
    };
    // Per scene file, the other files its last preparation read (get_local's keys name them).
    std::map<std::string, std::vector<std::string>> read_beside_;
    std::string dir_;
    int64_t max_bytes_;
    std::chrono::steady_clock::duration idle_;
    LoadLimits limits_;
    std::mutex mu_;
    std::list<Entry> lru_;  // most recent first
    std::atomic<uint64_t> hits_{0}, misses_{0};  // read by /metrics without the lock
};

}  // namespace tessera::server
