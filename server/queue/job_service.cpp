#include "server/store/job_results.h"
#include "server/queue/job_service.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <random>

#include <spdlog/spdlog.h>

#include "api/json_text.h"
#include "api/job_runner.h"
#include "engine/scene/procedural.h"
#include "server/http/problem.h"
#include "server/store/sqlite_job_store.h"
#include "server/farm/film_codec.h"
#include "server/loggable.h"
#include "server/memory_return.h"

namespace tessera::server {
using api::json_text;
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

double now_s() {
    return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

std::string new_id() {
    static thread_local std::mt19937_64 rng(std::random_device{}() ^ uint64_t(now_s() * 1e6));
    static const char* hex = "0123456789abcdef";
    std::string s(16, '0');
    uint64_t v = rng();
    for (auto& c : s) { c = hex[v & 15]; v >>= 4; }
    return s;
}

bool valid_id(const std::string& id) {
    return id.size() == 16 && id.find_first_not_of("0123456789abcdef") == std::string::npos;
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

JobService::JobService(ServiceConfig config)
    : config_(std::move(config)),
      catalog_(config_.project_scenes, config_.scene_dirs, (fs::path(writable_data_dir(config_.data_dir)) / "uploads").string()),
      scenes_("", config_.node.scene_cache_mb << 20, config_.load_limits, config_.node.scene_cache_idle_s) {
    if (!config_.redis_url.empty()) {
        // A farm: no queue in this process; render nodes (maybe one here) take the tiles.
        const RedisUrl url = RedisUrl::parse(config_.redis_url);
        auto rs = std::make_unique<RedisJobStore>(url, config_.max_store_bytes);
        redis_store_ = rs.get();
        store_ = std::move(rs);
        if (config_.render_locally) {
            NodeConfig nc = config_.node;
            nc.redis = url;
            nc.data_dir = config_.data_dir;
            nc.threads = config_.render_threads > 0 ? config_.render_threads : int(std::max(1u, std::thread::hardware_concurrency()));
            nc.load_limits = config_.load_limits;
            node_ = std::make_unique<RenderNode>(nc);
            node_->start();
        }
        std::optional<FarmLook> first;
        try {
            first = look_at_farm();
        } catch (const std::exception& e) {
            spdlog::warn("events: cannot read the farm's jobs: {}", e.what());
        }
        farm_watch_ = std::thread([this, first = std::move(first)]() mutable { watch_farm(std::move(first)); });
        return;
    }
    store_ = std::make_unique<SqliteJobStore>(config_.data_dir + "/tessera.db", config_.max_store_bytes);
    const int requeued = store_->requeue_all_running();
    if (requeued) spdlog::warn("{} job(s) were running when the server stopped; queued again", requeued);
    for (const JobRecord& r : store_->queued_in_order()) queue_.insert({r.priority, r.seq, r.id});
    if (!queue_.empty()) spdlog::info("{} queued job(s) restored", queue_.size());
    for (int i = 0; i < std::max(1, config_.concurrent_jobs); ++i) workers_.emplace_back([this] { worker(); });
}

JobService::~JobService() { shutdown(); }

void JobService::shutdown() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        accepting_ = false;
        if (stopping_ && workers_.empty() && !node_) return;
        stopping_ = true;
        for (auto& [id, r] : running_) { r->shutdown = true; r->stop = true; }
    }
    cv_.notify_all();
    pause_cv_.notify_all();
    for (auto& w : workers_) if (w.joinable()) w.join();
    workers_.clear();
    if (farm_watch_.joinable()) farm_watch_.join();
    events_.close();
    // A farm's node hands its tasks in hand back to the others.
    if (node_) node_->stop();
    node_.reset();
}

std::vector<std::pair<std::string, std::string>> JobService::render_nodes() {
    if (!redis_store_) return {};
    return redis_store_->nodes();
}

void JobService::publish_scene(const std::string& id, const std::string& scene) {
    auto entry = catalog_.find(scene.substr(0, scene.find('?')));
    if (!entry) throw Problem(404, "unknown-scene", "Unknown scene", "no scene named '" + scene + "'").with_field("/scene");
    SceneRef ref;
    if (entry->source == "builtin") {
        ref.source = scene;
        redis_store_->put_scene(id, ref, nullptr);
        return;
    }
    std::ifstream in(entry->path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (!in.good() && !in.eof()) throw Problem(503, "scene-unreadable", "Scene unreadable", "cannot read scene '" + scene + "'");
    ref.source = entry->path;
    ref.hash = content_hash(bytes);
    ref.ext = fs::path(entry->path).extension().string();
    for (char& c : ref.ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    redis_store_->put_scene(id, ref, &bytes);
}

// A render farm's nodes read the job's environment map from Redis, as they read its scene (the
// catalog's folders need not be theirs).
void JobService::publish_environment(const std::string& id, const std::string& name) {
    const auto entry = catalog_.find_environment(name);
    if (!entry)
        throw Problem(404, "unknown-environment", "Unknown environment map", "no environment map named '" + name + "'")
            .with_field("/environment");
    std::ifstream in(entry->path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (!in.good() && !in.eof())
        throw Problem(503, "scene-unreadable", "Scene unreadable", "cannot read environment map '" + name + "'");
    SceneRef ref;
    ref.source = entry->path;
    ref.hash = content_hash(bytes);
    ref.ext = fs::path(entry->path).extension().string();
    for (char& c : ref.ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    redis_store_->put_environment(id, ref, bytes);
}

std::string JobService::job_dir(const std::string& id) const { return job_results_dir(config_.data_dir, id).string(); }

json JobService::submit(const json& body) {
    if (!accepting_) throw Problem(503, "shutting-down", "The server is shutting down", "no new jobs are accepted").with_retry_after(5);
    api::RenderJob job;
    try {
        job = api::parse_render_job(body, config_.job_limits);
    } catch (const api::InvalidJob& e) {
        throw Problem(400, "invalid-field", "Invalid job", e.what()).with_field(e.pointer());
    }
    // Built-in names may carry parameters (builtin:displaced_sphere?triangles=N): checked now,
    // not when the job runs.
    const std::string base = job.scene.substr(0, job.scene.find('?'));
    if (!catalog_.find(base))
        throw Problem(404, "unknown-scene", "Unknown scene",
                      "no scene named '" + job.scene + "' (GET /v1/scenes lists them)").with_field("/scene");
    if (base.rfind("builtin:", 0) == 0) {
        try {
            check_builtin_name(job.scene);
        } catch (const SceneError& e) {
            throw Problem(400, "invalid-field", "Invalid job", e.detail()).with_field("/scene");
        }
    } else if (base != job.scene) {
        throw Problem(404, "unknown-scene", "Unknown scene", "only built-in scenes take parameters").with_field("/scene");
    }
    if (!job.environment.empty()) {
        if (!catalog_.find_environment(job.environment))
            throw Problem(404, "unknown-environment", "Unknown environment map",
                          "no environment map named '" + job.environment + "' (an .exr or .hdr file in the scene folders)")
                .with_field("/environment");
    }
    if (!job.reference.empty()) {
        std::optional<JobRecord> ref;
        try {
            ref = store_->get(job.reference);
        } catch (const StoreError& e) {
            throw store_problem(e);
        }
        if (!ref) throw Problem(400, "invalid-field", "Invalid job", "no job " + job.reference + " to use as reference").with_field("/reference");
        if (ref->state != JobState::succeeded)
            throw Problem(409, "not-finished", "The reference job has not succeeded", "job " + job.reference + " is " + to_string(ref->state)).with_field("/reference");
        const json rs = json::parse(ref->spec_json);
        if (rs["width"] != job.render.width || rs["height"] != job.render.height)
            throw Problem(400, "invalid-field", "Invalid job", "the reference is " + json_text(rs["width"]) + "×" + json_text(rs["height"]) +
                                                                  ", the job " + std::to_string(job.render.width) + "×" + std::to_string(job.render.height)).with_field("/reference");
    }
    return enqueue(job);
}

json JobService::enqueue(const api::Job& job) {
    JobRecord rec;
    rec.id = new_id();
    rec.state = JobState::queued;
    rec.spec_json = json_text(api::to_json(job));  // the typed job, serialized once
    rec.priority = api::priority_of(job);
    rec.created_at = now_s();
    if (redis_store_) {
        try {
            const size_t queued = store_->count(JobState::queued);
            if (queued >= config_.max_queued)
                throw Problem(429, "queue-full", "The queue is full",
                              "the queue holds " + std::to_string(queued) + " jobs, its limit").with_retry_after(10);
            publish_scene(rec.id, api::scene_of(job));
            if (const auto* rj = std::get_if<api::RenderJob>(&job); rj && !rj->environment.empty())
                publish_environment(rec.id, rj->environment);
            store_->insert(rec);  // durable in Redis, and its first task queued, before it is acknowledged
            store_wrote();
        } catch (const StoreError& e) {
            ++metrics_.store_errors;
            store_refused(e.what());
            spdlog::error("job refused: {}", e.what());
            throw store_problem(e);
        }
    } else {
        std::lock_guard<std::mutex> lock(mutex_);
        if (queue_.size() >= config_.max_queued)
            throw Problem(429, "queue-full", "The queue is full",
                          "the queue holds " + std::to_string(queue_.size()) + " jobs, its limit").with_retry_after(10);
        try {
            store_->insert(rec);  // durable before it is acknowledged
            store_wrote();
        } catch (const StoreError& e) {
            ++metrics_.store_errors;
            store_refused(e.what());
            spdlog::error("job refused: {}", e.what());
            throw store_problem(e);
        }
        queue_.insert({rec.priority, rec.seq, rec.id});
        // Before a worker can take it: "created" comes before its "running".
        json st = status_json(rec, true);
        publish("created", st);
        cv_.notify_one();
        ++metrics_.jobs_submitted;
        spdlog::info("job {} queued (scene {}, priority {})", rec.id, api::scene_of(job), rec.priority);
        return st;
    }
    cv_.notify_one();
    ++metrics_.jobs_submitted;
    spdlog::info("job {} queued (scene {}, priority {})", rec.id, api::scene_of(job), rec.priority);
    return status_json(rec);
}

json JobService::submit_comparison(const json& body) {
    if (!accepting_) throw Problem(503, "shutting-down", "The server is shutting down", "no new jobs are accepted").with_retry_after(5);
    api::ComparisonJob job;
    try {
        job = api::parse_comparison_job(body, config_.job_limits);
    } catch (const api::InvalidJob& e) {
        throw Problem(400, "invalid-field", "Invalid comparison", e.what()).with_field(e.pointer());
    }
    if (!catalog_.find(job.scene.substr(0, job.scene.find('?'))))
        throw Problem(404, "unknown-scene", "Unknown scene", "no scene named '" + job.scene + "'").with_field("/scene");
    return enqueue(job);
}

json JobService::status(const std::string& id) {
    if (!valid_id(id)) throw Problem(404, "not-found", "No such job", "no job with id '" + id + "'");
    auto rec = store_->get(id);
    if (!rec) throw Problem(404, "not-found", "No such job", "no job with id '" + id + "'");
    return status_json(*rec);
}

namespace {

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

}  // namespace

// A running job's status from what its worker holds: no store read and not the service's lock
// (which store writes hold), so render threads publishing progress and passes never wait.
json JobService::running_status_json(Running& r) {
    api::JobStatus st = record_status(r.rec);
    if (r.job) st.live_progress = api::job_progress(*r.job, r.samples.load(), r.tiles_done.load(), r.tiles_total.load());
    std::lock_guard<std::mutex> pass_lock(r.pass_mutex);
    st.latest_pass = r.pass;
    return api::to_json(st);
}

json JobService::status_json(const JobRecord& rec, bool locked) {
    api::JobStatus st = record_status(rec);
    if (redis_store_) {
        try {
            if (rec.state == JobState::queued) {
                // Not in the run order any more: taken meanwhile, starting (see below).
                const long long pos = redis_store_->queue_position(rec.id);
                st.queue_position = pos >= 0 ? size_t(pos) : 0;
            } else if (rec.state == JobState::running) {
                if (const auto p = redis_store_->live_progress(rec.id))
                    st.live_progress = api::job_progress(api::job_from_json(st.settings), p->samples, p->tiles_done, p->tiles_total);
            }
        } catch (const std::exception&) {
            // Progress is a courtesy (a store refusal, a record of another version): the record
            // itself was read.
        }
    } else {
        std::unique_lock<std::mutex> lock(mutex_, std::defer_lock);
        if (!locked) lock.lock();
        if (rec.state == JobState::queued) {
            // The record was read before the lock: a job not in the queue any more was taken
            // from its head meanwhile (it is starting), so its position is 0, never null.
            st.queue_position = 0;
            size_t pos = 0;
            for (const auto& k : queue_) {
                if (k.id == rec.id) { st.queue_position = pos; break; }
                ++pos;
            }
        }
        auto it = running_.find(rec.id);
        if (it != running_.end()) {
            const Running& r = *it->second;
            if (r.job) st.live_progress = api::job_progress(*r.job, r.samples.load(), r.tiles_done.load(), r.tiles_total.load());
            if (rec.state == JobState::running) {
                std::lock_guard<std::mutex> pass_lock(it->second->pass_mutex);
                st.latest_pass = r.pass;
            }
        }
    }
    return api::to_json(st);
}

json JobService::list(const std::string& state, size_t offset, size_t limit) {
    std::optional<JobState> filter;
    if (!state.empty()) {
        JobState s;
        if (!parse_job_state(state, s))
            throw Problem(400, "invalid-parameter", "Invalid query parameter",
                          "state must be queued, running, succeeded, failed or canceled").with_field("state");
        filter = s;
    }
    json jobs = json::array();
    for (const JobRecord& r : store_->list(filter, offset, limit)) jobs.push_back(status_json(r));
    return {{"jobs", jobs}, {"total", store_->count(filter)}, {"offset", offset}, {"limit", limit}};
}

json JobService::cancel(const std::string& id) {
    status(id);  // 404 for unknown ids
    if (redis_store_) {
        // Queued or running alike: nodes drop its tasks, and stop a tile in hand within a row.
        try {
            if (store_->finish(id, JobState::canceled, now_s(), "", "")) spdlog::info("job {} canceled", id);
        } catch (const StoreError& e) {
            throw store_problem(e);
        }
        return status(id);
    }
    bool canceled_queued = false;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        for (auto it = queue_.begin(); it != queue_.end(); ++it)
            if (it->id == id) {
                // The store first: if it refuses (503), the job stays queued in both.
                if (store_->finish(id, JobState::canceled, now_s(), "", "")) spdlog::info("job {} canceled while queued", id);
                queue_.erase(it);
                canceled_queued = true;
                break;
            }
        auto r = running_.find(id);
        if (r != running_.end()) { r->second->cancel = true; r->second->stop = true; }
    }
    json st = status(id);
    if (canceled_queued) publish("state", st);  // a running job's ends when its worker stops it
    return st;
}

void JobService::delete_results(const std::string& id) {
    const json s = status(id);
    JobState st;
    parse_job_state(s["state"].get<std::string>(), st);
    if (!is_final(st)) throw Problem(409, "not-finished", "The job is not finished", "cancel it first or wait");
    std::error_code ec;
    fs::remove_all(job_dir(id), ec);
    spdlog::info("job {} results deleted", id);
}

std::string JobService::result_path(const std::string& id, const std::string& file) {
    const json s = status(id);
    const std::string state = s["state"];
    if (state == "queued" || state == "running")
        throw Problem(409, "not-finished", "The job is not finished", "job " + id + " is " + state + "; poll /v1/jobs/" + id);
    const fs::path p = fs::path(job_dir(id)) / file;
    if (!fs::exists(p))
        throw Problem(410, "gone", "No such result",
                      state == "succeeded" ? "the results of job " + id + " were deleted" : "job " + id + " " + state + " without results");
    return p.string();
}

size_t JobService::queue_depth() {
    if (redis_store_) return store_->count(JobState::queued);
    std::lock_guard<std::mutex> lock(mutex_);
    return queue_.size();
}

std::map<std::string, size_t> JobService::counts_by_state() {
    std::map<std::string, size_t> m;
    for (JobState s : {JobState::queued, JobState::running, JobState::succeeded, JobState::failed, JobState::canceled})
        m[to_string(s)] = store_->count(s);
    return m;
}

bool JobService::take_next(JobRecord& rec, std::shared_ptr<Running>& running) {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
        cv_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
        if (stopping_) return false;
        const QueueKey key = *queue_.begin();
        queue_.erase(queue_.begin());
        try {
            // Read, then mark: if the store refuses either, the job is still queued in it,
            // and queued again here below. (Marked first, a failed read would leave it
            // "running" with no worker until the next start.)
            std::optional<JobRecord> r = store_->get(key.id);
            if (!r) continue;
            const double started = now_s();
            if (!store_->mark_running(key.id, started)) continue;  // canceled meanwhile
            rec = std::move(*r);
            rec.state = JobState::running;
            rec.started_at = started;
            ++rec.attempts;
        } catch (const std::exception& e) {
            // The store refused: the job is still queued there. Keep it queued here too and
            // try again after a pause, rather than spin on a full or read-only store.
            ++metrics_.store_errors;
            spdlog::error("job {} cannot start: {}", key.id, e.what());
            queue_.insert(key);
            pause_cv_.wait_for(lock, std::chrono::seconds(1), [&] { return stopping_; });
            continue;
        }
        running = std::make_shared<Running>();
        running->rec = rec;
        try {
            running->job = api::job_from_json(json::parse(rec.spec_json));
        } catch (const std::exception&) {
            // run() fails the job with the reason; until then it shows no progress.
        }
        running_[key.id] = running;
        return true;
    }
}

void JobService::worker() {
    JobRecord rec;
    std::shared_ptr<Running> running;
    while (take_next(rec, running)) {
        spdlog::info("job {} running (attempt {})", rec.id, rec.attempts);
        publish("state", running_status_json(*running));
        try {
            run(rec, *running);
        } catch (const std::exception& e) {
            spdlog::error("job {}: {}", rec.id, loggable(e.what(), 2000));  // run() records every outcome; this only keeps the worker alive
        } catch (...) {
            spdlog::error("job {}: unknown exception", rec.id);
        }
        {
            std::lock_guard<std::mutex> lock(mutex_);
            running_.erase(rec.id);
        }
        publish_state(rec.id);  // finished, failed, canceled, or queued again by a shutdown
        running.reset();
        release_free_memory();  // the job's film, images and a scene the cache did not keep
    }
}

void JobService::release_memory() {
    scenes_.drop_idle();
    if (node_) node_->drop_idle_scenes();
    release_free_memory();
}

void JobService::store_refused(const std::string& why) {
    std::lock_guard<std::mutex> lock(store_health_mutex_);
    store_refused_at_ = std::chrono::steady_clock::now();
    store_refusal_ = why;
}

void JobService::store_wrote() {
    std::lock_guard<std::mutex> lock(store_health_mutex_);
    store_refusal_.clear();
}

std::string JobService::unready_reason() {
    if (!accepting_) return "the server is shutting down";
    if (redis_store_) {
        try {
            store_->count(JobState::queued);
        } catch (const StoreError& e) {
            return std::string("Redis does not answer: ") + e.what();
        }
    }
    std::lock_guard<std::mutex> lock(store_health_mutex_);
    // A refused write counts for a while; then the next job tries the store again (a full disk
    // may have been freed meanwhile), and a refusal starts the wait anew.
    if (!store_refusal_.empty() && std::chrono::steady_clock::now() - store_refused_at_ < std::chrono::seconds(10))
        return "the job store refused its last write (" + store_refusal_ + ")";
    return "";
}

bool JobService::until_stored(const std::string& id, const char* what, const std::function<void()>& change) {
    for (int attempt = 0;; ++attempt) {
        try {
            change();
            if (attempt) spdlog::info("job {}: the store took '{}' after {} retries", id, what, attempt);
            store_wrote();
            return true;
        } catch (const std::exception& e) {
            ++metrics_.store_errors;
            // Readiness follows the store's own refusals, not any error of the change.
            if (dynamic_cast<const StoreError*>(&e)) store_refused(e.what());
            if (attempt == 0) spdlog::error("job {}: cannot record '{}': {}; retrying", id, what, e.what());
        }
        std::unique_lock<std::mutex> lock(mutex_);
        const auto pause = std::chrono::milliseconds(std::min(5000, 100 << std::min(attempt, 6)));
        if (pause_cv_.wait_for(lock, pause, [&] { return stopping_; })) {
            spdlog::warn("job {}: '{}' not recorded before shutdown; the job runs again after a restart", id, what);
            return false;
        }
    }
}

std::string JobService::scene_source(const std::string& scene) {
    auto entry = catalog_.find(scene.substr(0, scene.find('?')));
    if (!entry) throw std::runtime_error("scene '" + scene + "' is no longer in the catalog");
    return entry->source == "builtin" ? scene : entry->path;
}

void JobService::run(const JobRecord& rec, Running& running) {
    std::string error;
    api::JobOutcome outcome;
    try {
        const api::Job job = api::job_from_json(json::parse(rec.spec_json));
        api::RunOptions opt;
        opt.scene_source = scene_source(api::scene_of(job));
        opt.load_limits = config_.load_limits;
        opt.threads = config_.render_threads;
        opt.job_id = rec.id;
        opt.prepare = [this](const std::string& source, const RenderSceneOptions& options) { return scenes_.get_local(source, options); };
        if (const auto* r = std::get_if<api::RenderJob>(&job)) {
            running.max_spp = r->render.spp;
            if (!r->reference.empty()) opt.reference_image = job_image_exr(config_.data_dir, r->reference).string();
            if (!r->environment.empty()) {
                const auto env = catalog_.find_environment(r->environment);
                if (!env) throw std::runtime_error("environment map '" + r->environment + "' is no longer in the scene folders");
                opt.environment_file = env->path;
            }
        }
        const std::string dir = job_dir(rec.id);
        fs::create_directories(dir);
        api::RunCallbacks cb;
        cb.stop = &running.stop;
        cb.progress = [&](const RenderProgress& p) {
            running.tiles_done = p.tiles_done;
            running.tiles_total = p.tiles_total;
            running.samples = p.samples_done;
            // At most four progress events a second: one render thread claims each slot.
            const int64_t now = std::chrono::steady_clock::now().time_since_epoch().count();
            int64_t last = running.progress_event_ns.load();
            if (now - last >= 250'000'000 && running.progress_event_ns.compare_exchange_strong(last, now))
                publish("progress", running_status_json(running));
        };
        cb.pass = [&](const api::PassSnapshot& snap) {
            api::PassSummary ps{snap.index, snap.spp, snap.point.spp_mean, snap.point.seconds, snap.point.est_rel_mse,
                                snap.point.rel_mse};
            {
                std::lock_guard<std::mutex> lock(running.pass_mutex);
                running.pass = ps;
                running.pass_image = snap.image;
            }
            publish("pass", running_status_json(running), &ps);
        };
        outcome = api::run_job(job, opt, api::RunOutputs::in_directory(dir), cb);
    } catch (const SceneError& e) {
        error = std::string("scene: ") + e.what();
    } catch (const std::exception& e) {
        error = e.what();
    }
    {
        // From here the job's state becomes final: its images are its results, not a pass.
        std::lock_guard<std::mutex> lock(running.pass_mutex);
        running.pass.reset();
        running.pass_image.reset();
    }
    if (error.empty() && outcome.stopped) {
        if (running.shutdown) {
            if (until_stored(rec.id, "queued again", [&] { store_->requeue(rec.id); }))
                spdlog::warn("job {} interrupted by shutdown; queued again", rec.id);
        } else if (until_stored(rec.id, "canceled", [&] { store_->finish(rec.id, JobState::canceled, now_s(), "", ""); })) {
            spdlog::info("job {} canceled while running", rec.id);
        }
        return;
    }
    if (!error.empty()) {
        if (until_stored(rec.id, "failed", [&] { store_->finish(rec.id, JobState::failed, now_s(), error, ""); }))
            spdlog::error("job {} failed: {}", rec.id, loggable(error, 2000));
        return;
    }
    if (outcome.render) {
        metrics_.rays += outcome.render->stats.rays();
        metrics_.render_micros += uint64_t(outcome.render->stats.render_seconds * 1e6);
    }
    const std::string summary = json_text(outcome.summary);
    if (until_stored(rec.id, "succeeded", [&] { store_->finish(rec.id, JobState::succeeded, now_s(), "", summary); }))
        spdlog::info("job {} succeeded in {:.3f} s", rec.id,
                     outcome.render ? outcome.render->timings.total_s : 0.0);
}

std::optional<JobService::LivePass> JobService::live_pass(const std::string& id) {
    std::shared_ptr<Running> r;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        auto it = running_.find(id);
        if (it == running_.end()) return std::nullopt;
        r = it->second;
    }
    std::lock_guard<std::mutex> lock(r->pass_mutex);
    if (!r->pass || !r->pass_image) return std::nullopt;
    return LivePass{*r->pass, r->pass_image, r->max_spp};
}

void JobService::publish(const char* type, const json& status, const api::PassSummary* pass) {
    // Called from render threads too: an event that cannot be made is logged, never thrown.
    try {
        json data = {{"job", status}};
        if (pass) data["pass"] = api::to_json(*pass);
        events_.publish(type, status.value("id", ""), json_text(data));
    } catch (const std::exception& e) {
        spdlog::warn("events: no {} event: {}", type, e.what());
    }
}

void JobService::publish_state(const std::string& id) {
    try {
        publish("state", status(id));
    } catch (const std::exception& e) {
        spdlog::warn("job {}: no state event: {}", id, e.what());
    }
}

JobService::FarmLook JobService::look_at_farm() {
    // A look reads ids only (three sorted-set ranges) and the progress of running jobs.
    FarmLook now;
    for (const std::string& id : redis_store_->ids(JobState::queued, 1000)) now[id] = {FarmSeen::queued, 0};
    for (const std::string& id : redis_store_->ids(JobState::running, 1000)) {
        const auto p = redis_store_->live_progress(id);
        now[id] = {FarmSeen::running, p ? p->samples : 0};
    }
    // The newest jobs, whatever their state: one that came and went between two looks.
    for (const std::string& id : redis_store_->ids(std::nullopt, 50)) now.emplace(id, std::pair{FarmSeen::other, uint64_t(0)});
    return now;
}

void JobService::watch_farm(std::optional<FarmLook> first) {
    // What each job looked like at the last look, kept up to date even while no one listens,
    // so that nothing is missed in the gap while a client reconnects. Records are read for the
    // jobs that changed, and only when someone listens. Without a first look (Redis was not
    // there at start), the first one here is the baseline.
    bool baseline = !first;
    FarmLook seen = first ? std::move(*first) : FarmLook{};
    for (;;) {
        {
            std::unique_lock<std::mutex> lock(mutex_);
            if (pause_cv_.wait_for(lock, std::chrono::milliseconds(300), [&] { return stopping_; })) return;
        }
        try {
            FarmLook now = look_at_farm();
            const bool listening = events_.subscribers() > 0;
            std::vector<std::pair<std::string, const char*>> changes;
            // Unfinished before, out of sight now: it finished, and 50 newer jobs came since.
            for (const auto& [id, before] : seen)
                if (!now.count(id) && before.first != FarmSeen::other) changes.push_back({id, "state"});
            if (!baseline)
                for (const auto& [id, state] : now) {
                    auto it = seen.find(id);
                    if (it == seen.end()) changes.push_back({id, "created"});
                    else if (it->second.first != state.first) changes.push_back({id, "state"});
                    else if (state.first == FarmSeen::running && it->second.second != state.second) changes.push_back({id, "progress"});
                }
            seen = std::move(now);
            baseline = false;
            if (!listening) continue;
            for (const auto& [id, type] : changes) {
                const std::optional<JobRecord> rec = store_->get(id);
                if (!rec) continue;
                const json st = status_json(*rec);
                publish(type, st);
                // New to us after it started: created, then the state it has reached.
                if (std::string(type) == "created" && rec->state != JobState::queued) publish("state", st);
            }
        } catch (const std::exception& e) {
            spdlog::warn("events: cannot read the farm's jobs: {}", e.what());
        }
    }
}

}  // namespace tessera::server
