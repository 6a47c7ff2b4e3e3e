#pragma once
// Where a job's results live under a data directory: jobs/<id>/, one file per result under
// api::RunOutputs::in_directory's names. API nodes serve them, workers and render nodes write
// them (a farm shares the directory), a reference job's EXR is read back from them.
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

namespace tessera::server {

inline std::filesystem::path job_results_dir(const std::string& data_dir, const std::string& id) {
    return std::filesystem::path(data_dir) / "jobs" / id;
}
// The linear image a job left: a later job's reference.
inline std::filesystem::path job_image_exr(const std::string& data_dir, const std::string& id) {
    return job_results_dir(data_dir, id) / "image.exr";
}
// A job that ends without its results (canceled, failed) is never continued: its checkpoints
// (the render's, or a shot's frames') under `dir` go.
inline void remove_checkpoints(const std::filesystem::path& dir) {
    std::error_code ec;
    std::vector<std::filesystem::path> found;
    for (std::filesystem::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
        if (it->path().filename() == "checkpoint.tck" || it->path().filename() == "checkpoint.tck.part") found.push_back(it->path());
    for (const auto& p : found) std::filesystem::remove(p, ec);
}

}  // namespace tessera::server
