#include "server/scene_cache.h"

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

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

std::shared_ptr<const PreparedScene> SceneCache::get(Redis& redis, const SceneRef& ref, const RenderSceneOptions& options) {
    const std::string key = (ref.hash.empty() ? ref.source : ref.hash) + "|" + options_key(options);
    {
        std::lock_guard lock(mu_);
        for (auto it = lru_.begin(); it != lru_.end(); ++it)
            if (it->key == key) {
                lru_.splice(lru_.begin(), lru_, it);
                ++hits_;
                return it->scene;
            }
        ++misses_;
    }
    // Loaded outside the lock: two threads may both load a scene they both miss, and the
    // second copy is dropped; tiles of other scenes are not held up meanwhile.
    const std::string path = file_for(redis, ref);
    auto p = std::make_shared<PreparedScene>();
    const auto t0 = Clock::now();
    const SceneDescription desc = load_scene(path, limits_);
    const auto t1 = Clock::now();
    p->scene = build_render_scene(desc, options);
    p->load_s = std::chrono::duration<double>(t1 - t0).count();
    p->build_s = std::chrono::duration<double>(Clock::now() - t1).count();
    p->bytes = p->scene.triangle_accel_bytes() + p->scene.triangle_count() * 160 + p->scene.spheres.size() * 64 + 4096;
    std::lock_guard lock(mu_);
    for (const Entry& e : lru_)
        if (e.key == key) return e.scene;
    lru_.push_front({key, p});
    int64_t total = 0;
    for (const Entry& e : lru_) total += int64_t(e.scene->bytes);
    while (lru_.size() > 1 && total > max_bytes_) {
        total -= int64_t(lru_.back().scene->bytes);
        lru_.pop_back();
    }
    return p;
}

}  // namespace tessera::server
