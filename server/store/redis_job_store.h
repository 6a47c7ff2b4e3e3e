#pragma once
// The job store of a render farm: every record in Redis, so any API node answers for any job.
// A job is a hash (tessera:job:<id>); sorted sets keep submission order overall and per state,
// and run order for the queued ones. Each change is one Lua script, atomic in Redis. Queuing a
// job also adds its first task ("start") to the stream of its priority (cluster_keys.h), in the
// same script, so an accepted job can never be recorded without being scheduled.
// Durability is Redis's: see docs/scaling.md (AOF, appendfsync everysec).
#include <memory>
#include <mutex>

#include "server/store/job_store.h"
#include "server/store/redis_client.h"
#include "server/store/scene_ref.h"

namespace tessera::server {

class RedisJobStore final : public JobStore {
public:
    // Connects and checks that Redis answers; throws StoreError.
    explicit RedisJobStore(const RedisUrl& url, int64_t max_bytes = 0);
    ~RedisJobStore() override;

    void insert(JobRecord& rec) override;
    std::optional<JobRecord> get(const std::string& id) const override;
    std::vector<JobRecord> list(std::optional<JobState> state, size_t offset, size_t limit) const override;
    size_t count(std::optional<JobState> state) const override;
    bool mark_running(const std::string& id, double started_at) override;
    bool finish(const std::string& id, JobState state, double finished_at, const std::string& error,
                const std::string& report_json) override;
    bool pause(const std::string& id) override;
    bool resume(const std::string& id) override;
    bool release(const std::string& id) override;
    // The job's task log (keys::task_log) from its `from`th line on: at most `limit` lines and
    // about `bytes` bytes (one line at least), and the number of the first (past lines dropped).
    struct LogLines {
        size_t first = 0;
        std::vector<std::string> lines;
    };
    LogLines task_log(const std::string& id, size_t from, size_t limit, size_t bytes) const;
    void append_task_log(const std::string& id, const std::string& line);
    // Whether this call is the first to claim `what` (SET NX, kept a week): one API node of
    // many does a thing once.
    bool claim_once(const std::string& what);
    // Queued jobs per priority, from the run order's scores (keys::queue_score).
    std::vector<std::pair<int, size_t>> queued_by_priority() const;
    // Per priority stream: entries no node has read (XINFO GROUPS' lag) and read, not acknowledged.
    struct StreamBacklog {
        int priority = 0;
        long long lag = -1, pending = 0;  // lag -1: Redis cannot tell (entries deleted)
    };
    std::vector<StreamBacklog> task_backlog() const;
    bool requeue(const std::string& id) override;
    int requeue_all_running() override;
    std::vector<JobRecord> queued_in_order() const override;
    bool remove_final(const std::string& id) override;
    void set_max_bytes(int64_t max_bytes) override;

    // The position of a queued job in run order (0: next), or -1.
    long long queue_position(const std::string& id) const;
    // The newest `limit` job ids in a state (or of all jobs), without their records: what a
    // watcher compares look to look.
    std::vector<std::string> ids(std::optional<JobState> state, size_t limit) const;

    // Farm side. Publishes what a job's scene is (and the file's bytes, once per content) before
    // the job is queued, so render nodes load exactly the bytes the job named.
    void put_scene(const std::string& job_id, const SceneRef& ref, const std::string* bytes);
    // The job's environment map: its bytes under its content hash, and the job's reference to it.
    void put_environment(const std::string& job_id, const SceneRef& ref, const std::string& bytes);
    struct LiveProgress {
        size_t tiles_done = 0, tiles_total = 0;
        uint64_t samples = 0;
        int pass = 0;
    };
    // A running job's progress across all nodes (tiles of the current pass, samples overall).
    std::optional<LiveProgress> live_progress(const std::string& id) const;
    // The failures of a job's tasks (keys::failures), or none when no task failed.
    std::optional<api::TaskFailures> task_failures(const std::string& id) const;
    // Removes the lanes of required tags no unfinished job uses (lua::prune_lanes); how many.
    long long prune_lanes();
    // The job's lane (cluster_keys.h); "" for a job not stored.
    std::string lane(const std::string& id) const;
    // The render nodes' last heartbeats: name → their metrics (JSON text).
    std::vector<std::pair<std::string, std::string>> nodes() const;

private:
    template <class Fn>
    auto locked(const char* op, Fn&& fn) const;
    std::vector<JobRecord> records(const std::vector<std::string>& ids) const;

    mutable std::mutex mu_;
    mutable Redis redis_;
    int64_t max_bytes_ = 0;
};

}  // namespace tessera::server
