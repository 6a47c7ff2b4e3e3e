#include "server/queue/job_queue.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <unordered_map>

#include <spdlog/spdlog.h>

#include "api/json_text.h"
#include "api/result_files.h"
#include "engine/core/scene_error.h"
#include "engine/scene/procedural.h"
#include "server/loggable.h"
#include "server/memory_return.h"
#include "server/store/job_results.h"

namespace tessera::server {
using api::json_text;
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string new_id() {
    static thread_local std::mt19937_64 rng(std::random_device{}() ^ uint64_t(unix_time_s() * 1e6));
    static const char* hex = "0123456789abcdef";
    std::string s(16, '0');
    uint64_t v = rng();
    for (auto& c : s) { c = hex[v & 15]; v >>= 4; }
    return s;
}

bool valid_id(const std::string& id) {
    return id.size() == 16 && id.find_first_not_of("0123456789abcdef") == std::string::npos;
}

QueueError no_such_job(const std::string& id) {
    return QueueError(QueueErrorKind::not_found, "not-found", "No such job", "no job with id '" + loggable(id, 64) + "'");
}

// The data directory, created if need be, after a write into it: a read-only or full disk
// stops the start with a reason that names the directory, not with SQLite's "unable to open".
std::string writable_data_dir(const std::string& dir) {
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) throw std::runtime_error("data directory " + dir + ": " + ec.message());
    const std::string probe = (fs::path(dir) / ".write-test").string();
    std::FILE* f = std::fopen(probe.c_str(), "w");
    const int err = errno;
    const bool written = f && std::fputc('x', f) != EOF && std::fflush(f) == 0;
    const int werr = errno;
    if (f) std::fclose(f);
    std::remove(probe.c_str());
    if (!f) throw std::runtime_error("data directory " + dir + " is not writable: " + std::strerror(err));
    if (!written) throw std::runtime_error("data directory " + dir + " is not writable: " + std::strerror(werr));
    return dir;
}

}  // namespace

double unix_time_s() {
    return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

json to_json(const JobList& list) {
    json jobs = json::array();
    for (const api::JobStatus& s : list.jobs) jobs.push_back(api::to_json(s));
    return {{"jobs", jobs}, {"total", list.total}, {"offset", list.offset}, {"limit", list.limit}};
}

api::JobStatus record_status(const JobRecord& rec) {
    api::JobStatus st;
    st.id = rec.id;
    st.state = rec.state;
    st.settings = json::parse(rec.spec_json, nullptr, false);
    st.priority = rec.priority;
    st.created_at = rec.created_at;
    st.started_at = rec.started_at;
    st.finished_at = rec.finished_at;
    st.attempts = rec.attempts;
    st.error = rec.error;
    if (!rec.report_json.empty()) st.summary = json::parse(rec.report_json, nullptr, false);
    return st;
}

JobQueue::JobQueue(QueueConfig config)
    : config_(std::move(config)),
      catalog_(config_.project_scenes, config_.scene_dirs, (fs::path(writable_data_dir(config_.data_dir)) / "uploads").string()) {}

JobQueue::~JobQueue() = default;

QueueError JobQueue::shutting_down() const {
    return QueueError(QueueErrorKind::unavailable, "shutting-down", "The server is shutting down", "no new jobs are accepted")
        .with_retry_after(5);
}

std::string JobQueue::job_dir(const std::string& id) const { return job_results_dir(config_.data_dir, id).string(); }

api::JobStatus JobQueue::submit(const json& body) {
    if (!accepting_) throw shutting_down();
    api::RenderJob job;
    try {
        job = api::parse_render_job(body, config_.job_limits);
    } catch (const api::InvalidJob& e) {
        throw QueueError(QueueErrorKind::invalid, "invalid-field", "Invalid job", e.what()).with_field(e.pointer());
    }
    check_render_job(job);
    return accept(job);
}

api::JobStatus JobQueue::submit_comparison(const json& body) {
    if (!accepting_) throw shutting_down();
    api::ComparisonJob job;
    try {
        job = api::parse_comparison_job(body, config_.job_limits);
    } catch (const api::InvalidJob& e) {
        throw QueueError(QueueErrorKind::invalid, "invalid-field", "Invalid comparison", e.what()).with_field(e.pointer());
    }
    if (!catalog_.find(job.scene.substr(0, job.scene.find('?'))))
        throw QueueError(QueueErrorKind::not_found, "unknown-scene", "Unknown scene", "no scene named '" + job.scene + "'")
            .with_field("/scene");
    return accept(job);
}

// What the job names must exist now, not when it runs: its scene (built-in names may carry
// parameters, builtin:displaced_sphere?triangles=N), its environment map, its reference job.
void JobQueue::check_render_job(const api::RenderJob& job) {
    const std::string base = job.scene.substr(0, job.scene.find('?'));
    if (!catalog_.find(base))
        throw QueueError(QueueErrorKind::not_found, "unknown-scene", "Unknown scene",
                         "no scene named '" + job.scene + "' (GET /v1/scenes lists them)").with_field("/scene");
    if (base.rfind("builtin:", 0) == 0) {
        try {
            check_builtin_name(job.scene, config_.load_limits.max_triangles);
        } catch (const SceneError& e) {
            throw QueueError(QueueErrorKind::invalid, "invalid-field", "Invalid job", e.detail()).with_field("/scene");
        }
    } else if (base != job.scene) {
        throw QueueError(QueueErrorKind::not_found, "unknown-scene", "Unknown scene", "only built-in scenes take parameters")
            .with_field("/scene");
    }
    if (!job.environment.empty() && !catalog_.find_environment(job.environment))
        throw QueueError(QueueErrorKind::not_found, "unknown-environment", "Unknown environment map",
                         "no environment map named '" + job.environment + "' (an .exr or .hdr file in the scene folders)")
            .with_field("/environment");
    if (job.reference.empty()) return;
    std::optional<JobRecord> ref;
    try {
        ref = store_->get(job.reference);
    } catch (const StoreError& e) {
        throw store_refusal(e);
    }
    if (!ref)
        throw QueueError(QueueErrorKind::invalid, "invalid-field", "Invalid job", "no job " + job.reference + " to use as reference")
            .with_field("/reference");
    if (ref->state != JobState::succeeded)
        throw QueueError(QueueErrorKind::conflict, "not-finished", "The reference job has not succeeded",
                         "job " + job.reference + " is " + to_string(ref->state)).with_field("/reference");
    // The reference's size from its typed job, as stored.
    const api::Job stored = api::job_from_json(json::parse(ref->spec_json));
    const auto* r = std::get_if<api::RenderJob>(&stored);
    if (r && r->frames)
        throw QueueError(QueueErrorKind::invalid, "invalid-field", "Invalid job",
                         "job " + job.reference + " is a shot; a reference is a still's image").with_field("/reference");
    if (!r || r->render.width != job.render.width || r->render.height != job.render.height)
        throw QueueError(QueueErrorKind::invalid, "invalid-field", "Invalid job",
                         r ? "the reference is " + std::to_string(r->render.width) + "×" + std::to_string(r->render.height) +
                                 ", the job " + std::to_string(job.render.width) + "×" + std::to_string(job.render.height)
                           : "job " + job.reference + " is a comparison, not an image")
            .with_field("/reference");
}

api::JobStatus JobQueue::accept(const api::Job& job) {
    // The jobs it runs after must be known now: a typo would otherwise wait for ever.
    const std::vector<std::string>& after = api::after_of(job);
    for (size_t i = 0; i < after.size(); ++i) {
        std::optional<JobRecord> dep;
        try {
            dep = store_->get(after[i]);
        } catch (const StoreError& e) {
            throw store_refusal(e);
        }
        if (!dep)
            throw QueueError(QueueErrorKind::invalid, "invalid-field", "Invalid job", "no job " + after[i] + " to run after")
                .with_field("/after/" + std::to_string(i));
    }
    // A notification's URL must be one this server may call, now (and again when it sends).
    if (const auto& n = api::notify_of(job)) {
        if (!notifier_)
            throw QueueError(QueueErrorKind::invalid, "invalid-field", "Invalid job",
                             "this server sends no notifications (it was started without --notify-secret)").with_field("/notify");
        try {
            admitted_address(n->url, notifier_->policy());
        } catch (const std::invalid_argument& e) {
            throw QueueError(QueueErrorKind::invalid, "invalid-field", "Invalid job", std::string("notify.url: ") + e.what())
                .with_field("/notify/url");
        }
    }
    JobRecord rec;
    rec.id = new_id();
    rec.state = after.empty() ? JobState::queued : JobState::waiting;
    rec.spec_json = json_text(api::to_json(job));  // the typed job, serialized once
    rec.priority = api::priority_of(job);
    rec.created_at = unix_time_s();
    const std::string id = rec.id;
    api::JobStatus st = enqueue(job, std::move(rec));
    if (after.empty()) return st;
    settle_waiting();  // the jobs it runs after may have ended already
    return status(id);
}

void JobQueue::start_notifier(const std::string& node) {
    if (config_.notify.secret.empty()) return;
    notifier_ = std::make_unique<Notifier>(config_.notify, node, [this](const std::string& job, const TaskRecord& t) { record_task(job, t); });
}

void JobQueue::stop_notifier() {
    if (notifier_) notifier_->stop();
}

void JobQueue::notify(const api::JobStatus& st, const std::string& event) {
    if (!notifier_ || !st.settings.is_object()) return;
    const json n = st.settings.value("notify", json());
    if (!n.is_object() || !n.contains("url") || !n["url"].is_string()) return;
    const std::string what = event.empty() ? to_string(st.state) : event;
    if (what == "frame" && !n.value("frames", false)) return;
    try {
        if (!claim_notification(st.id, what)) return;
    } catch (const std::exception& e) {
        spdlog::warn("job {}: the {} notification cannot be claimed: {}", st.id, what, e.what());
        return;
    }
    const json body = {{"event", what}, {"sent_at", unix_time_s()}, {"job", api::to_json(st)}};
    notifier_->send(st.id, n["url"].get<std::string>(), what, json_text(body));
}

void JobQueue::settle_waiting() {
    std::lock_guard<std::mutex> lock(settle_mutex_);
    // Until nothing changes: a job failed here fails the jobs that run after it in turn.
    for (bool changed = true; changed;) {
        changed = false;
        std::vector<JobRecord> waiting;
        try {
            // Every waiting job, a page of the store's at a time (it lists at most 1000).
            const size_t total = store_->count(JobState::waiting);
            if (total == 0) return;
            for (size_t offset = 0; offset < total;) {
                std::vector<JobRecord> page = store_->list(JobState::waiting, offset, 1000);
                if (page.empty()) break;
                offset += page.size();
                waiting.insert(waiting.end(), std::make_move_iterator(page.begin()), std::make_move_iterator(page.end()));
            }
        } catch (const std::exception& e) {
            spdlog::warn("waiting jobs: cannot read them: {}", e.what());
            return;
        }
        std::reverse(waiting.begin(), waiting.end());  // oldest first
        for (const JobRecord& rec : waiting) {
            std::vector<std::string> after;
            try {
                after = api::after_of(api::job_from_json(json::parse(rec.spec_json)));
            } catch (const std::exception&) {
                continue;  // a record of another version: left as it is
            }
            std::optional<std::pair<JobState, std::string>> end;  // the state it takes, and why
            bool all = true;
            try {
                for (const std::string& dep : after) {
                    const std::optional<JobRecord> d = store_->get(dep);
                    if (!d) {
                        end = {JobState::failed, "job " + dep + ", which it runs after, is gone"};
                    } else if (d->state == JobState::failed) {
                        // Its reason too, bounded: a long chain would repeat every link's.
                        const std::string why = d->error.size() > 400 ? d->error.substr(0, 400) + "…" : d->error;
                        end = {JobState::failed, "job " + dep + ", which it runs after, failed" + (why.empty() ? "" : ": " + why)};
                    } else if (d->state == JobState::canceled) {
                        end = {JobState::canceled, "job " + dep + ", which it runs after, was canceled"};
                    } else if (d->state != JobState::succeeded) {
                        all = false;
                        continue;
                    } else {
                        continue;
                    }
                    break;
                }
                if (end && store_->finish(rec.id, end->first, unix_time_s(), end->second, "")) {
                    spdlog::info("job {} {}: {}", rec.id, to_string(end->first), end->second);
                } else if (!end && all && store_->release(rec.id)) {
                    spdlog::info("job {} queued: every job it runs after has succeeded", rec.id);
                    released(rec);
                } else {
                    continue;
                }
                changed = true;
                publish_state(rec.id);
            } catch (const std::exception& e) {
                ++metrics_.store_errors;
                spdlog::error("job {}: cannot settle its wait: {}", rec.id, e.what());
            }
        }
    }
}

QueueError JobQueue::refused_submission(const StoreError& e) {
    ++metrics_.store_errors;
    store_refused(e.what());
    spdlog::error("job refused: {}", e.what());
    return store_refusal(e);
}

void JobQueue::queued(const std::string& id, const api::Job& job, int priority) {
    ++metrics_.jobs_submitted;
    spdlog::info("job {} queued (scene {}, priority {})", id, api::scene_of(job), priority);
}

api::JobStatus JobQueue::status(const std::string& id) {
    if (!valid_id(id)) throw no_such_job(id);
    std::optional<JobRecord> rec;
    try {
        rec = store_->get(id);
    } catch (const StoreError& e) {
        throw store_refusal(e);
    }
    if (!rec) throw no_such_job(id);
    return status_of(*rec);
}

api::JobStatus JobQueue::status_of(const JobRecord& rec, bool locked) {
    api::JobStatus st = record_status(rec);
    add_live(st, rec, locked);
    // A shot no worker of this process holds (queued, failed or canceled; running before its
    // worker has begun, or on a farm's node): its frames from the job, those done from the
    // frames written, in order, in the results folder the farm shares.
    const bool shot = st.settings.is_object() && st.settings.contains("frames") && !st.settings["frames"].is_null();
    if (shot && !st.shot && !(st.summary.is_object() && st.summary.contains("shot"))) {
        const api::Job job = api::job_from_json(st.settings);
        api::ShotProgress p;
        p.frames = std::get<api::RenderJob>(job).frames->frames();
        // A farm's chunks finish out of order. The folders there are listed, not every frame
        // looked up: a status costs what was written, not the shot's length.
        const fs::path frames_dir = fs::path(job_dir(rec.id)) / "frames";
        std::error_code ec;
        if (rec.state != JobState::queued && fs::is_directory(frames_dir, ec)) {
            std::unordered_map<int, size_t> index;
            for (size_t i = 0; i < p.frames.size(); ++i) index.emplace(p.frames[i], i);
            p.written.assign(p.frames.size(), 0);
            for (const auto& e : fs::directory_iterator(frames_dir, ec)) {
                int n = 0;
                const std::string name = e.path().filename().string();
                const auto [end, err] = std::from_chars(name.data(), name.data() + name.size(), n);
                if (err != std::errc() || end != name.data() + name.size()) continue;
                const auto it = index.find(n);
                if (it != index.end() && !p.written[it->second] && fs::exists(e.path() / "report.json", ec))
                    p.written[it->second] = 1, ++p.frames_done;
            }
        }
        p.running = rec.state == JobState::running;
        if (p.running && (!st.live_progress || st.live_progress->fraction == 0.0) && !p.frames.empty())
            st.live_progress = api::JobProgress{double(p.frames_done) / double(p.frames.size()), 0, 0, 0};
        st.shot = p;
    }
    return st;
}

JobList JobQueue::list(const std::string& state, size_t offset, size_t limit) {
    std::optional<JobState> filter;
    if (!state.empty()) {
        JobState s;
        if (!parse_job_state(state, s))
            throw QueueError(QueueErrorKind::invalid, "invalid-parameter", "Invalid query parameter",
                             "state must be queued, waiting, running, paused, succeeded, failed or canceled").with_field("state");
        filter = s;
    }
    JobList out;
    out.offset = offset;
    out.limit = limit;
    try {
        for (const JobRecord& r : store_->list(filter, offset, limit)) out.jobs.push_back(status_of(r));
        out.total = store_->count(filter);
    } catch (const StoreError& e) {
        throw store_refusal(e);
    }
    return out;
}

void JobQueue::delete_results(const std::string& id) {
    if (!is_final(status(id).state))
        throw QueueError(QueueErrorKind::conflict, "not-finished", "The job is not finished", "cancel it first or wait");
    std::error_code ec;
    fs::remove_all(job_dir(id), ec);
    spdlog::info("job {} results deleted", id);
}

namespace {

// What the job never has (api/result_files.h, the rule its links follow) is not "gone" but never
// made: 404, whatever its state (not "poll" while it runs).
// A running shot shows its current frame's latest pass at the job's own image URLs (the web
// page does): between passes those are "not yet" (409), as a still's before its first.
void check_offered(const std::string& id, const nlohmann::json& settings, const std::string& file, bool frame,
                   JobState state) {
    const std::string fetch = "/v1/jobs/" + id;
    const api::ResultFiles results = api::ResultFiles::of(settings);
    switch (results.unoffered(file, frame)) {
    case api::Unoffered::none: return;
    case api::Unoffered::not_a_shot:
        throw QueueError(QueueErrorKind::not_found, "not-a-shot", "Not a shot",
                         "job " + id + " is not a shot: it has no " + (frame ? "frames" : file) +
                             (!frame ? ""
                              : results.kind == api::ResultFiles::Kind::comparison ? "; its results are " + fetch + "/report.json and " + fetch + "/convergence.svg"
                                                                                   : "; fetch " + fetch + "/" + file));
    case api::Unoffered::per_frame:
        if (!is_final(state) && api::ResultFiles::live(file))
            throw QueueError(QueueErrorKind::conflict, "not-finished", "No pass to show yet",
                             "job " + id + " is " + to_string(state) + ": its current frame's latest pass is shown here once it has one; poll " + fetch);
        throw QueueError(QueueErrorKind::not_found, "per-frame-result", "A shot's images are per frame",
                         "job " + id + " is a shot: fetch " + fetch + "/frames/{n}/" + file + ", or contact_sheet.png");
    case api::Unoffered::not_a_render:
        throw QueueError(QueueErrorKind::not_found, "not-a-render", "A comparison has no images",
                         "job " + id + " is a comparison: its results are " + fetch + "/report.json and " + fetch +
                             "/convergence.svg");
    case api::Unoffered::not_denoised:
        throw QueueError(QueueErrorKind::not_found, "not-denoised", "The job does not denoise",
                         "job " + id + " was not asked to denoise (\"denoise\": true): it has no " + file);
    case api::Unoffered::no_such_pass: {
        const std::string name = file == "passes.exr" ? "" : file.substr(7, file.size() - 7 - 4);  // passes/<name>.exr
        throw QueueError(QueueErrorKind::not_found, "no-such-pass", "The job has no such pass",
                         "job " + id + (name.empty() ? " asked for no passes" : " did not ask for the pass " + name) +
                             " (\"passes\": [...])");
    }
    }
}

// A denoising job whose render ended before every pixel had two samples (a time limit): the
// denoiser compares a pixel's two halves, and there was nothing to denoise.
QueueError nothing_denoised(const std::string& what) {
    return QueueError(QueueErrorKind::not_found, "not-denoised", "Nothing was denoised",
                      "job " + what + " has no denoised image: its render ended before every pixel had the two samples the "
                      "denoiser compares (its time limit, or a pixel of one sample); the report's render.left_out says so");
}

}  // namespace

std::string JobQueue::result_path(const std::string& id, const std::string& file) {
    const api::JobStatus st = status(id);
    const JobState state = st.state;
    check_offered(id, st.settings, file, false, state);
    if (!is_final(state))
        throw QueueError(QueueErrorKind::conflict, "not-finished", "The job is not finished",
                         "job " + id + " is " + to_string(state) + "; poll /v1/jobs/" + id);
    const fs::path p = fs::path(job_dir(id)) / file;
    if (!fs::exists(p)) {
        if (file.starts_with("denoised.") && fs::exists(fs::path(job_dir(id)) / "image.exr")) throw nothing_denoised(id);
        throw QueueError(QueueErrorKind::gone, "gone", "No such result",
                         state == JobState::succeeded ? "the results of job " + id + " were deleted"
                                                      : "job " + id + " " + to_string(state) + " without results");
    }
    return p.string();
}

std::string JobQueue::frame_result_path(const std::string& id, int frame, const std::string& file) {
    const api::JobStatus st = status(id);
    check_offered(id, st.settings, file, true, st.state);
    const api::Job job = api::job_from_json(st.settings);
    const auto* r = std::get_if<api::RenderJob>(&job);
    if (!r || !r->frames || !r->frames->contains(frame))
        throw QueueError(QueueErrorKind::not_found, "no-such-frame", "No such frame",
                         "job " + id + " does not render frame " + std::to_string(frame));
    const fs::path dir = fs::path(job_dir(id)) / "frames" / std::to_string(frame);
    // report.json is a frame's last file: before it, the frame is not finished.
    if (!fs::exists(dir / "report.json")) {
        if (!is_final(st.state))
            throw QueueError(QueueErrorKind::conflict, "not-finished", "The frame is not finished",
                             "frame " + std::to_string(frame) + " of job " + id + " is not written yet; poll /v1/jobs/" + id);
        throw QueueError(QueueErrorKind::gone, "gone", "No such result",
                         "job " + id + " " + to_string(st.state) + " without frame " + std::to_string(frame));
    }
    const fs::path p = dir / file;
    if (!fs::exists(p)) {
        if (file.starts_with("denoised.") && fs::exists(dir / "image.exr")) throw nothing_denoised(id + " frame " + std::to_string(frame));
        throw QueueError(QueueErrorKind::gone, "gone", "No such result", "frame " + std::to_string(frame) + " of job " + id + " has no " + file);
    }
    return p.string();
}

std::map<std::string, size_t> JobQueue::counts_by_state() {
    std::map<std::string, size_t> m;
    for (JobState s : api::kJobStates) m[to_string(s)] = store_->count(s);
    return m;
}

void JobQueue::release_memory() { release_free_memory(); }

void JobQueue::store_refused(const std::string& why) {
    std::lock_guard<std::mutex> lock(store_health_mutex_);
    store_refused_at_ = std::chrono::steady_clock::now();
    store_refusal_ = why;
}

void JobQueue::store_wrote() {
    std::lock_guard<std::mutex> lock(store_health_mutex_);
    store_refusal_.clear();
}

std::string JobQueue::unready_reason() {
    if (!accepting_) return "the server is shutting down";
    if (std::string why = store_unreachable(); !why.empty()) return why;
    std::lock_guard<std::mutex> lock(store_health_mutex_);
    // A refused write counts for a while; then the next job tries the store again (a full disk
    // may have been freed meanwhile), and a refusal starts the wait anew.
    if (!store_refusal_.empty() && std::chrono::steady_clock::now() - store_refused_at_ < std::chrono::seconds(10))
        return "the job store refused its last write (" + store_refusal_ + ")";
    return "";
}

void JobQueue::publish(const char* type, const api::JobStatus& status, const api::PassSummary* pass) {
    try {
        json data = {{"job", api::to_json(status)}};
        if (pass) data["pass"] = api::to_json(*pass);
        events_.publish(type, status.id, json_text(data));
    } catch (const std::exception& e) {
        spdlog::warn("events: no {} event: {}", type, e.what());
    }
}

void JobQueue::publish_state(const std::string& id) {
    try {
        const api::JobStatus st = status(id);
        publish("state", st);
        if (api::is_final(st.state)) notify(st);
    } catch (const std::exception& e) {
        spdlog::warn("job {}: no state event: {}", id, e.what());
    }
}

}  // namespace tessera::server
