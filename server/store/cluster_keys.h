#pragma once
// The names of everything a render farm keeps in Redis, in one place: the job store, the task
// streams and the render nodes agree on them here.
#include <algorithm>
#include <string>
#include <vector>

namespace tessera::server::keys {

inline const std::string prefix = "tessera:";
inline std::string job(const std::string& id) { return prefix + "job:" + id; }
inline const std::string seq = prefix + "seq";
inline const std::string all_jobs = prefix + "jobs";  // zset seq → id
inline std::string jobs_in(const std::string& state) { return prefix + "jobs:" + state; }
inline const std::string queue = prefix + "queue";  // zset run order → id (queued jobs)
// Tasks: one stream per lane in use; `priorities` lists the lanes (score = priority). A lane is
// a priority, with the node tags its jobs require after a '|' ("5", "5|avx512,bigmem"): a node
// reads only the lanes whose tags it has, so no task waits behind a node that cannot take it.
inline const std::string priorities = prefix + "priorities";
inline std::string lane(long long priority, const std::vector<std::string>& tags) {
    std::string l = std::to_string(priority);
    for (size_t i = 0; i < tags.size(); ++i) l += (i ? "," : "|") + tags[i];
    return l;
}
// The tags a lane requires (sorted, as the job lists them).
inline std::vector<std::string> lane_tags(const std::string& lane) {
    std::vector<std::string> tags;
    const size_t bar = lane.find('|');
    if (bar == std::string::npos) return tags;
    for (size_t at = bar + 1; at <= lane.size();) {
        const size_t comma = std::min(lane.find(',', at), lane.size());
        if (comma > at) tags.push_back(lane.substr(at, comma - at));
        at = comma + 1;
    }
    return tags;
}
inline std::string lane_tasks(const std::string& lane) { return prefix + "tasks:" + lane; }
// Unfinished jobs per lane (hash lane → count), so that a lane none uses can go.
inline const std::string lane_jobs = prefix + "lanejobs";
// The most lanes of required tags at once: a job that would open another is refused (507).
inline constexpr long long max_tag_lanes = 256;
inline std::string tasks(long long priority) { return lane_tasks(std::to_string(priority)); }
inline const std::string group = "nodes";
// A render job's film, tile by tile: field t<i> the tile's encoded film, p<i> its pass.
inline std::string film(const std::string& id) { return prefix + "film:" + id; }
// A job rendered straight through (no stop rule needs the whole image between passes): each
// tile's error sums and reach times per pass target, for the convergence curve (field t<i>).
inline std::string sums(const std::string& id) { return prefix + "sums:" + id; }
// Deliveries of each task of a job (field: pass:tile), to fail a job whose task keeps dying.
inline std::string deliveries(const std::string& id) { return prefix + "deliveries:" + id; }
// Failures of a job's tasks (task:<kind>:<pass>:<tile> and node:<name> → count), their reasons
// (a list, a line each, oldest first) and the nodes that take no more of its tasks (a set).
inline std::string failures(const std::string& id) { return prefix + "failures:" + id; }
inline std::string failure_reasons(const std::string& id) { return prefix + "reasons:" + id; }
inline std::string blocklist(const std::string& id) { return prefix + "blocklist:" + id; }
inline constexpr long long max_failure_reasons = 50;
// Per node across jobs: tasks failed, and jobs that blocklisted it (hash name → count).
inline const std::string node_failed_tasks = prefix + "nodefailed";
inline const std::string node_blocklisted_jobs = prefix + "nodeblocked";
// Tiles and seconds per node for a job's report.
inline std::string node_tiles(const std::string& id) { return prefix + "nodetiles:" + id; }
inline std::string node_seconds(const std::string& id) { return prefix + "nodeseconds:" + id; }
// A job's convergence curve: one JSON point per pass.
inline std::string curve(const std::string& id) { return prefix + "curve:" + id; }
// The job's log, a task a line (JSON, server/queue/task_log.h), oldest first.
inline std::string task_log(const std::string& id) { return prefix + "log:" + id; }
inline constexpr long long max_task_records = 20000;  // kept per job, the oldest dropped first
// The lines ever appended to it: a line's index stays its own when the oldest are dropped.
inline std::string task_log_count(const std::string& id) { return prefix + "logcount:" + id; }
// What a job's scene is (SceneRef::encode), written by the API node before the job is queued.
inline std::string job_scene(const std::string& id) { return prefix + "jobscene:" + id; }
// A job's environment map, when it names one (SceneRef::encode of the .exr/.hdr file, whose
// bytes are kept under scene(hash) like a scene's), written with job_scene.
inline std::string job_environment(const std::string& id) { return prefix + "jobenv:" + id; }
// A shot spread over nodes: how many chunk tasks it has (set once, when they are queued), and
// the chunks written (a set of their first frame's index).
inline std::string shot_chunks(const std::string& id) { return prefix + "shotchunks:" + id; }
inline std::string shot_done(const std::string& id) { return prefix + "shotdone:" + id; }
// Scene files by content hash.
inline std::string scene(const std::string& hash) { return prefix + "scene:" + hash; }
// Live render nodes: hash name → JSON of its metrics, with a heartbeat time.
inline const std::string nodes = prefix + "nodes";

// Run order of queued jobs as one sorted-set score: priority descending, then seq ascending.
inline double queue_score(int priority, long long seq) { return double(1000 - priority) * 1e12 + double(seq); }

}  // namespace tessera::server::keys
