#pragma once
// The scenes a job may name: our `scenes/` folder, folders given with --scenes, uploads, and
// the built-in procedural scenes. A job's `scene` is looked up here by name and never used as
// a path, so no name can reach a file outside the catalog.
#include <map>
#include <mutex>
#include <semaphore>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/scene/scene_description.h"

namespace tessera::server {

struct CatalogEntry {
    std::string name;    // what a job names: "cornell_box", "sky/CBbunny", "upload/<id>", "builtin:furnace"
    std::string path;    // file path, or the built-in name
    std::string source;  // "project", "directory", "upload", "builtin"
    // What the server calls the file in what a client reads (errors, logs, reports): its place
    // in the catalog ("sky/CBbunny.dae", "upload/<id>/box.gltf"), never its folders on the
    // server's disk. Given to the loaders, so the text is right where it is made: cutting the
    // folders out of finished text would also cut them out of a client's own words (a name
    // inside an uploaded file), telling the client which folders are the server's.
    std::string shown;
};

class SceneCatalog {
public:
    SceneCatalog(std::string project_dir, std::vector<std::string> dirs, std::string upload_dir);
    // Rescans the folders (uploads included).
    void refresh();
    std::optional<CatalogEntry> find(const std::string& name);
    // An environment map (.exr, .hdr) in the same folders, named like a scene.
    std::optional<CatalogEntry> find_environment(const std::string& name);
    std::vector<CatalogEntry> entries();
    // Counts and bounds of a scene, loading it once (cached by path and modification time).
    // Throws SceneError for a broken file.
    nlohmann::json describe(const CatalogEntry& e, const LoadLimits& limits);
    // Stores an uploaded scene after validating its name and content; returns its entry.
    // Throws QueueError (invalid name, broken file, store full or unavailable).
    CatalogEntry add_upload(const std::string& filename, const std::string& bytes, const LoadLimits& limits);

private:
    void scan_locked();
    std::string project_dir_;
    std::vector<std::string> dirs_;
    std::string upload_dir_;
    std::mutex mutex_;
    std::map<std::string, CatalogEntry> entries_;
    std::map<std::string, CatalogEntry> environments_;
    // path + '\n' + shown → (mtime, details): a file under two names is described under each,
    // its warnings naming it as each name's entry does.
    std::map<std::string, std::pair<long long, nlohmann::json>> details_;
    // Scenes loaded at once to check or describe them (uploads, the catalog): each may take its
    // whole load budget (texels, triangles), so a burst of uploads costs two budgets, not one
    // for each upload in flight.
    static constexpr std::ptrdiff_t kConcurrentLoads = 2;
    std::counting_semaphore<kConcurrentLoads> loads_{kConcurrentLoads};
};

}  // namespace tessera::server
