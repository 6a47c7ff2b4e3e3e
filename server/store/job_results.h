#pragma once
// Where a job's results live under a data directory: jobs/<id>/, one file per result under
// api::RunOutputs::in_directory's names. API nodes serve them, workers and render nodes write
// them (a farm shares the directory), a reference job's EXR is read back from them.
#include <filesystem>
#include <string>

namespace tessera::server {

inline std::filesystem::path job_results_dir(const std::string& data_dir, const std::string& id) {
    return std::filesystem::path(data_dir) / "jobs" / id;
}
// The linear image a job left: a later job's reference.
inline std::filesystem::path job_image_exr(const std::string& data_dir, const std::string& id) {
    return job_results_dir(data_dir, id) / "image.exr";
}

}  // namespace tessera::server
