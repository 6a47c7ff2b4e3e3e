#pragma once
// The job contract: a job is one typed value, a render or an equal-time comparison. Every
// field is declared once, in the tables of job_fields.cpp (name, type, default, bounds, help,
// command-line names); parsing, serialization, the CLI's flags and the check against
// api/openapi.yaml all read those tables.
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/render/render_settings.h"
#include "engine/scene/render_scene.h"

namespace tessera::api {

// Bad input: `pointer` names the offending field ("/spp", "/adaptive/batch"; "" for the body).
class InvalidJob : public std::runtime_error {
public:
    // Both cut to a few hundred bytes: they quote what the client sent (a 1 MB unknown key made
    // a 3 MB answer).
    InvalidJob(std::string pointer, const std::string& what);
    const std::string& pointer() const { return pointer_; }

private:
    std::string pointer_;
};

// Limits against absurd or abusive jobs (configurable by the server), checked at submission
// only: a stored job is never re-checked against limits that changed since.
struct JobLimits {
    int64_t max_pixels = 16384ll * 16384;
    int max_dimension = 16384;
    int max_spp = 1 << 16;
    int max_depth = 1000;
    int max_light_rays = 1024;
    double max_time_limit_s = 7 * 24 * 3600.0;
    int max_frames = 100'000;          // frames in one shot
    // The checks between fields that came after jobs were stored (denoise needs spp 2, frame
    // times within kMaxShotSeconds): at submission only, so a job stored before them still
    // reads back (its status, its frames, a job after it).
    bool submission = true;
    // No limits: how a stored job, already checked when it was accepted, is read back.
    static JobLimits none();
};

// The frames of the scene's animation a shot renders: a range (start to end, every step-th) or
// a list. Frame n shows the scene at time n / fps seconds, as Blender's exporter times keys.
struct FrameSet {
    int start = 1, end = 1, step = 1;  // used when `list` is empty
    std::vector<int> list;
    std::vector<int> frames() const;
    size_t count() const;
    bool contains(int frame) const;  // without listing a range's frames
};

// How far from the animation's start a shot's frame (n / fps, with its shutter) may be: about
// 32 years, a time every animation and its float keys can be asked about.
inline constexpr double kMaxShotSeconds = 1e9;

// The seed frame `frame` renders with: the job's seed mixed with the frame number, so that a
// frame's noise is not the next frame's and a frame renders the same wherever it is rendered.
uint64_t frame_seed(uint64_t seed, int frame);

// One image, or a shot: the scene, how to render it, and its place in the queue.
// Where a job's status is POSTed when it ends (and after each frame of a shot, with `frames`),
// signed by the server (server/queue/notifier.h).
struct NotifySpec {
    std::string url;      // http[s]://host[:port]/path
    bool frames = false;  // a shot's frames too
    bool operator==(const NotifySpec&) const = default;
};

// How a farm places a job's tasks and counts their failures (server/farm/render_node.cpp).
struct TaskPolicy {
    int max_retries = 3;      // a failed task is tried again up to this many times, on another node where there is one
    int blocklist_after = 3;  // a node that fails this many of the job's tasks takes no more of them
    std::vector<std::string> required_tags;  // node tags (tessera worker --tags) a node needs to take them; sorted, distinct
    bool operator==(const TaskPolicy&) const = default;
};
// The most tags a job may require, and a tag's form: [a-z0-9][a-z0-9_.-]{0,31}.
inline constexpr size_t kMaxRequires = 16;
bool valid_node_tag(const std::string& tag);

struct RenderJob {
    std::string scene;
    RenderSettings render;             // engine settings; `threads` is the runner's, not the job's
    RenderSceneOptions scene_options;  // BVH and triangle test
    int priority = 0;
    std::string reference;             // a finished job whose image the error is measured against
    // An environment map (lat-long EXR or HDR) lighting the scene from infinity: a file path
    // (CLI) or a name from the server's catalog folders; empty: none.
    std::string environment;
    // A shot: the frames to render (absent: a still of the scene at rest), at `fps` frames a
    // second, playing `animation` (a name or an index; empty: every animation at once).
    std::optional<FrameSet> frames;
    double fps = 24;
    std::string animation;
    bool animation_index = false;  // given as a number: an index, never a name (a name may be "1")
    int chunk = 0;  // frames per task on a farm; 0: chosen from the measured open and frame times
    // A shot's motion blur: the shutter's opening and closing in frames around each frame
    // (e.g. -0.25 and 0.25); absent: none (each frame an instant).
    std::optional<std::pair<double, double>> shutter;
    // Jobs this one runs after: it waits until every one has succeeded (JobState::waiting).
    std::vector<std::string> after;
    std::optional<NotifySpec> notify;
    TaskPolicy tasks;
    // A shot's frame as the engine renders it: the job with that frame's seed.
    RenderSettings frame_settings(int frame) const;
};

// One configuration of a comparison: a label and the render fields it sets (the rest are the
// comparison's or the defaults).
struct ComparisonConfigJob {
    std::string label;
    RenderJob job;
    nlohmann::json given;  // the fields as given, label included (what to_json shows)
};

// Sampling configurations compared at equal time against a converged reference.
struct ComparisonJob {
    std::string scene;
    int width = 0, height = 0, max_depth = 0;
    double seconds = 0;
    int reps = 0, reference_spp = 0;
    double target_error = 0;
    int priority = 0;
    bool standard_configs = true;  // "configs": "standard"
    std::vector<ComparisonConfigJob> configs;
    std::vector<std::string> after;  // as a render job's
    std::optional<NotifySpec> notify;
    TaskPolicy tasks;
};

using Job = std::variant<RenderJob, ComparisonJob>;

// A shot's `animation` as to_json writes it: null, a name, or an index (a number).
nlohmann::json animation_json(const RenderJob& job);

// A render job with every field at its declared default (scene empty).
RenderJob default_render_job();

// POST /v1/jobs and the CLI's job: throws InvalidJob. Only "scene" is required; unknown fields
// are errors.
RenderJob parse_render_job(const nlohmann::json& body, const JobLimits& limits = {});
// POST /v1/comparisons: throws InvalidJob.
ComparisonJob parse_comparison_job(const nlohmann::json& body, const JobLimits& limits = {});

// The effective job, every field present (GET /v1/jobs/{id} "settings", report.json). A
// comparison carries "kind": "comparison".
nlohmann::json to_json(const RenderJob& job);
nlohmann::json to_json(const ComparisonJob& job);
nlohmann::json to_json(const Job& job);
// A stored job (to_json's output) read back, without limits; throws InvalidJob.
Job job_from_json(const nlohmann::json& stored);

const std::string& scene_of(const Job& job);
int priority_of(const Job& job);
const std::vector<std::string>& after_of(const Job& job);
const std::optional<NotifySpec>& notify_of(const Job& job);
const TaskPolicy& task_policy_of(const Job& job);
// The most jobs one job may run after.
inline constexpr size_t kMaxAfter = 64;

}  // namespace tessera::api
