#pragma once
// A farm's render nodes as their heartbeats describe them (keys::nodes): which are live, the tags
// they offer, and the failures counted against them across jobs. The nodes read it to know who
// else can take a task; the API nodes to say where a job can run and which nodes fail.
#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace tessera::server {

struct FarmNode {
    std::string name;
    double last_seen = 0;  // unix seconds of its last heartbeat
    double beat_s = 0;     // its heartbeat period (a quarter of its --visibility-ms)
    int threads = 0;
    double busy = 0;
    std::vector<std::string> tags;  // sorted
    long long failed_tasks = 0;      // tasks it failed, every job's
    long long blocklisted_jobs = 0;  // jobs that take no more of its tasks
    nlohmann::json heartbeat;        // the whole record
};

// Heartbeats older than this are a node gone (stopped, killed, cut off); or than three of its
// periods, for a node whose --visibility-ms makes them rarer.
inline constexpr double kNodeLiveSeconds = 30;
// A node that this many jobs blocklisted is reported as failing (status, metrics, page).
inline constexpr long long kFailingNodeBlocklists = 2;

// Records that do not parse are skipped.
std::vector<FarmNode> parse_farm_nodes(const std::vector<std::pair<std::string, std::string>>& hash);
inline bool is_live(const FarmNode& n, double now_s) { return n.last_seen > now_s - std::max(kNodeLiveSeconds, 3 * n.beat_s); }
// Whether the node offers every tag of `required` (both sorted).
bool has_tags(const FarmNode& n, const std::vector<std::string>& required);
inline bool is_failing(const FarmNode& n) { return n.blocklisted_jobs >= kFailingNodeBlocklists; }
nlohmann::json to_json(const FarmNode& n, double now_s);

}  // namespace tessera::server
