#include "server/scene_cache.h"

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <sys/stat.h>
#include <unistd.h>

#include "server/cluster_keys.h"
#include "server/film_codec.h"

namespace tessera::server {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

std::string options_key(const RenderSceneOptions& o) {
    std::ostringstream s;
    s << int(o.bvh.type) << ',' << o.bvh.max_leaf_size << ',' << o.bvh.sah_bins << ',' << int(o.triangle_test) << ','
      << o.bvh.traversal_cost << ',' << o.bvh.intersection_cost << ',' << o.bvh.leaf_block << ',' << o.min_prims_for_bvh << ','
      << int(o.embree_quality);
    return s.str();
}

std::string read_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return {};
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

}  // namespace

SceneRef SceneRef::decode(const std::string& s) {
    SceneRef r;
    std::istringstream in(s);
    std::getline(in, r.source);
    std::getline(in, r.hash);
    std::getline(in, r.ext);
    return r;
}

SceneCache::SceneCache(std::string dir, int64_t max_bytes, LoadLimits limits)
    : dir_(std::move(dir)), max_bytes_(max_bytes), limits_(limits) {}

std::string SceneCache::file_for(Redis& redis, const SceneRef& ref) {
    if (ref.hash.empty()) return ref.source;  // built-in
    const fs::path cached = fs::path(dir_) / (ref.hash + ref.ext);
    if (fs::exists(cached)) return cached.string();
    // The same file on this node's disk (a shared volume, the same image's catalog) when its
    // bytes are the job's; otherwise the bytes the API node published.
    std::string bytes = read_file(ref.source);
    if (bytes.empty() || content_hash(bytes) != ref.hash) {
        const RedisValue v = redis.command({"GET", keys::scene(ref.hash)});
        if (v.is_nil()) throw std::runtime_error("scene " + ref.hash + " is neither on this node nor in Redis");
        bytes = v.text;
        if (content_hash(bytes) != ref.hash) throw std::runtime_error("scene " + ref.hash + " in Redis does not match its hash");
    }
    fs::create_directories(dir_);
    // A name of this thread's own: threads of a node miss the cache together at a job's start.
    static std::atomic<uint64_t> writes{0};
    const fs::path part = cached.string() + ".part" + std::to_string(::getpid()) + "-" + std::to_string(++writes);
    {
        std::ofstream out(part, std::ios::binary | std::ios::trunc);
        out.write(bytes.data(), std::streamsize(bytes.size()));
        if (!out) throw std::runtime_error("cannot write " + part.string());
    }
    fs::rename(part, cached);  // atomic: another thread reads whole files only
    return cached.string();
}

std::shared_ptr<const PreparedScene> SceneCache::find(const std::string& key) {
    std::lock_guard lock(mu_);
    for (auto it = lru_.begin(); it != lru_.end(); ++it)
        if (it->key == key) {
            lru_.splice(lru_.begin(), lru_, it);
            ++hits_;
            return it->scene;
        }
    ++misses_;
    return nullptr;
}

// Two threads may both have prepared a scene they both missed: the first kept wins.
std::shared_ptr<const PreparedScene> SceneCache::keep(const std::string& key, std::shared_ptr<const PreparedScene> scene) {
    std::lock_guard lock(mu_);
    for (const Entry& e : lru_)
        if (e.key == key) return e.scene;
    lru_.push_front({key, scene});
    int64_t total = 0;
    for (const Entry& e : lru_) total += int64_t(e.scene->bytes);
    while (lru_.size() > 1 && total > max_bytes_) {
        total -= int64_t(lru_.back().scene->bytes);
        lru_.pop_back();
    }
    return scene;
}

std::shared_ptr<const PreparedScene> SceneCache::get(Redis& redis, const SceneRef& ref, const RenderSceneOptions& options) {
    const std::string key = (ref.hash.empty() ? ref.source : ref.hash) + "|" + options_key(options);
    if (auto hit = find(key)) return hit;
    // Prepared outside the lock: jobs on other scenes are not held up meanwhile.
    return keep(key, api::prepare_scene(file_for(redis, ref), limits_, options));
}

std::pair<std::shared_ptr<const PreparedScene>, bool> SceneCache::get_local(const std::string& source, const RenderSceneOptions& options) {
    std::string identity = source;
    if (source.rfind("builtin:", 0) != 0) {
        // The file as it is now: its path, inode, size and modification time. A file edited
        // or replaced (an upload under the same name, a scene folder synced anew) is another key.
        struct stat st {};
        if (::stat(source.c_str(), &st) == 0)
            identity = fs::weakly_canonical(source).string() + "#" + std::to_string(st.st_ino) + ":" + std::to_string(st.st_size) + ":" +
                       std::to_string(st.st_mtim.tv_sec) + "." + std::to_string(st.st_mtim.tv_nsec);
    }
    const std::string key = identity + "|" + options_key(options);
    if (auto hit = find(key)) return {hit, true};
    return {keep(key, api::prepare_scene(source, limits_, options)), false};
}

}  // namespace tessera::server
