#pragma once
// A render node of a farm: takes tasks from the Redis streams (highest priority first), renders
// them and stores what they produce, with no HTTP of its own. Three kinds of task:
//   start     a queued job: load its scene, mark it running, queue the tiles of its first pass
//             (a comparison job runs whole on the node that takes it);
//   tile      one tile of one pass: read its film, render the pass, store the film, and queue
//             `assemble` when it was the pass's last tile;
//   assemble  a pass is complete: measure the error, then queue the next pass or write the
//             image, rate map, EXR and report to the shared results directory and finish.
// Delivery is at least once: a task is acknowledged after its result is stored; a task whose
// node went silent past the visibility timeout is claimed by another node (a node renews the
// claims it holds while it works); a task delivered more than `max_deliveries` times fails its
// job with that reason. A task that fails on a node is queued again for another (the job's
// max_retries), a node that fails blocklist_after of a job's tasks takes no more of them, and a
// node reads only the lanes whose tags it has (cluster_keys.h). Every store checks the job's state and pass, so a late duplicate
// changes nothing, and a tile rendered twice is the same tile (per-pixel random streams).
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "engine/io/scene_loader.h"
#include "server/store/redis_client.h"

namespace tessera::server {

struct NodeConfig {
    RedisUrl redis;
    std::string data_dir = "./data";  // the results directory every node and API node shares
    std::string name;                 // "" → <hostname>-<pid>
    int threads = 1;                  // tiles rendered at once, one per thread
    int visibility_ms = 10000;        // silence after which another node takes a task over
    int max_deliveries = 5;
    std::vector<std::string> tags;   // what the node offers to jobs' `requires` (sorted)
    double checkpoint_s = 30;        // a shot's frame in hand is checkpointed this often (and when stopped)
    int64_t scene_cache_mb = 2048;   // prepared scenes kept between tiles and jobs
    double scene_cache_idle_s = 30;  // and dropped after this long unused
    LoadLimits load_limits;
};

struct NodeMetrics {
    std::atomic<uint64_t> tiles{0}, assemblies{0}, starts{0}, duplicates{0}, reclaimed{0}, redis_errors{0};
    std::atomic<uint64_t> frames{0};  // a shot's frames rendered here (not those kept from an earlier run)
    std::atomic<uint64_t> shot_opens{0};  // a shot's scene file opened here (once per shot, kept across its chunks)
    std::atomic<uint64_t> rays{0}, render_micros{0};
    std::atomic<uint64_t> failed_tasks{0}, passed_on{0};  // tasks that failed here; handed to other nodes
};

class RenderNode {
public:
    explicit RenderNode(NodeConfig config);
    ~RenderNode();  // stop()
    // Starts the worker threads and the heartbeat.
    void start();
    // Stops taking tasks; a task in hand is handed back (made claimable at once), and the
    // threads are joined.
    void stop();
    const std::string& name() const;
    NodeMetrics& metrics();
    // Drops prepared scenes unused for the cache's idle time (called every few seconds).
    void drop_idle_scenes();
    // Jobs' tiles that found their scene prepared, and those that prepared it.
    uint64_t scene_cache_hits() const;
    uint64_t scene_cache_misses() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace tessera::server
