#include "server/queue/scene_cache.h"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

#include "server/store/cluster_keys.h"

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

SceneCache::SceneCache(std::string dir, int64_t max_bytes, LoadLimits limits, double idle_s)
    : dir_(std::move(dir)), max_bytes_(max_bytes),
      idle_(std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(idle_s))),
      limits_(limits) {}

void SceneCache::drop_idle() {
    std::lock_guard lock(mu_);
    drop_idle_locked();
}

void SceneCache::drop_idle_locked() {
    const auto now = std::chrono::steady_clock::now();
    // A scene a running job still holds stays: dropped, the next job on it would prepare a
    // second copy beside the first.
    lru_.remove_if([&](const Entry& e) { return now - e.used > idle_ && e.scene.use_count() == 1; });
}

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

std::string SceneCache::as_published(std::string text, const std::vector<SceneRef>& refs) const {
    const std::string folder = (fs::path(dir_) / "").string();
    for (size_t at = text.find(folder); at != std::string::npos; at = text.find(folder, at)) {
        size_t end = at + folder.size();
        while (end < text.size() && (std::isalnum(static_cast<unsigned char>(text[end])) || text[end] == '-' || text[end] == '.' || text[end] == '_'))
            ++end;
        const std::string name = text.substr(at + folder.size(), end - at - folder.size());
        // Another copy (a part file): its name alone.
        std::string shown = name.empty() ? "the node's scene folder" : name;
        for (const SceneRef& ref : refs)
            if (!ref.hash.empty() && ref.hash + ref.ext == name) shown = ref.shown();
        text.replace(at, end - at, shown);
        at += shown.size();
    }
    return text;
}

std::shared_ptr<const PreparedScene> SceneCache::find(const std::string& key) {
    std::lock_guard lock(mu_);
    drop_idle_locked();
    for (auto it = lru_.begin(); it != lru_.end(); ++it)
        if (it->key == key) {
            lru_.splice(lru_.begin(), lru_, it);
            it->used = std::chrono::steady_clock::now();
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
    lru_.push_front({key, scene, std::chrono::steady_clock::now()});
    int64_t total = 0;
    for (const Entry& e : lru_) total += int64_t(e.scene->bytes);
    // The budget holds for every entry, the newest too: a scene larger than the whole budget is
    // rendered by the jobs that hold it and then freed, not kept.
    while (!lru_.empty() && total > max_bytes_) {
        total -= int64_t(lru_.back().scene->bytes);
        lru_.pop_back();
    }
    return scene;
}

std::shared_ptr<const PreparedScene> SceneCache::get(Redis& redis, const SceneRef& ref, const RenderSceneOptions& options) {
    // The name is in the key: two jobs' files of the same bytes, named apart, report each its own.
    const std::string key = (ref.hash.empty() ? ref.source : ref.hash) + "|" + ref.shown() + "|" + options_key(options);
    if (auto hit = find(key)) return hit;
    // Prepared outside the lock: jobs on other scenes are not held up meanwhile.
    return keep(key, api::prepare_scene(file_for(redis, ref), limits_, options, ref.shown()));
}

namespace {

// A file as it is now: device, inode, size, and modification and change times (ctime cannot
// be set back by tools that restore mtime, cp -p or rsync -t). "" when it cannot be read.
std::string file_identity(const std::string& path) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) return {};
    return std::to_string(st.st_dev) + ":" + std::to_string(st.st_ino) + ":" + std::to_string(st.st_size) + ":" +
           std::to_string(st.st_mtim.tv_sec) + "." + std::to_string(st.st_mtim.tv_nsec) + ":" +
           std::to_string(st.st_ctim.tv_sec) + "." + std::to_string(st.st_ctim.tv_nsec);
}

// What a scene file's preparation reads: the file, and the files besides it that its last
// preparation read (a glTF's external buffers and textures, wherever in its folder). "" when
// the file cannot be read: nothing is kept then.
std::string scene_identity(const std::string& source, const std::vector<std::string>& read_beside) {
    std::string id = file_identity(source);
    if (id.empty()) return {};
    std::error_code ec;
    id = fs::weakly_canonical(source, ec).string() + "#" + id;
    for (const std::string& f : read_beside) id += "|" + f + "#" + file_identity(f);
    return id;
}

}  // namespace

std::vector<std::string> SceneCache::read_beside(const std::string& source) {
    std::lock_guard lock(mu_);
    const auto it = read_beside_.find(source);
    return it == read_beside_.end() ? std::vector<std::string>{} : it->second;
}

std::pair<std::shared_ptr<const PreparedScene>, bool> SceneCache::get_local(const std::string& source, const std::string& name,
                                                                            const RenderSceneOptions& options) {
    if (source.rfind("builtin:", 0) == 0) {
        const std::string key = source + "|" + options_key(options);
        if (auto hit = find(key)) return {hit, true};
        return {keep(key, api::prepare_scene(source, limits_, options, name)), false};
    }
    // A file edited or replaced (an upload under the same name, a folder synced anew) is
    // another key; one that changed while it was being prepared is rendered but not kept. A
    // file in two of the catalog's folders is two names, each reported as its own.
    // An edited texture or buffer is another key too: the files the file's last preparation
    // read are part of it, their identities taken before this one reads them.
    const std::vector<std::string> beside = read_beside(source);
    const std::string before = scene_identity(source, beside);
    const std::string key = before + "|" + name + "|" + options_key(options);
    if (!before.empty())
        if (auto hit = find(key)) return {hit, true};
    auto prepared = api::prepare_scene(source, limits_, options, name);
    if (before.empty() || scene_identity(source, beside) != before) return {prepared, false};
    if (prepared->files_read == beside) return {keep(key, prepared), false};
    // It read other files than the last time (the first time, or an edit naming others), whose
    // identities before it read them are not known: rendered, not kept. The next job's key
    // names them, taken before its preparation, and that one is kept: an edit while a file is
    // read is never cached.
    std::lock_guard lock(mu_);
    if (read_beside_.size() > 4096) read_beside_.clear();  // a bound: files come and go in a long-lived server
    read_beside_[source] = prepared->files_read;
    return {prepared, false};
}

}  // namespace tessera::server
