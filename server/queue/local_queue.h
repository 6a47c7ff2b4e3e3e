#pragma once
// One process's job queue: records in SQLite, the queue in memory (priority, then first come),
// and workers that run each job through the job runner (api/job_runner.h), which writes the
// results under <data-dir>/jobs/<id>/. No exception leaves a worker: a job that cannot run
// fails with its reason, and a store that refuses a write (full disk, read-only file) is
// retried until it takes it, while submissions are refused as store_full or unavailable.
#include <atomic>
#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "server/queue/job_queue.h"
#include "server/queue/scene_cache.h"

namespace tessera::server {

class LocalQueue final : public JobQueue {
public:
    // Opens the store, re-queues jobs a stop interrupted, and starts the workers.
    explicit LocalQueue(QueueConfig config);
    ~LocalQueue() override;

    api::JobStatus cancel(const std::string& id) override;
    api::JobStatus pause(const std::string& id) override;
    api::JobStatus resume(const std::string& id) override;
    LogPage job_log(const std::string& id, size_t from, size_t limit) override;
    std::optional<LivePass> live_pass(const std::string& id) override;
    void shutdown() override;
    size_t queue_depth() override;
    std::map<int, size_t, std::greater<int>> queued_by_priority() override;
    SceneCacheCounts scene_cache_counts() const override { return {scenes_.hits(), scenes_.misses()}; }
    void release_memory() override;

private:
    struct Running {
        std::atomic<bool> stop{false};  // what the renderer checks between tiles; set with a reason below
        std::atomic<bool> cancel{false};
        std::atomic<bool> pause{false};
        // A resume asked while the pause takes effect: the job is queued again, not paused (the
        // stop, which the render may have acted on already, is never taken back).
        std::atomic<bool> resume{false};
        std::atomic<bool> shutdown{false};
        std::atomic<size_t> tiles_done{0}, tiles_total{0};
        std::atomic<uint64_t> samples{0};
        JobRecord rec;                          // as it started: its status while it runs
        std::optional<api::Job> job;            // rec's, typed (its progress is api::job_progress)
        std::atomic<int64_t> progress_event_ns{0};  // when progress was last published
        std::mutex pass_mutex;
        std::optional<api::PassSummary> pass;   // the latest finished pass, and its image
        std::shared_ptr<const Image> pass_image;
        std::shared_ptr<const Image> pass_denoised;  // a denoising job's latest denoised image
        int max_spp = 0;
        std::optional<api::ShotProgress> shot;  // a shot's frames (under pass_mutex)
    };
    struct QueueKey {
        int priority;
        int64_t seq;
        std::string id;
        bool operator<(const QueueKey& o) const { return priority != o.priority ? priority > o.priority : seq < o.seq; }
    };

    api::JobStatus enqueue(const api::Job& job, JobRecord rec) override;
    void released(const JobRecord& rec) override;
    void record_task(const std::string& job, const TaskRecord& task) override;
    void add_live(api::JobStatus& st, const JobRecord& rec, bool locked) override;

    void worker();
    // Takes the next queued job into `running_`; false when stopping.
    bool take_next(JobRecord& rec, std::shared_ptr<Running>& running);
    void run(const JobRecord& rec, Running& running);
    // A running job's status from what its worker holds: no store read and not the queue's
    // lock (which store writes hold), so render threads publishing progress never wait.
    api::JobStatus running_status(Running& running);
    // Runs a store change until the store takes it (a full disk, a read-only file: retried
    // with back-off); false if the queue stops first.
    bool until_stored(const std::string& id, const char* what, const std::function<void()>& change);
    // Cancels a job its run has just recorded as paused, for a cancel that only marked the run
    // (the store said "running" then); a job resumed or finished meanwhile is left as it is.
    void cancel_stopped(const std::string& id);
    // Ends as canceled, with its checkpoints, a job the store holds paused; false for any other
    // state. The caller holds mutex_; a store that refuses throws StoreError.
    bool cancel_if_paused(const std::string& id);
    CatalogEntry scene_entry(const std::string& scene);

    // Prepared scenes kept between jobs (bounded by scene_cache_mb).
    SceneCache scenes_;
    TaskLogIndex log_index_;  // where the pages of the jobs' logs start
    std::mutex mutex_;
    std::condition_variable cv_;        // a job was queued, or the queue stops
    std::condition_variable pause_cv_;  // the queue stops (ends a worker's pause before a retry)
    std::set<QueueKey> queue_;
    std::map<std::string, std::shared_ptr<Running>> running_;
    // Runs of a job that failed for a reason other than its input, with the reasons: the job is
    // queued again until they pass its max_retries (under mutex_; a restart forgets them).
    std::map<std::string, std::vector<std::string>> failures_;
    bool stopping_ = false;
    std::vector<std::thread> workers_;
};

}  // namespace tessera::server
