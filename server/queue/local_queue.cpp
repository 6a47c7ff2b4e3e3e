#include "server/queue/local_queue.h"

#include "server/queue/task_log.h"

#include <algorithm>
#include <chrono>
#include <filesystem>

#include <spdlog/spdlog.h>

#include "api/job_runner.h"
#include "api/json_text.h"
#include "engine/core/scene_error.h"
#include "server/loggable.h"
#include "server/memory_return.h"
#include "server/store/job_results.h"
#include "server/store/sqlite_job_store.h"

namespace tessera::server {
using api::json_text;
namespace fs = std::filesystem;
using nlohmann::json;

LocalQueue::LocalQueue(QueueConfig config)
    : JobQueue(std::move(config)),
      scenes_("", config_.scene_cache_mb << 20, config_.load_limits, config_.scene_cache_idle_s) {
    store_ = std::make_unique<SqliteJobStore>(config_.data_dir + "/tessera.db", config_.max_store_bytes);
    const int requeued = store_->requeue_all_running();
    if (requeued) spdlog::warn("{} job(s) were running when the server stopped; queued again", requeued);
    for (const JobRecord& r : store_->queued_in_order()) queue_.insert({r.priority, r.seq, r.id});
    if (!queue_.empty()) spdlog::info("{} queued job(s) restored", queue_.size());
    start_notifier("local");  // before any job can end
    for (int i = 0; i < std::max(1, config_.concurrent_jobs); ++i) workers_.emplace_back([this] { worker(); });
    settle_waiting();  // jobs whose dependencies ended while the server was down
}

void LocalQueue::record_task(const std::string& job, const TaskRecord& task) {
    append_task_record((fs::path(job_dir(job)) / "log.jsonl").string(), task);
}

LocalQueue::~LocalQueue() { shutdown(); }

void LocalQueue::shutdown() {
    stop_notifier();
    {
        std::lock_guard<std::mutex> lock(mutex_);
        accepting_ = false;
        if (stopping_ && workers_.empty()) return;
        stopping_ = true;
        for (auto& [id, r] : running_) { r->shutdown = true; r->stop = true; }
    }
    cv_.notify_all();
    pause_cv_.notify_all();
    for (auto& w : workers_) if (w.joinable()) w.join();
    workers_.clear();
    events_.close();
}

api::JobStatus LocalQueue::enqueue(const api::Job& job, JobRecord rec) {
    // No other node will ever come to one process: a job it cannot take is refused, not queued.
    const std::vector<std::string>& need = api::task_policy_of(job).required_tags;
    for (const std::string& tag : need)
        if (std::find(config_.tags.begin(), config_.tags.end(), tag) == config_.tags.end())
            throw QueueError(QueueErrorKind::invalid, "no-node-has-tags", "No node can take the job",
                             "the job requires the node tag '" + tag + "'; this server renders on one process" +
                                 (config_.tags.empty() ? std::string(" without tags") : " tagged " + api::json_text(config_.tags)) +
                                 " (serve --tags): submit it to a farm with a node that has it")
                .with_field("/requires");
    std::lock_guard<std::mutex> lock(mutex_);
    // Jobs waiting for others count too: each will be queued.
    size_t waiting = 0;
    try {
        waiting = store_->count(JobState::waiting);
    } catch (const StoreError& e) {
        throw refused_submission(e);
    }
    if (queue_.size() + waiting >= config_.max_queued)
        throw QueueError(QueueErrorKind::queue_full, "queue-full", "The queue is full",
                         "the queue holds " + std::to_string(queue_.size() + waiting) + " jobs (queued or waiting), its limit")
            .with_retry_after(10);
    try {
        store_->insert(rec);  // durable before it is acknowledged
        store_wrote();
    } catch (const StoreError& e) {
        throw refused_submission(e);
    }
    if (rec.state == JobState::queued) queue_.insert({rec.priority, rec.seq, rec.id});
    // Before a worker can take it: "created" comes before its "running".
    api::JobStatus st = status_of(rec, true);
    publish("created", st);
    cv_.notify_one();
    queued(rec.id, job, rec.priority);
    return st;
}

void LocalQueue::released(const JobRecord& rec) {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        queue_.insert({rec.priority, rec.seq, rec.id});
    }
    cv_.notify_one();
}

api::JobStatus LocalQueue::running_status(Running& r) {
    api::JobStatus st = record_status(r.rec);
    if (r.job) st.live_progress = api::job_progress(*r.job, r.samples.load(), r.tiles_done.load(), r.tiles_total.load());
    std::lock_guard<std::mutex> pass_lock(r.pass_mutex);
    st.latest_pass = r.pass;
    st.shot = r.shot;
    return st;
}

void LocalQueue::add_live(api::JobStatus& st, const JobRecord& rec, bool locked) {
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
    if (it == running_.end()) return;
    Running& r = *it->second;
    if (r.job) st.live_progress = api::job_progress(*r.job, r.samples.load(), r.tiles_done.load(), r.tiles_total.load());
    if (rec.state == JobState::running) {
        std::lock_guard<std::mutex> pass_lock(r.pass_mutex);
        st.latest_pass = r.pass;
        st.shot = r.shot;
    }
}

api::JobStatus LocalQueue::cancel(const std::string& id) {
    status(id);  // not_found for unknown ids
    bool canceled_queued = false;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        for (auto it = queue_.begin(); it != queue_.end(); ++it)
            if (it->id == id) {
                // The store first: if it refuses, the job stays queued in both.
                try {
                    if (store_->finish(id, JobState::canceled, unix_time_s(), "", "")) spdlog::info("job {} canceled while queued", id);
                } catch (const StoreError& e) {
                    throw store_refusal(e);
                }
                queue_.erase(it);
                canceled_queued = true;
                break;
            }
        failures_.erase(id);  // a canceled job is never run again
        auto r = running_.find(id);
        if (r != running_.end()) {
            r->second->cancel = true;
            r->second->stop = true;
            // A run that has recorded its pause looks at its marks no more: the job is paused
            // in the store, and this cancel ends it (the run, seeing the mark, does nothing more).
            try {
                if (cancel_if_paused(id)) {
                    spdlog::info("job {} canceled as its run paused", id);
                    canceled_queued = true;
                }
            } catch (const StoreError& e) {
                throw store_refusal(e);
            }
        } else if (!canceled_queued) {
            // Paused (or waiting): in neither the queue nor a worker. Its checkpoint goes with it.
            try {
                if (store_->finish(id, JobState::canceled, unix_time_s(), "", "")) {
                    spdlog::info("job {} canceled while paused", id);
                    remove_checkpoints(job_dir(id));
                    canceled_queued = true;
                }
            } catch (const StoreError& e) {
                throw store_refusal(e);
            }
        }
    }
    api::JobStatus st = status(id);
    if (canceled_queued) {
        publish("state", st);  // a running job's ends when its worker stops it
        notify(st);
        settle_waiting();      // jobs that run after it are canceled too
    }
    return st;
}

api::JobStatus LocalQueue::pause(const std::string& id) {
    const api::JobStatus before = status(id);  // not_found for unknown ids
    if (is_final(before.state)) throw job_finished(id, to_string(before.state), "paused");
    if (before.state == JobState::waiting) throw waiting_job(id);
    bool paused_queued = false;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        for (auto it = queue_.begin(); it != queue_.end(); ++it)
            if (it->id == id) {
                // The store first: if it refuses, the job stays queued in both.
                try {
                    if (store_->pause(id)) spdlog::info("job {} paused while queued", id);
                } catch (const StoreError& e) {
                    throw store_refusal(e);
                }
                queue_.erase(it);
                paused_queued = true;
                break;
            }
        auto r = running_.find(id);
        if (r != running_.end()) { r->second->pause = true; r->second->stop = true; }
    }
    api::JobStatus st = status(id);
    if (paused_queued) publish("state", st);  // a running job's pauses when its worker stops it
    return st;
}

api::JobStatus LocalQueue::resume(const std::string& id) {
    const api::JobStatus before = status(id);
    if (is_final(before.state)) throw job_finished(id, to_string(before.state), "resumed");
    bool resumed = false;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        // A running job asked to pause and not yet paused: its worker queues it again instead.
        auto r = running_.find(id);
        if (r != running_.end() && !r->second->cancel && !r->second->shutdown && r->second->pause) r->second->resume = true;
        try {
            // The record first (its place in the queue), then the change: a failed read changes nothing.
            const std::optional<JobRecord> rec = store_->get(id);
            if (rec && rec->state == JobState::paused && store_->resume(id)) {
                queue_.insert(QueueKey{rec->priority, rec->seq, id});
                resumed = true;
            }
        } catch (const StoreError& e) {
            throw store_refusal(e);
        }
    }
    if (resumed) {
        spdlog::info("job {} resumed: queued again", id);
        cv_.notify_one();
    }
    api::JobStatus st = status(id);
    if (resumed) publish("state", st);
    return st;
}

LogPage LocalQueue::job_log(const std::string& id, size_t from, size_t limit) {
    status(id);  // not_found for unknown ids
    return read_task_log((fs::path(job_dir(id)) / "log.jsonl").string(), from, limit, kMaxLogPageBytes, &log_index_);
}

std::map<int, size_t, std::greater<int>> LocalQueue::queued_by_priority() {
    std::lock_guard<std::mutex> lock(mutex_);
    std::map<int, size_t, std::greater<int>> by;
    for (const QueueKey& k : queue_) ++by[k.priority];
    return by;
}

size_t LocalQueue::queue_depth() {
    std::lock_guard<std::mutex> lock(mutex_);
    return queue_.size();
}

bool LocalQueue::take_next(JobRecord& rec, std::shared_ptr<Running>& running) {
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
            const double started = unix_time_s();
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

void LocalQueue::worker() {
    JobRecord rec;
    std::shared_ptr<Running> running;
    while (take_next(rec, running)) {
        publish("state", running_status(*running));
        try {
            run(rec, *running);
        } catch (const std::exception& e) {
            spdlog::error("job {}: {}", rec.id, loggable(e.what(), 2000));  // run() records every outcome; this only keeps the worker alive
        } catch (...) {
            spdlog::error("job {}: unknown exception", rec.id);
        }
        {
            std::lock_guard<std::mutex> lock(mutex_);
            // Only this run's entry: a job queued again by a pause taken back may run on another
            // worker already.
            if (auto it = running_.find(rec.id); it != running_.end() && it->second == running) running_.erase(it);
        }
        publish_state(rec.id);  // finished, failed, canceled, or queued again by a shutdown
        settle_waiting();       // jobs that run after it
        running.reset();
        release_free_memory();  // the job's film, images and a scene the cache did not keep
    }
}

bool LocalQueue::cancel_if_paused(const std::string& id) {
    const std::optional<JobRecord> now = store_->get(id);
    if (!now || now->state != JobState::paused || !store_->finish(id, JobState::canceled, unix_time_s(), "", "")) return false;
    remove_checkpoints(job_dir(id));
    return true;
}

void LocalQueue::cancel_stopped(const std::string& id) {
    bool canceled = false;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        try {
            canceled = cancel_if_paused(id);
        } catch (const std::exception& e) {
            spdlog::error("job {}: cannot cancel it as its run paused: {}", id, e.what());
        }
    }
    if (canceled) spdlog::info("job {} canceled as its run paused", id);
}

void LocalQueue::release_memory() {
    scenes_.drop_idle();
    JobQueue::release_memory();
}

bool LocalQueue::until_stored(const std::string& id, const char* what, const std::function<void()>& change) {
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

// The job's scene: a file's entry, or a built-in's with its parameters (builtin:NAME?params).
CatalogEntry LocalQueue::scene_entry(const std::string& scene) {
    auto entry = catalog_.find(scene.substr(0, scene.find('?')));
    if (!entry) throw std::runtime_error("scene '" + scene + "' is no longer in the catalog");
    if (entry->source == "builtin") entry->path = entry->shown = scene;
    return *entry;
}

void LocalQueue::run(const JobRecord& rec, Running& running) {
    std::string error;
    bool input_error = false;
    api::JobOutcome outcome;
    // The job's log: this run as one task (a shot's frames each a task of their own), with what
    // the server logged meanwhile.
    const std::string log_path = (fs::path(job_dir(rec.id)) / "log.jsonl").string();
    TaskRecord task;
    task.task = "render";
    task.node = "local";
    task.start = unix_time_s();
    task.attempt = rec.attempts;
    std::optional<TaskLogCapture> capture(std::in_place, task);
    // Written before the job's state changes: a job seen finished has its whole log.
    auto log_task = [&](const char* how) {
        capture.reset();
        std::error_code ec;
        fs::create_directories(job_dir(rec.id), ec);  // a job that failed before it had a folder
        task.end = unix_time_s();
        task.outcome = how;
        task.lines.push_back(std::string(error.empty() ? "info: " : "error: ") + "job " + how +
                             (error.empty() ? "" : ": " + loggable(error, 2000)) + " after " +
                             std::to_string(task.end - task.start) + " s");
        if (!error.empty()) task.errors.push_back(error);
        append_task_record(log_path, task);
    };
    spdlog::info("job {} running (attempt {})", rec.id, rec.attempts);
    try {
        const api::Job job = api::job_from_json(json::parse(rec.spec_json));
        if (std::holds_alternative<api::ComparisonJob>(job)) task.task = "comparison";
        else if (std::get<api::RenderJob>(job).frames) task.task = "shot";
        api::RunOptions opt;
        const CatalogEntry scene = scene_entry(api::scene_of(job));
        opt.scene_source = scene.path;
        opt.scene_name = scene.shown;
        opt.load_limits = config_.load_limits;
        opt.threads = config_.render_threads;
        opt.job_id = rec.id;
        opt.resume_frames = true;  // a shot queued again after a shutdown keeps its written frames
        opt.checkpoint_seconds = config_.checkpoint_s;  // and a render its samples
        opt.prepare = [this](const std::string& source, const std::string& name, const RenderSceneOptions& options) {
            return scenes_.get_local(source, name, options);
        };
        if (const auto* r = std::get_if<api::RenderJob>(&job)) {
            running.max_spp = r->render.spp;
            if (r->frames) {
                std::lock_guard<std::mutex> lock(running.pass_mutex);
                running.shot = api::ShotProgress{};
                running.shot->frames = r->frames->frames();
                running.shot->running = true;
            }
            if (!r->reference.empty()) opt.reference_image = job_image_exr(config_.data_dir, r->reference).string();
            if (!r->environment.empty()) {
                const auto env = catalog_.find_environment(r->environment);
                if (!env) throw std::runtime_error("environment map '" + r->environment + "' is no longer in the scene folders");
                opt.environment_file = env->path;
                opt.environment_name = env->shown;
            }
        }
        const std::string dir = job_dir(rec.id);
        fs::create_directories(dir);
        api::RunCallbacks cb;
        cb.stop = &running.stop;
        cb.discard = &running.cancel;
        cb.progress = [&](const RenderProgress& p) {
            running.tiles_done = p.tiles_done;
            running.tiles_total = p.tiles_total;
            running.samples = p.samples_done;
            // At most four progress events a second: one render thread claims each slot.
            const int64_t now = std::chrono::steady_clock::now().time_since_epoch().count();
            int64_t last = running.progress_event_ns.load();
            if (now - last >= 250'000'000 && running.progress_event_ns.compare_exchange_strong(last, now))
                publish("progress", running_status(running));
        };
        cb.pass = [&](const api::PassSnapshot& snap) {
            api::PassSummary ps{snap.index, snap.spp, snap.point.spp_mean, snap.point.seconds, snap.point.est_rel_mse,
                                snap.point.rel_mse, snap.point.denoised_est_rel_mse};
            {
                std::lock_guard<std::mutex> lock(running.pass_mutex);
                running.pass = ps;
                running.pass_image = snap.image;
                running.pass_denoised = snap.denoised;
            }
            publish("pass", running_status(running), &ps);
        };
        cb.frame = [&](const api::FrameDone& f) {
            if (f.kept) {  // written by an earlier run: logged and notified then
                std::lock_guard<std::mutex> lock(running.pass_mutex);
                if (running.shot) running.shot->frames_done = f.index + 1;
                return;
            }
            // The frame's task: what was logged since the last one.
            TaskRecord fr;
            fr.task = "frame";
            fr.frame = f.frame;
            fr.node = "local";
            fr.end = unix_time_s();
            fr.start = fr.end - f.seconds;
            fr.attempt = rec.attempts;
            fr.outcome = "done";
            std::swap(fr.lines, task.lines);
            std::swap(fr.warnings, task.warnings);
            std::swap(fr.errors, task.errors);
            append_task_record(log_path, fr);
            {
                std::lock_guard<std::mutex> lock(running.pass_mutex);
                if (running.shot) {
                    running.shot->frames_done = f.index + 1;
                    running.shot->frames_seconds += f.seconds;
                }
                running.pass.reset();  // the next frame's passes start afresh
                running.pass_image.reset();
                running.pass_denoised.reset();
            }
            const api::JobStatus frame_status = running_status(running);
            publish("frame", frame_status);
            notify(frame_status, "frame");
        };
        outcome = api::run_job(job, opt, api::RunOutputs::in_directory(dir), cb);
    } catch (const SceneError& e) {
        // Not final: a scene or map may fail to read for a while (a folder remounted, a file
        // being replaced); a bad one fails each run the same way, which the error then says.
        error = std::string("scene: ") + e.what();
    } catch (const api::InvalidJob& e) {
        error = e.what();
        input_error = true;
    } catch (const std::exception& e) {
        error = e.what();
    }
    {
        // From here the job's state becomes final: its images are its results, not a pass.
        std::lock_guard<std::mutex> lock(running.pass_mutex);
        running.pass.reset();
        running.pass_image.reset();
        running.pass_denoised.reset();
    }
    // A run that failed while a cancel, a pause or a shutdown was asked ends as that stop asks: it
    // is not a failure to run again.
    if (!error.empty() && !input_error) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (running.cancel || (running.pause && !running.resume) || running.shutdown) {
            error.clear();
            outcome.stopped = true;
        }
    }
    if (error.empty() && outcome.stopped) {
        // A cancel wins over a pause, and both over a shutdown (which would queue the job again).
        const bool pausing = running.pause && !running.resume;
        log_task(running.cancel ? "canceled" : pausing ? "paused" : "interrupted");
        if (running.cancel) {
            if (until_stored(rec.id, "canceled", [&] { store_->finish(rec.id, JobState::canceled, unix_time_s(), "", ""); })) {
                remove_checkpoints(job_dir(rec.id));
                spdlog::info("job {} canceled while running", rec.id);
            }
        } else if (pausing) {
            if (until_stored(rec.id, "paused", [&] { store_->pause(rec.id); }))
                spdlog::info("job {} paused; its film is kept in its checkpoint", rec.id);
            // A cancel or a resume that came while it was being paused (the store said
            // "running" then, so they only marked the run): now. A cancel that comes after this
            // look finds the job paused in the store and ends it itself.
            bool again = false, canceled = false;
            {
                std::lock_guard<std::mutex> lock(mutex_);
                canceled = running.cancel;
                again = running.resume && !canceled;
            }
            if (canceled) cancel_stopped(rec.id);
            else if (again) resume(rec.id);
        } else if (until_stored(rec.id, "queued again", [&] { store_->requeue(rec.id); })) {
            if (running.shutdown) {
                spdlog::warn("job {} interrupted by shutdown; queued again", rec.id);
            } else {  // a pause taken back after the render had seen it: it continues from its checkpoint
                std::lock_guard<std::mutex> lock(mutex_);
                queue_.insert(QueueKey{rec.priority, rec.seq, rec.id});
                cv_.notify_one();
            }
        }
        return;
    }
    if (!error.empty() && !input_error) {
        // Not the job's input: run it again (from its checkpoint) up to its max_retries.
        int max_retries = api::TaskPolicy{}.max_retries;
        try {
            max_retries = api::task_policy_of(api::job_from_json(json::parse(rec.spec_json))).max_retries;
        } catch (const std::exception&) {
        }
        std::vector<std::string> reasons;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            failures_[rec.id].push_back(error);
            reasons = failures_[rec.id];
            if (int(reasons.size()) > max_retries) failures_.erase(rec.id);
        }
        if (int(reasons.size()) <= max_retries) {
            log_task("failed");
            if (until_stored(rec.id, "queued again", [&] { store_->requeue(rec.id); })) {
                spdlog::warn("job {} failed (run {} of at most {}), queued again: {}", rec.id, reasons.size(), max_retries + 1,
                             loggable(error, 2000));
                // The stops asked meanwhile, seen under the lock that a cancel takes: one that came
                // before finds the job here, one that comes after finds it in the queue.
                bool canceled = false, paused = false;
                {
                    std::lock_guard<std::mutex> lock(mutex_);
                    canceled = running.cancel;
                    paused = running.pause && !running.resume;
                    if (!canceled && !paused && !running.shutdown) {
                        queue_.insert(QueueKey{rec.priority, rec.seq, rec.id});
                        cv_.notify_one();
                    }
                    if (canceled) failures_.erase(rec.id);
                }
                if (canceled && until_stored(rec.id, "canceled", [&] { store_->finish(rec.id, JobState::canceled, unix_time_s(), "", ""); }))
                    remove_checkpoints(job_dir(rec.id));
                else if (paused && until_stored(rec.id, "paused", [&] { store_->pause(rec.id); })) {
                    bool late = false;  // a cancel that only marked the run while the pause was recorded
                    {
                        std::lock_guard<std::mutex> lock(mutex_);
                        late = running.cancel;
                    }
                    if (late) cancel_stopped(rec.id);
                }
                // A shutdown leaves it queued: the next start runs it.
            }
            return;
        }
        if (reasons.size() > 1) {
            // The last reason first (what a reader greps for), then the earlier runs' where they differ.
            std::string earlier;
            for (size_t i = 0; i + 1 < reasons.size(); ++i)
                if (reasons[i] != reasons.back()) earlier += "; run " + std::to_string(i + 1) + ": " + reasons[i];
            error += " (failed " + std::to_string(reasons.size()) + " times, more than the job's max_retries (" + std::to_string(max_retries) +
                     ")" + (earlier.empty() ? ", each time so" : earlier) + ")";
        }
    }
    if (!error.empty()) {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            failures_.erase(rec.id);
        }
        log_task("failed");
        remove_checkpoints(job_dir(rec.id));
        if (until_stored(rec.id, "failed", [&] { store_->finish(rec.id, JobState::failed, unix_time_s(), error, ""); }))
            spdlog::error("job {} failed: {}", rec.id, loggable(error, 2000));
        return;
    }
    if (outcome.render) {
        metrics_.rays += outcome.render->stats.rays();
        metrics_.render_micros += uint64_t(outcome.render->stats.render_seconds * 1e6);
    }
    if (outcome.render) task.warnings.insert(task.warnings.end(), outcome.render->scene_build.warnings.begin(), outcome.render->scene_build.warnings.end());
    {
        std::lock_guard<std::mutex> lock(mutex_);
        failures_.erase(rec.id);
    }
    log_task("done");
    const std::string summary = json_text(outcome.summary);
    if (until_stored(rec.id, "succeeded", [&] { store_->finish(rec.id, JobState::succeeded, unix_time_s(), "", summary); }))
        spdlog::info("job {} succeeded in {:.3f} s", rec.id, outcome.render ? outcome.render->timings.total_s : 0.0);
}

std::optional<LivePass> LocalQueue::live_pass(const std::string& id) {
    std::shared_ptr<Running> r;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        auto it = running_.find(id);
        if (it == running_.end()) return std::nullopt;
        r = it->second;
    }
    std::lock_guard<std::mutex> lock(r->pass_mutex);
    if (!r->pass || !r->pass_image) return std::nullopt;
    return LivePass{*r->pass, r->pass_image, r->pass_denoised, r->max_spp};
}

}  // namespace tessera::server
