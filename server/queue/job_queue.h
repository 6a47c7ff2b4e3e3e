#pragma once
// The job queue as the HTTP layer sees it, one interface for both kinds: one process's queue and
// workers (LocalQueue, local_queue.h) and a render farm's API node over Redis (FarmQueue,
// server/farm/farm_queue.h). It takes JSON bodies, answers with api/ types and refuses with
// QueueError; it knows nothing of HTTP.
//
// What both share lives here: a submission's checks (the typed job, its scene, environment map
// and reference), the record it becomes, reads of records, results on disk, events and the
// store's health. The kinds differ only in how a job is queued, run, canceled and shown live.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "api/job.h"
#include "api/job_status.h"
#include "engine/scene/scene_description.h"
#include "engine/render/image.h"
#include "server/queue/job_events.h"
#include "server/queue/notifier.h"
#include "server/queue/queue_error.h"
#include "server/queue/scene_catalog.h"
#include "server/queue/task_log.h"
#include "server/store/job_store.h"

namespace tessera::server {

struct QueueConfig {
    std::string data_dir = "./data";
    std::string project_scenes;            // our scenes/ folder
    std::vector<std::string> scene_dirs;   // --scenes
    int render_threads = 0;                // 0: all cores
    int64_t max_store_bytes = 0;           // the job store's size bound (0: none)
    int concurrent_jobs = 1;
    std::vector<std::string> tags;         // one process's node tags (--tags): a job requiring others is refused
    size_t max_queued = 1000;
    api::JobLimits job_limits;
    LoadLimits load_limits;
    int64_t scene_cache_mb = 2048;   // prepared scenes kept between jobs
    double scene_cache_idle_s = 30;  // and dropped after this long unused
    // A running job's film is written to its folder this often (seconds of rendering; 0: only
    // when it is stopped): after a crash, kill -9 or a restart it continues from there.
    double checkpoint_s = 30;
    NotifyPolicy notify;  // --notify-secret, --notify-allow (notifier.h)
};

struct QueueMetrics {
    std::atomic<uint64_t> rays{0};
    std::atomic<uint64_t> render_micros{0};
    std::atomic<uint64_t> jobs_submitted{0};
    std::atomic<uint64_t> store_errors{0};
};

// One page of GET /v1/jobs.
struct JobList {
    std::vector<api::JobStatus> jobs;
    size_t total = 0, offset = 0, limit = 0;
};
nlohmann::json to_json(const JobList& list);

// A running job's latest finished pass (its image and error), rendered in this process.
struct LivePass {
    api::PassSummary pass;
    std::shared_ptr<const Image> image;
    std::shared_ptr<const Image> denoised;  // a denoising job's, from the 4-spp pass on
    int max_spp = 0;  // the job's spp: the rate map's scale
};

struct SceneCacheCounts {
    uint64_t hits = 0, misses = 0;
};

class JobQueue {
public:
    virtual ~JobQueue();
    JobQueue(const JobQueue&) = delete;
    JobQueue& operator=(const JobQueue&) = delete;

    // Validates and stores a job, then queues it; returns its status. Throws QueueError.
    api::JobStatus submit(const nlohmann::json& body);
    // An equal-time comparison of sampling configurations (one job; results: report.json with
    // the table, convergence.svg with a curve per configuration). Throws QueueError.
    api::JobStatus submit_comparison(const nlohmann::json& body);
    api::JobStatus status(const std::string& id);  // throws QueueError not_found
    // `state`: "" for every state; throws QueueError invalid for an unknown one.
    JobList list(const std::string& state, size_t offset, size_t limit);
    // Idempotent; throws QueueError not_found.
    virtual api::JobStatus cancel(const std::string& id) = 0;
    // A queued job leaves the queue; a running one stops before its next tile, keeping its film
    // (a checkpoint), and frees its render threads. Idempotent for a paused job; throws
    // QueueError not_found, or conflict for a finished one.
    virtual api::JobStatus pause(const std::string& id) = 0;
    // A paused job is queued again in its place and continues from its checkpoint, to the image
    // it would have had never paused. Idempotent for a queued or running job; conflict for a
    // finished one.
    virtual api::JobStatus resume(const std::string& id) = 0;
    // A page of the job's log (task_log.h) as JSON lines, from its `from`th task on, at most
    // `limit` of them; throws not_found.
    virtual LogPage job_log(const std::string& id, size_t from, size_t limit) = 0;
    // Jobs waiting for others (`after`): queued once every one has succeeded; failed or
    // canceled, naming it, once one has failed or been canceled. Called wherever a job may have
    // ended, and at start; a store read when none waits. Thread-safe; call it holding no lock
    // of the kind's.
    void settle_waiting();
    void delete_results(const std::string& id);  // throws QueueError not_found / conflict
    // The path of a finished job's result file ("image.png", ...); throws QueueError
    // not_found / conflict / gone.
    std::string result_path(const std::string& id, const std::string& file);
    // A shot's frame result, as soon as that frame is written (the job may still run).
    std::string frame_result_path(const std::string& id, int frame, const std::string& file);
    // A running job's latest finished pass when this process renders it; nothing for other
    // jobs, before the first pass, and in a farm (no one process holds it).
    virtual std::optional<LivePass> live_pass(const std::string& id) { (void)id; return std::nullopt; }
    // What GET /v1/events streams: job created, state changed, progress, pass finished.
    JobEvents& events() { return events_; }

    // Stops accepting jobs; running renders are interrupted and their jobs re-queued in the
    // store (they run again after a restart). Blocks until the workers have stopped.
    virtual void shutdown() = 0;
    bool accepting() const { return accepting_; }
    // Why a new job would be refused now: shutting down, the store away, or the store refusing
    // writes (for 10 s after a refusal); "" when jobs are accepted. What /readyz answers.
    std::string unready_reason();
    virtual size_t queue_depth() = 0;
    // Queued jobs by priority (what an autoscaler watches), highest first.
    virtual std::map<int, size_t, std::greater<int>> queued_by_priority() = 0;
    // A farm's task streams: per priority, the tasks no node has taken yet (lag) and those taken
    // and not yet done (pending), as KEDA's redis-streams scaler reads them; empty for one process.
    struct TaskBacklog {
        int priority = 0;
        long long lag = -1, pending = 0;  // lag -1: not known
    };
    virtual std::vector<TaskBacklog> task_backlog() { return {}; }
    std::map<std::string, size_t> counts_by_state();
    QueueMetrics& metrics() { return metrics_; }
    virtual SceneCacheCounts scene_cache_counts() const = 0;
    // Drops prepared scenes left idle and returns free memory to the system (every few seconds).
    virtual void release_memory();
    // A farm's render nodes and their last heartbeat's metrics (JSON text); empty for one process.
    virtual std::vector<std::pair<std::string, std::string>> render_nodes() { return {}; }
    // GET /v1/nodes: a farm's render nodes (FarmNode's JSON), failing ones flagged; one process: none.
    virtual nlohmann::json node_report() { return nlohmann::json::array(); }
    JobStore& store() { return *store_; }
    SceneCatalog& catalog() { return catalog_; }
    const QueueConfig& config() const { return config_; }

protected:
    // Creates the data directory (a read-only or full disk stops the start with its reason) and
    // the catalog; the kind opens its store.
    explicit JobQueue(QueueConfig config);

    // Queues a checked job's new record, durably before it returns; throws QueueError.
    virtual api::JobStatus enqueue(const api::Job& job, JobRecord rec) = 0;
    // What only the kind knows of a record: its place in the queue, a running job's progress
    // and latest pass. `locked`: the caller holds the kind's own lock (see LocalQueue).
    virtual void add_live(api::JobStatus& st, const JobRecord& rec, bool locked) = 0;
    // Starts the notifier when the server has a secret (the kind's constructor, last: its
    // record writes the kind's log); stop_notifier() in the kind's shutdown, first.
    void start_notifier(const std::string& node);
    void stop_notifier();
    // Puts a notification attempt in the job's log.
    virtual void record_task(const std::string& job, const TaskRecord& task) = 0;
    // Whether this process sends the job's `event` notification (a farm's API nodes: one of them).
    virtual bool claim_notification(const std::string& id, const std::string& event) { (void)id; (void)event; return true; }
    // Sends the job's notification for `event` (its final state when empty) if it asked for one.
    void notify(const api::JobStatus& st, const std::string& event = "");
    // A waiting job the store has just queued: the kind's own queue takes it (a farm's store
    // queued its start task already).
    virtual void released(const JobRecord& rec) { (void)rec; }
    // Whether the store answers, for readiness ("" when it does, or when the kind has nothing to ask).
    virtual std::string store_unreachable() { return ""; }

    api::JobStatus status_of(const JobRecord& rec, bool locked = false);
    // One event for every subscriber of /v1/events: the job's status, and a pass when given.
    // Logged, never thrown: render threads call it.
    void publish(const char* type, const api::JobStatus& status, const api::PassSummary* pass = nullptr);
    // The job's status as stored now, published (a state change); store errors are logged only.
    void publish_state(const std::string& id);
    // A write the store refused or took: readiness follows the last one.
    void store_refused(const std::string& why);
    void store_wrote();
    // A refused submission: counted, logged, and the refusal to answer with.
    QueueError refused_submission(const StoreError& e);
    void queued(const std::string& id, const api::Job& job, int priority);  // counts and logs an accepted job
    QueueError shutting_down() const;
    std::string job_dir(const std::string& id) const;

    QueueConfig config_;
    std::unique_ptr<JobStore> store_;
    SceneCatalog catalog_;
    QueueMetrics metrics_;
    JobEvents events_;
    std::atomic<bool> accepting_{true};

private:
    api::JobStatus accept(const api::Job& job);
    void check_render_job(const api::RenderJob& job);

    std::mutex store_health_mutex_;
    std::chrono::steady_clock::time_point store_refused_at_;
    std::string store_refusal_;  // the last refused write's reason, "" once a write succeeded
    std::mutex settle_mutex_;    // one settle_waiting at a time (its events in order)
    std::unique_ptr<Notifier> notifier_;
};

// Now, in seconds since 1970: the records' times.
double unix_time_s();

// The record a job's status starts from (its settings as stored, the summary once finished).
api::JobStatus record_status(const JobRecord& rec);

}  // namespace tessera::server
