#include "server/queue/scene_catalog.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include "api/scene_summary.h"
#include "engine/io/scene_loader.h"
#include "server/queue/queue_error.h"

namespace tessera::server {
namespace fs = std::filesystem;

namespace {

std::string lower_extension(const fs::path& p) {
    std::string e = p.extension().string();
    std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return e;
}

bool scene_extension(const fs::path& p) {
    const std::string e = lower_extension(p);
    return e == ".dae" || e == ".gltf" || e == ".glb";
}

// Lat-long environment maps (CS184 -e), named like scenes: their path without the extension.
bool environment_extension(const fs::path& p) {
    const std::string e = lower_extension(p);
    return e == ".exr" || e == ".hdr";
}

std::string random_hex(size_t n) {
    static thread_local std::mt19937_64 rng(std::random_device{}());
    static const char* hex = "0123456789abcdef";
    std::string s(n, '0');
    for (auto& c : s) c = hex[rng() & 15];
    return s;
}

}  // namespace

SceneCatalog::SceneCatalog(std::string project_dir, std::vector<std::string> dirs, std::string upload_dir)
    : project_dir_(std::move(project_dir)), dirs_(std::move(dirs)), upload_dir_(std::move(upload_dir)) {
    refresh();
}

void SceneCatalog::refresh() {
    std::lock_guard<std::mutex> lock(mutex_);
    scan_locked();
}

void SceneCatalog::scan_locked() {
    entries_.clear();
    environments_.clear();
    for (const char* b : {"builtin:cornell_box", "builtin:cornell_spheres", "builtin:furnace", "builtin:many_lights",
                          "builtin:displaced_sphere"})
        entries_[b] = {b, b, "builtin", b};
    auto add_dir = [&](const std::string& dir, const std::string& source, const std::string& prefix) {
        std::error_code ec;
        if (dir.empty() || !fs::is_directory(dir, ec)) return;
        for (auto it = fs::recursive_directory_iterator(dir, fs::directory_options::skip_permission_denied, ec);
             !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
            if (it.depth() > 8) { it.disable_recursion_pending(); continue; }
            if (!it->is_regular_file(ec)) continue;
            const bool scene = scene_extension(it->path()), environment = environment_extension(it->path());
            if (!scene && !environment) continue;
            // Where the entry sits in the folder, not where a link points: a link's target would
            // name a folder of the server's disk (fs::relative resolves links).
            const fs::path rel = it->path().lexically_relative(dir);
            if (rel.empty() || *rel.begin() == "..") continue;
            std::string name = prefix + (rel.parent_path() / rel.stem()).generic_string();
            (scene ? entries_ : environments_)
                .try_emplace(name, CatalogEntry{name, it->path().string(), source, prefix + rel.generic_string()});
        }
    };
    add_dir(project_dir_, "project", "");
    for (const auto& d : dirs_) add_dir(d, "directory", "");
    add_dir(upload_dir_, "upload", "upload/");
}

std::optional<CatalogEntry> SceneCatalog::find(const std::string& name) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = entries_.find(name);
    if (it == entries_.end()) {
        scan_locked();  // a file added since the last scan
        it = entries_.find(name);
        if (it == entries_.end()) return std::nullopt;
    }
    return it->second;
}

std::optional<CatalogEntry> SceneCatalog::find_environment(const std::string& name) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = environments_.find(name);
    if (it == environments_.end()) {
        scan_locked();
        it = environments_.find(name);
        if (it == environments_.end()) return std::nullopt;
    }
    return it->second;
}

std::vector<CatalogEntry> SceneCatalog::entries() {
    std::lock_guard<std::mutex> lock(mutex_);
    scan_locked();
    std::vector<CatalogEntry> out;
    for (const auto& [k, v] : entries_) out.push_back(v);
    return out;
}

namespace {

// One of the catalog's load slots, held while a scene loads.
struct LoadSlot {
    explicit LoadSlot(std::counting_semaphore<2>& s) : sem(s) { sem.acquire(); }
    ~LoadSlot() { sem.release(); }
    LoadSlot(const LoadSlot&) = delete;
    LoadSlot& operator=(const LoadSlot&) = delete;
    std::counting_semaphore<2>& sem;
};

}  // namespace

nlohmann::json SceneCatalog::describe(const CatalogEntry& e, const LoadLimits& limits) {
    long long mtime = 0;
    if (e.source != "builtin") {
        std::error_code ec;
        mtime = (long long)fs::last_write_time(e.path, ec).time_since_epoch().count();
    }
    {
        std::lock_guard<std::mutex> lock(mutex_);
        auto it = details_.find(e.path + '\n' + e.shown);
        if (it != details_.end() && it->second.first == mtime) return it->second.second;
    }
    nlohmann::json d;
    if (e.path == "builtin:displaced_sphere") {
        d = {{"triangles", 1002528}, {"spheres", 0}, {"lights", 1}, {"note", "?triangles=N sets the size"}};
    } else {
        LoadSlot slot(loads_);
        d = api::describe_scene(load_scene(e.path, limits, e.shown));
    }
    std::lock_guard<std::mutex> lock(mutex_);
    details_[e.path + '\n' + e.shown] = {mtime, d};
    return d;
}

CatalogEntry SceneCatalog::add_upload(const std::string& filename, const std::string& bytes, const LoadLimits& limits) {
    const fs::path p(filename);
    const bool clean = !filename.empty() && filename.size() <= 128 && p.filename().string() == filename &&
                       filename.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789._-") ==
                           std::string::npos &&
                       filename[0] != '.';
    if (!clean)
        throw QueueError(QueueErrorKind::invalid, "invalid-scene-name", "Invalid scene file name",
                      "the name must be a plain file name of letters, digits, '.', '_' and '-' (no path)")
            .with_field("name");
    if (!scene_extension(p))
        throw QueueError(QueueErrorKind::invalid, "invalid-scene-name", "Unsupported scene format", "the name must end in .gltf, .glb or .dae")
            .with_field("name");
    const std::string id = random_hex(16);
    const fs::path dir = fs::path(upload_dir_) / id;
    const fs::path file = dir / filename;
    const std::string shown = "upload/" + id + "/" + filename;
    {
        // A full disk refuses the upload (507) and leaves nothing half-written behind.
        std::error_code ec;
        fs::create_directories(dir, ec);
        int err = ec.value();
        std::ofstream out;
        if (!ec) {
            errno = 0;
            out.open(file, std::ios::binary);
            out.write(bytes.data(), std::streamsize(bytes.size()));
            out.close();
            err = errno;
        }
        if (ec || !out) {
            fs::remove_all(dir, ec);
            if (err == ENOSPC || err == EDQUOT)
                throw QueueError(QueueErrorKind::store_full, "insufficient-storage", "The upload could not be stored",
                              "no space left for the scene file; retry when space is freed")
                    .with_retry_after(30);
            throw QueueError(QueueErrorKind::unavailable, "storage-unavailable", "The upload could not be stored",
                          std::string("writing the scene file failed: ") + std::strerror(err ? err : EIO))
                .with_retry_after(10);
        }
    }
    nlohmann::json details;
    try {
        // Validation: a broken upload is refused, not stored. What it finds is what the
        // catalog says of the scene, so the file is not loaded a second time for that.
        LoadSlot slot(loads_);
        details = api::describe_scene(load_scene(file.string(), limits, shown));
    } catch (const SceneError& e) {
        std::error_code ec;
        fs::remove_all(dir, ec);
        throw QueueError(QueueErrorKind::broken_file, "invalid-scene", "The scene file is broken", e.detail()).with_location(
            filename + (e.where().line ? ":" + std::to_string(e.where().line) : "") +
            (e.where().pointer.empty() ? "" : "#" + e.where().pointer));
    }
    const std::string name = "upload/" + id + "/" + p.stem().string();
    std::lock_guard<std::mutex> lock(mutex_);
    scan_locked();
    CatalogEntry entry{name, file.string(), "upload", shown};
    entries_[name] = entry;
    std::error_code ec;
    details_[entry.path + '\n' + entry.shown] = {(long long)fs::last_write_time(entry.path, ec).time_since_epoch().count(), std::move(details)};
    return entry;
}

}  // namespace tessera::server
