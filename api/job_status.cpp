#include "api/job_status.h"

#include <algorithm>

#include "api/result_files.h"

namespace tessera::api {

JobProgress job_progress(const Job& job, uint64_t samples, uint64_t tiles_done, uint64_t tiles_total) {
    const auto* r = std::get_if<RenderJob>(&job);
    // A shot's budget is every frame's.
    const double frames = r && r->frames ? double(r->frames->count()) : 1.0;
    const double budget = r ? double(r->render.spp) * r->render.width * r->render.height * frames : 0.0;
    return {budget > 0 ? std::min(1.0, double(samples) / budget) : 0.0, tiles_done, tiles_total, samples};
}

using nlohmann::json;

const char* to_string(JobState s) {
    switch (s) {
    case JobState::queued: return "queued";
    case JobState::running: return "running";
    case JobState::succeeded: return "succeeded";
    case JobState::failed: return "failed";
    case JobState::canceled: return "canceled";
    case JobState::paused: return "paused";
    case JobState::waiting: return "waiting";
    }
    return "unknown";
}

bool parse_job_state(const std::string& s, JobState& out) {
    for (JobState st : kJobStates) {
        if (s == to_string(st)) {
            out = st;
            return true;
        }
    }
    return false;
}

namespace {

json or_null(double v) { return v > 0 ? json(v) : json(nullptr); }

json progress_json(const JobProgress& p) {
    return {{"fraction", p.fraction}, {"tiles_done", p.tiles_done}, {"tiles_total", p.tiles_total},
            {"samples_done", p.samples_done}};
}

json measured(double v) { return v >= 0 ? json(v) : json(nullptr); }

}  // namespace

json to_json(const PassSummary& p) {
    return {{"index", p.index}, {"spp", p.spp}, {"spp_mean", p.spp_mean}, {"seconds", p.seconds},
            {"est_rel_mse", measured(p.est_rel_mse)}, {"rel_mse", measured(p.rel_mse)},
            {"denoised_est_rel_mse", measured(p.denoised_est_rel_mse)}};
}

json to_json(const ShotProgress& p) {
    const size_t total = p.frames.size();
    // Timed from this process's frames only (a farm's node times its own): untimed is null.
    const bool timed = p.frames_done && p.frames_seconds > 0;
    const double mean = timed ? p.frames_seconds / double(p.frames_done) : 0.0;
    const bool by_mask = !p.written.empty();
    json j = {{"frames_total", total}, {"frames_done", p.frames_done},
              {"current_frame", !by_mask && p.running && p.frames_done < total ? json(p.frames[p.frames_done]) : json(nullptr)},
              {"mean_frame_s", timed ? json(mean) : json(nullptr)},
              {"eta_s", timed ? json(mean * double(total - p.frames_done)) : json(nullptr)}};
    if (total <= kStatusFrameList) {
        json list = json::array();
        for (size_t i = 0; i < total; ++i) {
            const bool done = by_mask ? i < p.written.size() && p.written[i] : i < p.frames_done;
            list.push_back({{"frame", p.frames[i]},
                            {"state", done ? "succeeded" : !by_mask && i == p.frames_done && p.running ? "running" : "queued"}});
        }
        j["frames"] = list;
    }
    return j;
}

json to_json(const TaskFailures& f) { return {{"failures", f.failures}, {"blocklisted", f.blocklisted}, {"latest", f.latest}}; }

json to_json(const JobStatus& s) {
    json j;
    j["id"] = s.id;
    j["state"] = to_string(s.state);
    j["settings"] = s.settings;
    j["priority"] = s.priority;
    j["created_at"] = or_null(s.created_at);
    j["started_at"] = or_null(s.started_at);
    j["finished_at"] = or_null(s.finished_at);
    j["attempts"] = s.attempts;
    j["error"] = s.error.empty() ? json(nullptr) : json(s.error);
    j["queue_position"] = s.queue_position ? json(*s.queue_position) : json(nullptr);
    JobProgress progress;
    progress.fraction = s.state == JobState::succeeded ? 1.0 : 0.0;
    j["progress"] = progress_json(s.live_progress ? *s.live_progress : progress);
    j["latest_pass"] = s.latest_pass ? to_json(*s.latest_pass) : json(nullptr);
    const bool has_summary = s.summary.is_object();
    if (s.state == JobState::succeeded && has_summary && s.summary.contains("progress")) j["progress"] = s.summary["progress"];
    json timings = {{"queued_s", nullptr}, {"load_s", nullptr}, {"bvh_s", nullptr}, {"render_s", nullptr},
                    {"write_s", nullptr}, {"total_s", nullptr}};
    if (s.started_at > 0) timings["queued_s"] = s.started_at - s.created_at;
    if (has_summary && s.summary.contains("timings"))
        for (const auto& [k, v] : s.summary["timings"].items()) timings[k] = v;
    j["timings"] = timings;
    j["stats"] = has_summary && s.summary.contains("stats") ? s.summary["stats"] : json(nullptr);
    // A farm's render: each node's share of the tiles; null for one process.
    j["nodes"] = has_summary && s.summary.contains("nodes") ? s.summary["nodes"] : json(nullptr);
    // Continued from a checkpoint: what it kept; null for a job rendered in one go.
    j["recovered"] = has_summary && s.summary.contains("recovered") ? s.summary["recovered"] : json(nullptr);
    // A farm's: tasks that failed and where, and why no node can take the job now.
    j["task_failures"] = s.task_failures ? to_json(*s.task_failures) : json(nullptr);
    j["unplaceable"] = s.unplaceable.empty() ? json(nullptr) : json(s.unplaceable);
    // The links are to what the job will have (api/result_files.h, the rule the server serves by).
    const std::string self = "/v1/jobs/" + s.id;
    const ResultFiles results = ResultFiles::of(s.settings, has_summary ? s.summary : json(nullptr));
    j["links"] = {{"self", self}};
    // A failed or canceled job keeps no results: its status links to itself alone.
    if (s.state != JobState::failed && s.state != JobState::canceled)
        for (const auto& [name, file] : results.links()) j["links"][name] = self + "/" + file;
    // A shot: its frames' states, from the running job or, once finished, from its summary;
    // a still's is null. Its results are per frame, and a contact sheet.
    j["shot"] = nullptr;
    if (results.kind == ResultFiles::Kind::shot) {
        if (has_summary && s.summary.contains("shot")) {
            j["shot"] = s.summary["shot"];
            j["shot"]["current_frame"] = nullptr;
            j["shot"]["eta_s"] = 0.0;
        } else if (s.shot) {
            j["shot"] = to_json(*s.shot);
        }
    }
    return j;
}

}  // namespace tessera::api
