#pragma once
// What a finished render job reports, as a typed value (the runner fills it, the CLI prints it)
// and as JSON (report.json, and the timings and statistics of GET /v1/jobs/{id}).
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "api/job.h"
#include "engine/render/renderer.h"

namespace tessera::api {

struct JobTimings {
    double load_s = 0, bvh_s = 0, render_s = 0, write_s = 0, total_s = 0;
};

// A render node's part in a job rendered by a farm: the tiles it committed and its seconds in them.
struct NodeShare {
    std::string node;
    size_t tiles = 0;
    double seconds = 0;
};

// How a job got its scene: from a server's cache of prepared scenes (a hit: prepared before,
// by this job's scene bytes and build options) or prepared for it; what preparing it cost.
struct SceneCacheUse {
    bool used = false;  // the runner keeps prepared scenes
    bool hit = false;
    double load_s = 0, build_s = 0;  // when it was prepared
};

struct RenderReport {
    RenderJob job;
    JobTimings timings;
    RenderStats stats;
    // The scene as built for this job.
    size_t triangles = 0, spheres = 0;
    BvhBuildStats bvh;
    size_t accel_bytes = 0;
    BuildReport scene_build;
    // What the render built and left out (film buffers, bounces, light paths).
    std::vector<std::string> render_built, render_left_out;
    bool denoised = false;  // a denoised image was made (a denoising render that had two samples a pixel)
    ConvergenceCurve curve;
    double spp_min = 0, spp_max = 0;
    double mean_radiance = 0;  // of the linear image, over pixels and channels
    size_t tiles_done = 0, tiles_total = 0;
    std::vector<NodeShare> nodes;  // a farm's render nodes; empty for one process
    SceneCacheUse scene_cache;
    // Continued from a checkpoint (a restart, a pause): the samples and render time it kept.
    uint64_t recovered_samples = 0;
    double recovered_render_s = 0;
};

// report.json: settings, timings, statistics, scene, convergence, render, progress.
nlohmann::json to_json(const RenderReport& r);
// A point of the report's convergence curve: unmeasured errors are null (or absent). A render
// farm keeps its curve in Redis in the same form.
nlohmann::json to_json(const ConvergencePoint& p);
ConvergencePoint convergence_point_from_json(const nlohmann::json& j);
// The part of a report that a job's status shows ("timings", "stats", "progress"); what the
// job store keeps, so a status poll never reads the whole report.
nlohmann::json status_summary(const RenderReport& r);

}  // namespace tessera::api
