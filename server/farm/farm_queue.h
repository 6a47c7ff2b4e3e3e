#pragma once
// A render farm's API node as a job queue: records, queue and tiles in Redis (RedisJobStore),
// rendered by render nodes, maybe one in this process (`serve --redis … --render`). Submitting
// publishes the job's scene and environment map bytes to Redis, so nodes need not share the
// catalog's folders. It renders nothing itself: it turns what it sees change in Redis into
// events while someone listens.
#include <chrono>
#include <condition_variable>
#include <map>
#include <mutex>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "server/farm/farm_nodes.h"
#include "server/farm/render_node.h"
#include "server/queue/job_queue.h"
#include "server/store/redis_job_store.h"

namespace tessera::server {

// What `serve` configures: the queue, and where its farm is.
struct ServiceConfig : QueueConfig {
    // A render farm: records, queue and tiles in Redis at this address (redis://…); "" is one
    // process with SQLite. With Redis, `render_locally` also runs a render node in this process
    // (`serve --render`), configured by `node`.
    std::string redis_url;
    bool render_locally = false;
    NodeConfig node;
};

// The queue `config` asks for: a FarmQueue with a Redis URL, else a LocalQueue.
std::unique_ptr<JobQueue> open_job_queue(const ServiceConfig& config);

class FarmQueue final : public JobQueue {
public:
    // Connects to Redis (throws StoreError when it does not answer) and starts the watcher and,
    // with render_locally, a render node.
    explicit FarmQueue(const ServiceConfig& config);
    ~FarmQueue() override;

    api::JobStatus cancel(const std::string& id) override;
    // A render job's (a still's): its nodes drop its tasks; resumed, the tiles of its pass not
    // yet stored are queued again (RedisJobStore::resume). A shot or a comparison: 409, so far.
    api::JobStatus pause(const std::string& id) override;
    api::JobStatus resume(const std::string& id) override;
    // The nodes' records in Redis (RenderNode keeps the newest keys::max_task_records).
    LogPage job_log(const std::string& id, size_t from, size_t limit) override;
    void record_task(const std::string& job, const TaskRecord& task) override;
    bool claim_notification(const std::string& id, const std::string& event) override;
    void shutdown() override;
    size_t queue_depth() override;
    std::map<int, size_t, std::greater<int>> queued_by_priority() override;
    std::vector<TaskBacklog> task_backlog() override;
    SceneCacheCounts scene_cache_counts() const override;
    void release_memory() override;
    std::vector<std::pair<std::string, std::string>> render_nodes() override;
    nlohmann::json node_report() override;

private:
    api::JobStatus enqueue(const api::Job& job, JobRecord rec) override;
    void add_live(api::JobStatus& st, const JobRecord& rec, bool locked) override;
    std::string store_unreachable() override;

    void publish_scene(const std::string& id, const std::string& scene);
    void publish_environment(const std::string& id, const std::string& name);
    // Each job as one look saw it: queued, running (with its samples) or other.
    enum class Seen { queued, running, other };
    using Look = std::map<std::string, std::pair<Seen, uint64_t>>;
    Look look();
    // `first`: the first look, taken before the server answers anyone, so that a job submitted
    // as soon as it listens is new to the watcher (none: Redis did not answer then).
    void watch(std::optional<Look> first);

    // The farm's nodes, read at most once a second (a list of jobs asks for each one's placement).
    std::vector<FarmNode> farm_nodes();
    std::mutex nodes_mutex_;
    std::vector<FarmNode> nodes_;
    std::chrono::steady_clock::time_point nodes_read_{};
    std::chrono::steady_clock::time_point lanes_pruned_{};  // the watcher's last prune_lanes

    RedisJobStore* redis_ = nullptr;   // store_
    std::unique_ptr<RenderNode> node_;  // serve --redis … --render
    std::mutex stop_mutex_;
    std::condition_variable stop_cv_;
    bool stopping_ = false;
    std::thread watcher_;
};

}  // namespace tessera::server
