#pragma once
// A job's state and status as GET /v1/jobs/{id} answers it: the typed record the server fills
// from its store and queue, and its JSON.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include <array>

#include "api/job.h"

namespace tessera::api {

// paused: stopped by its owner, its film kept; resumed, it is queued again and continues.
// waiting: for the jobs it runs after (`after`) to succeed.
enum class JobState { queued, running, succeeded, failed, canceled, paused, waiting };
inline constexpr std::array<JobState, 7> kJobStates{JobState::queued,   JobState::waiting, JobState::running, JobState::paused,
                                                   JobState::succeeded, JobState::failed,  JobState::canceled};

const char* to_string(JobState s);
bool parse_job_state(const std::string& s, JobState& out);
inline bool is_final(JobState s) { return s == JobState::succeeded || s == JobState::failed || s == JobState::canceled; }

struct JobProgress {
    double fraction = 0;
    uint64_t tiles_done = 0, tiles_total = 0, samples_done = 0;
};
// A running job's progress, one rule wherever it is shown (a worker's own job, a farm's from
// Redis): the samples taken over the job's budget of spp × pixels (× frames for a shot; a
// comparison has none: 0), with the tiles done of its current pass.
JobProgress job_progress(const Job& job, uint64_t samples, uint64_t tiles_done, uint64_t tiles_total);

// A running render's latest finished pass (its image is served until the job ends).
struct PassSummary {
    int index = 0;              // 0 for the first pass
    int spp = 0;                // the pass's per-pixel sample target
    double spp_mean = 0, seconds = 0;
    double est_rel_mse = -1, rel_mse = -1;  // negative: not measured
    double denoised_est_rel_mse = -1;      // a denoising job's denoised image's estimate
};
nlohmann::json to_json(const PassSummary& p);

// A shot's frames: how many are done, the one rendering, and an estimate of the time left from
// the frames measured so far.
struct ShotProgress {
    std::vector<int> frames;       // every frame, in rendering order
    size_t frames_done = 0;        // the first frames_done of `frames` are written (unless `written`)
    bool running = false;          // frames[frames_done] is rendering (unless `written`)
    double frames_seconds = 0;     // the frames done, together
    // Written frames one by one, where they finish out of order (a farm's chunks); empty: the
    // first frames_done. Which frame renders next is then not known here.
    std::vector<char> written;
};
// Frames listed one by one in a status up to this many (a longer shot gives counts only).
constexpr size_t kStatusFrameList = 2000;
nlohmann::json to_json(const ShotProgress& p);

// A farm job's failed tasks: failures counted, the nodes that take no more of its tasks, and the
// latest reasons (node: task: error).
struct TaskFailures {
    long long failures = 0;
    std::vector<std::string> blocklisted;
    std::vector<std::string> latest;  // oldest first
};
nlohmann::json to_json(const TaskFailures& f);

struct JobStatus {
    std::string id;
    JobState state = JobState::queued;
    nlohmann::json settings;   // the stored job (to_json of the typed job)
    int priority = 0;
    double created_at = 0, started_at = 0, finished_at = 0;  // unix seconds; 0: not yet
    int attempts = 0;
    std::string error;
    std::optional<size_t> queue_position;
    std::optional<JobProgress> live_progress;  // a running job's, from its renderer
    std::optional<PassSummary> latest_pass;    // a running job's, once a pass has finished
    std::optional<ShotProgress> shot;          // a shot's frames (a finished one's come from its summary)
    std::optional<TaskFailures> task_failures;  // a farm job some of whose tasks failed
    std::string unplaceable;   // a queued or running farm job no live node can take: why ("" when one can)
    nlohmann::json summary;    // the finished job's status_summary (timings, stats, progress), or null
};

nlohmann::json to_json(const JobStatus& s);

}  // namespace tessera::api
