#pragma once
// The job queue and its workers, knowing nothing of HTTP: a job is parsed once into its typed
// value (api/job.h), stored durably as that value's JSON, then queued in memory (priority, then
// first come); workers run it through the job runner (api/job_runner.h), which writes the
// results under <data-dir>/jobs/<id>/. No exception leaves a worker: a job that cannot run
// fails with its reason, and a store that refuses a write (full disk, read-only file) is
// retried until it takes it, while submissions get 507 or 503.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "api/job.h"
#include "api/job_status.h"
#include "engine/render/image.h"
#include "server/queue/job_events.h"
#include "server/store/job_store.h"
#include "server/store/redis_job_store.h"
#include "server/farm/render_node.h"
#include "server/queue/scene_cache.h"
#include "server/queue/scene_catalog.h"

namespace tessera::server {

struct ServiceConfig {
    std::string data_dir = "./data";
    std::string project_scenes;            // our scenes/ folder
    std::vector<std::string> scene_dirs;   // --scenes
    int render_threads = 0;                // 0: all cores
    int64_t max_store_bytes = 0;           // the job store's size bound (0: none)
    int concurrent_jobs = 1;
    size_t max_queued = 1000;
    api::JobLimits job_limits;
    LoadLimits load_limits;
    // A render farm: records, queue and tiles in Redis at this address (redis://…); "" is one
    // process with SQLite. With Redis, `render_locally` also runs a render node in this process
    // (`serve --render`), configured by `node`.
    std::string redis_url;
    bool render_locally = false;
    NodeConfig node;
};

struct ServiceMetrics {
    std::atomic<uint64_t> rays{0};
    std::atomic<uint64_t> render_micros{0};
    std::atomic<uint64_t> jobs_submitted{0};
    std::atomic<uint64_t> store_errors{0};
};

class JobService {
public:
    explicit JobService(ServiceConfig config);  // opens the store, re-queues interrupted jobs, starts workers
    ~JobService();

    // Validates and stores a job; throws Problem. Returns its status.
    nlohmann::json submit(const nlohmann::json& body);
    // An equal-time comparison of sampling configurations (one job; results: report.json with
    // the table, convergence.svg with a curve per configuration). Throws Problem.
    nlohmann::json submit_comparison(const nlohmann::json& body);
    nlohmann::json status(const std::string& id);  // throws Problem 404
    nlohmann::json list(const std::string& state, size_t offset, size_t limit);
    nlohmann::json cancel(const std::string& id);  // idempotent; throws Problem 404
    void delete_results(const std::string& id);    // throws Problem 404 / 409
    // The path of a finished job's result file ("image.png", ...); throws Problem 404/409/410.
    std::string result_path(const std::string& id, const std::string& file);
    // A running job's latest finished pass (its image and error), rendered in this process;
    // nothing for other jobs, before the first pass, and in a farm (no one process holds it).
    struct LivePass {
        api::PassSummary pass;
        std::shared_ptr<const Image> image;
        int max_spp = 0;  // the job's spp: the rate map's scale
    };
    std::optional<LivePass> live_pass(const std::string& id);
    // What GET /v1/events streams: job created, state changed, progress, pass finished.
    JobEvents& events() { return events_; }

    // Stops accepting jobs; running renders are interrupted and their jobs re-queued in the
    // store (they run again after a restart). Blocks until the workers have stopped.
    void shutdown();
    bool accepting() const { return accepting_; }
    // Why a new job would be refused now: shutting down, Redis away, or the store refusing
    // writes (for 10 s after a refusal); "" when jobs are accepted. What /readyz answers.
    std::string unready_reason();
    size_t queue_depth();
    std::map<std::string, size_t> counts_by_state();
    ServiceMetrics& metrics() { return metrics_; }
    const SceneCache& scene_cache() const { return scenes_; }
    // Drops prepared scenes left idle and returns free memory to the system (every few seconds).
    void release_memory();
    JobStore& store() { return *store_; }
    bool farm() const { return redis_store_ != nullptr; }
    // A farm's render nodes and their last heartbeat's metrics (JSON text); empty for one process.
    std::vector<std::pair<std::string, std::string>> render_nodes();
    SceneCatalog& catalog() { return catalog_; }
    const ServiceConfig& config() const { return config_; }

private:
    struct Running {
        std::atomic<bool> stop{false};  // what the renderer checks between tiles; set with a reason below
        std::atomic<bool> cancel{false};
        std::atomic<bool> shutdown{false};
        std::atomic<size_t> tiles_done{0}, tiles_total{0};
        std::atomic<uint64_t> samples{0};
        JobRecord rec;                          // as it started: its status while it runs
        std::optional<api::Job> job;            // rec's, typed (its progress is api::job_progress)
        std::atomic<int64_t> progress_event_ns{0};  // when progress was last published
        std::mutex pass_mutex;
        std::optional<api::PassSummary> pass;   // the latest finished pass, and its image
        std::shared_ptr<const Image> pass_image;
        int max_spp = 0;
    };
    struct QueueKey {
        int priority;
        int64_t seq;
        std::string id;
        bool operator<(const QueueKey& o) const { return priority != o.priority ? priority > o.priority : seq < o.seq; }
    };

    void worker();
    // Takes the next queued job into `running_`; false when stopping.
    bool take_next(JobRecord& rec, std::shared_ptr<Running>& running);
    void run(const JobRecord& rec, Running& running);
    // Runs a store change until the store takes it (a full disk, a read-only file: retried
    // with back-off); false if the service stops first.
    bool until_stored(const std::string& id, const char* what, const std::function<void()>& change);
    nlohmann::json enqueue(const api::Job& job);
    // `locked`: the caller holds mutex_.
    nlohmann::json status_json(const JobRecord& rec, bool locked = false);
    nlohmann::json running_status_json(Running& running);
    // One event for every subscriber of /v1/events: the job's status, and a pass when given.
    void publish(const char* type, const nlohmann::json& status, const api::PassSummary* pass = nullptr);
    // The job's status as stored now, published (a state change); store errors are logged only.
    void publish_state(const std::string& id);
    // A farm's API node does not run the jobs: it turns changes it sees in the store into
    // events while someone listens. Each job as one look saw it: queued, running (with its
    // samples) or other.
    enum class FarmSeen { queued, running, other };
    using FarmLook = std::map<std::string, std::pair<FarmSeen, uint64_t>>;
    FarmLook look_at_farm();
    // `first`: the first look, taken before the server answers anyone, so that a job submitted
    // as soon as it listens is new to the watcher (none: Redis did not answer then).
    void watch_farm(std::optional<FarmLook> first);
    std::string job_dir(const std::string& id) const;
    void store_refused(const std::string& why);
    void store_wrote();
    std::string scene_source(const std::string& scene);
    void publish_scene(const std::string& id, const std::string& scene);
    void publish_environment(const std::string& id, const std::string& name);

    ServiceConfig config_;
    std::unique_ptr<JobStore> store_;
    RedisJobStore* redis_store_ = nullptr;  // store_, when it is Redis
    std::unique_ptr<RenderNode> node_;      // serve --redis … --render
    SceneCatalog catalog_;
    // Prepared scenes kept between this process's jobs (bounded by node.scene_cache_mb).
    SceneCache scenes_;
    ServiceMetrics metrics_;
    std::mutex mutex_;
    std::condition_variable cv_;        // a job was queued, or the service stops
    std::condition_variable pause_cv_;  // the service stops (ends a worker's pause before a retry)
    std::set<QueueKey> queue_;
    std::map<std::string, std::shared_ptr<Running>> running_;
    std::atomic<bool> accepting_{true};
    std::mutex store_health_mutex_;
    std::chrono::steady_clock::time_point store_refused_at_;
    std::string store_refusal_;  // the last refused write's reason, "" once a write succeeded
    bool stopping_ = false;
    std::vector<std::thread> workers_;
    JobEvents events_;
    std::thread farm_watch_;
};

}  // namespace tessera::server
