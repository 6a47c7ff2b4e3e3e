#include "server/farm/render_node.h"

#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <set>

#include <spdlog/spdlog.h>

#include "api/json_text.h"
#include "api/job.h"
#include "api/job_runner.h"
#include "api/report.h"
#include "engine/camera/camera.h"
#include "engine/core/block_pool.h"
#include "engine/core/scene_error.h"
#include "engine/io/image_io.h"
#include "engine/io/scene_loader.h"
#include "engine/render/passes.h"
#include "engine/render/tile_context.h"
#include "engine/scene/environment.h"
#include "server/store/cluster_keys.h"
#include "server/store/cluster_lua.h"
#include "server/farm/farm_nodes.h"
#include "server/farm/farm_records.h"
#include "engine/render/film_codec.h"
#include "server/farm/tile_image_codec.h"
#include "server/farm/shot_chunks.h"
#include "server/queue/task_log.h"
#include "server/store/job_results.h"
#include "server/queue/scene_cache.h"

namespace tessera::server {
using api::json_text;

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

using Clock = std::chrono::steady_clock;

thread_local bool t_dropped = false;  // this thread's task was dropped (RenderNode::Impl::dropped)
thread_local bool t_passed = false;   // this thread handed a task to other nodes since its last read

double now_s() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }
long long now_ms() {
    return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
}

struct Task {
    std::string stream, id, job, kind;
    int pass = 0, tile = 0;
    int attempt = 1;          // 1 + the times the task failed before
    std::string run = "0";    // a whole job's run (its resumes) the task belongs to (start, frames)
    std::string consumer;     // who holds its delivery here (this node's thread)
    std::string avoid;        // the nodes that failed it, comma-separated
    bool reclaimed = false;  // taken over from a silent node (not a first delivery)
    std::string key() const { return stream + " " + id; }
    // The lane its stream serves (cluster_keys.h).
    std::string lane() const { return stream.substr(std::min(stream.size(), keys::lane_tasks("").size())); }
    // What it is, for a reason a person reads.
    std::string what() const {
        if (kind == "tile") return "tile " + std::to_string(tile) + " of pass " + std::to_string(pass);
        if (kind == "assemble") return "the assembly of pass " + std::to_string(pass);
        if (kind == "frames") return "the chunk of " + std::to_string(tile) + " frames from frame index " + std::to_string(pass);
        return "the " + kind + " task";
    }
};

// An entry as XREADGROUP and XAUTOCLAIM return it: [id, [field, value, ...]].
std::optional<Task> parse_entry(const std::string& stream, const RedisValue& e) {
    if (e.items.size() < 2 || e.items[1].type != RedisValue::array) return std::nullopt;
    Task t;
    t.stream = stream;
    t.id = e.items[0].text;
    const auto& f = e.items[1].items;
    for (size_t i = 0; i + 1 < f.size(); i += 2) {
        const std::string& k = f[i].text;
        const std::string& v = f[i + 1].text;
        if (k == "job") t.job = v;
        else if (k == "kind") t.kind = v;
        else if (k == "pass") t.pass = std::atoi(v.c_str());
        else if (k == "tile") t.tile = std::atoi(v.c_str());
        else if (k == "attempt") t.attempt = std::max(1, std::atoi(v.c_str()));
        else if (k == "avoid") t.avoid = v;
        else if (k == "run") t.run = v;
    }
    return t;
}

const RedisScript kBegin{lua::begin_run};
// Made on first use, not at start-up: its text comes from another file's statics.
const RedisScript& commit_tile() {
    static const RedisScript script{commit_tile_script()};
    return script;
}
const RedisScript kAdvance{lua::advance_pass};
const RedisScript kComplete{lua::complete_run};
const RedisScript kTransition{lua::transition_job};
const RedisScript kRenew{lua::renew_claim};
const RedisScript kAddChunks{lua::add_chunks};
const RedisScript kChunkDone{lua::chunk_done};
const RedisScript kFailTask{lua::fail_task};
const RedisScript kPassOn{lua::pass_on};
const RedisScript kStrand{lua::strand_job};
const RedisScript kAppendLog{lua::append_log};

bool lists(const std::string& comma_separated, const std::string& name) {
    return (',' + comma_separated + ',').find(',' + name + ',') != std::string::npos;
}

// A job as a node runs it: parsed once per node (the stored job never changes).
struct JobInfo {
    api::Job job;
    SceneRef ref;
    RenderSettings settings;  // a render job's, as nodes render it
    // The pass driver's plan; a whole-tile plan (no stop rule needs the whole image between
    // passes) is rendered a tile per task through every target, without a barrier per pass.
    PassPlan plan;
    std::optional<Image> reference;
};

// A job the node cannot run (scene broken, reference gone): the job fails with this reason.
struct JobFailure : std::runtime_error {
    using std::runtime_error::runtime_error;
};

}  // namespace

// How much work one read of the streams takes (see fetch), and at most how many tasks.
constexpr double kBatchSeconds = 0.02;
constexpr int kMaxBatch = 32;

struct RenderNode::Impl {
    NodeConfig cfg;
    std::string name;
    NodeMetrics metrics;
    SceneCache cache;
    std::atomic<bool> stopping{false};
    std::vector<std::thread> threads;
    std::thread heartbeat;
    std::mutex mu;  // held, jobs
    std::condition_variable wake;
    struct Held {
        Task task;
        std::string consumer;
        std::shared_ptr<std::atomic<bool>> cancel;  // stop working on it (job canceled, taken over, node stops)
        std::shared_ptr<std::atomic<bool>> lost;    // another node claimed it: not ours to acknowledge
        std::shared_ptr<std::atomic<bool>> acked;   // done here: a failed renewal means nothing then
    };
    std::map<std::string, Held> held;
    std::map<std::string, std::shared_ptr<const JobInfo>> jobs;
    // The state of a job's run as a tile needs it. A state seen running at the task's pass in the
    // last 50 ms is taken as is (one round trip less per tile: the commit checks again); any
    // other answer is read afresh, so a stale cache never drops a task.
    struct SeenRun {
        FarmRun run;
        Clock::time_point read;
    };
    std::map<std::string, SeenRun> states;
    // The denoiser's maps, kept from one assembly to the next (block_pool.h): trimmed after
    // each to what it used, cleared after a job's last pass.
    BlockPool denoise_memory;
    // Jobs that blocklisted this node (it hands their tasks to others), and the farm's nodes as
    // last read (for a second each): who else could take a task.
    std::set<std::string> blocked_jobs;
    std::vector<FarmNode> peers;
    Clock::time_point peers_read{};

    explicit Impl(NodeConfig c)
        : cfg(std::move(c)),
          cache((fs::temp_directory_path() / ("tessera-node-" + std::to_string(::getpid()))).string(), cfg.scene_cache_mb << 20,
                cfg.load_limits, cfg.scene_cache_idle_s) {
        name = cfg.name;
        if (name.empty()) {
            char host[256] = {0};
            ::gethostname(host, sizeof host - 1);
            name = std::string(host) + "-" + std::to_string(::getpid());
        }
    }

    std::shared_ptr<const JobInfo> job_info(Redis& r, const std::string& id) {
        {
            std::lock_guard lock(mu);
            auto it = jobs.find(id);
            if (it != jobs.end()) return it->second;
        }
        const auto v = r.pipeline({{"HGET", keys::job(id), "spec"}, {"GET", keys::job_scene(id)}, {"GET", keys::job_environment(id)},
                                   {"SISMEMBER", keys::blocklist(id), name}});
        if (v[0].is_nil()) return nullptr;
        if (v[3].as_int() == 1) {  // blocklisted by an earlier run of this node (the same name)
            std::lock_guard lock(mu);
            blocked_jobs.insert(id);
        }
        auto info = std::make_shared<JobInfo>();
        try {
            info->job = api::job_from_json(json::parse(v[0].text));
        } catch (const api::InvalidJob& e) {
            // Not the job's fault but this node's: an API node newer than it wrote a field it does
            // not know. Retried, and another node may read it (an InvalidJob fails the job at once).
            throw std::runtime_error(std::string("this node cannot read the job (an older version?): ") + e.what());
        }
        if (!v[1].is_nil()) info->ref = SceneRef::decode(v[1].text);
        else info->ref.source = api::scene_of(info->job);  // built-in scenes need no file
        if (const auto* rj = std::get_if<api::RenderJob>(&info->job)) {
            info->settings = rj->render;
            info->settings.threads = 1;
            info->settings.estimate_error = true;  // as the server's runner: the error curve is reported
            // The environment map the API node published; a file that does not load fails the job.
            if (!rj->environment.empty()) {
                if (v[2].is_nil()) throw JobFailure("the job's environment map '" + rj->environment + "' is missing from Redis");
                const SceneRef env = SceneRef::decode(v[2].text);
                // Named by its place in the API node's catalog, as one process's report names it.
                info->settings.environment = api::load_environment(cache.file_for(r, env), env.shown());
            }
            if (!rj->reference.empty()) {
                const fs::path ref = job_image_exr(cfg.data_dir, rj->reference);
                if (!fs::exists(ref)) throw JobFailure("the reference job's image was deleted");
                info->reference = read_image(ref.string());
            }
            info->plan = plan_passes(info->settings, info->reference.has_value(), false);
        }
        std::lock_guard lock(mu);
        if (jobs.size() > 256) jobs.clear();
        jobs[id] = info;
        return info;
    }

    void ack(Redis& r, const Task& t) {
        // Deleted once acknowledged: the streams hold only work not yet done.
        r.pipeline({{"XACK", t.stream, keys::group, t.id}, {"XDEL", t.stream, t.id}});
    }

    void fail_job(Redis& r, const std::string& id, const std::string& why) {
        if (r.eval(kTransition, {}, {keys::prefix, id, "failed", "queued,running", redis_number(now_s()), why, ""}).as_int() == 1)
            spdlog::error("node {}: job {} failed: {}", name, id, why);
    }

    // A task in hand goes back: idle as if its node had gone silent, so any node claims it now.
    void hand_back(Redis& r, const Task& t, const std::string& consumer) {
        try {
            r.command({"XCLAIM", t.stream, keys::group, consumer, "0", t.id, "IDLE", std::to_string(cfg.visibility_ms + 1), "JUSTID"});
        } catch (const RedisError&) {
        }
    }

    std::vector<std::string> streams(Redis& r) {
        std::vector<std::string> s;
        for (const auto& lane : r.command({"ZREVRANGEBYSCORE", keys::priorities, "+inf", "-inf"}).items) {
            const std::vector<std::string> need = keys::lane_tags(lane.text);
            if (std::includes(cfg.tags.begin(), cfg.tags.end(), need.begin(), need.end())) s.push_back(keys::lane_tasks(lane.text));
        }
        return s;
    }

    // Reads more tasks into `local`: those of silent nodes first, then new ones, highest priority
    // first. A read takes about `batch_ms_` of work (from the last tasks' times), so short tiles
    // do not cost a round trip each, while a long tile is never held back behind another.
    void fetch(Redis& r, const std::string& consumer, std::deque<Task>& local, Clock::time_point& last_reclaim,
               std::vector<std::string>& cached_streams, Clock::time_point& streams_read, double task_seconds) {
        // The streams in use change only when a job of a new priority arrives: read every 250 ms.
        if (Clock::now() - streams_read > std::chrono::milliseconds(250) || cached_streams.empty()) {
            cached_streams = streams(r);
            streams_read = Clock::now();
        }
        const std::vector<std::string>& ss = cached_streams;
        if (ss.empty()) {
            std::this_thread::sleep_for(std::chrono::milliseconds(200));
            return;
        }
        const int count = std::clamp(int(kBatchSeconds / std::max(task_seconds, 1e-6)), 1, kMaxBatch);
        const std::string n = std::to_string(count);
        if (Clock::now() - last_reclaim > std::chrono::milliseconds(std::max(100, cfg.visibility_ms / 4))) {
            last_reclaim = Clock::now();
            for (const auto& s : ss) {
                const RedisValue v = r.command({"XAUTOCLAIM", s, keys::group, consumer, std::to_string(cfg.visibility_ms), "0-0", "COUNT", n});
                if (v.items.size() >= 2)
                    for (const auto& e : v.items[1].items)
                        if (auto t = parse_entry(s, e)) {
                            ++metrics.reclaimed;
                            t->reclaimed = true;
                            spdlog::warn("node {}: took over {} task of job {} (pass {}, tile {}) from a silent node", name, t->kind, t->job, t->pass, t->tile);
                            local.push_back(*t);
                        }
                if (!local.empty()) return;
            }
        }
        for (const auto& s : ss) {
            const RedisValue v = r.command({"XREADGROUP", "GROUP", keys::group, consumer, "COUNT", n, "STREAMS", s, ">"});
            for (const auto& st : v.items)
                if (st.items.size() >= 2)
                    for (const auto& e : st.items[1].items)
                        if (auto t = parse_entry(s, e)) local.push_back(*t);
            if (!local.empty()) return;
        }
        std::vector<std::string> cmd = {"XREADGROUP", "GROUP", keys::group, consumer, "COUNT", "1", "BLOCK", "500", "STREAMS"};
        cmd.insert(cmd.end(), ss.begin(), ss.end());
        for (size_t i = 0; i < ss.size(); ++i) cmd.push_back(">");
        const RedisValue v = r.command(cmd);
        // One entry per stream may come back: in stream (priority) order, kept here.
        for (const auto& st : v.items)
            if (st.items.size() >= 2)
                for (const auto& e : st.items[1].items)
                    if (auto t = parse_entry(st.items[0].text, e)) local.push_back(*t);
    }

    void worker(int index) {
        const std::string consumer = name + "/" + std::to_string(index);
        Redis r(cfg.redis);
        std::deque<Task> local;
        auto last_reclaim = Clock::now() - std::chrono::hours(1);
        auto streams_read = last_reclaim;
        std::vector<std::string> cached_streams;
        double task_seconds = 1.0;  // a moving average: how many tasks one read takes
        int backoff_ms = 100;
        while (!stopping) {
            if (local.empty()) {
                // Tasks handed to other nodes: give them a moment to read them before this
                // node reads its lanes again (it would read them back first).
                if (t_passed) std::this_thread::sleep_for(std::chrono::milliseconds(100));
                t_passed = false;
                try {
                    fetch(r, consumer, local, last_reclaim, cached_streams, streams_read, task_seconds);
                    backoff_ms = 100;
                } catch (const RedisError& e) {
                    ++metrics.redis_errors;
                    spdlog::warn("node {}: {}; retrying in {} ms", name, e.what(), backoff_ms);
                    std::this_thread::sleep_for(std::chrono::milliseconds(backoff_ms));
                    backoff_ms = std::min(2000, backoff_ms * 2);
                    continue;
                }
                // Every task read is held from now on: the heartbeat renews its claim while it
                // waits its turn here, and stops it if its job is canceled.
                std::lock_guard lock(mu);
                for (const Task& t : local)
                    held[t.key()] = {t, consumer, std::make_shared<std::atomic<bool>>(false), std::make_shared<std::atomic<bool>>(false),
                                     std::make_shared<std::atomic<bool>>(false)};
                if (local.empty()) continue;
            }
            Task t = local.front();
            local.pop_front();
            t.consumer = consumer;
            Held h;
            {
                std::lock_guard lock(mu);
                h = held.at(t.key());
            }
            const auto t0 = Clock::now();
            // The same task again after a Redis error (a restart): every step is idempotent.
            for (int attempt = 0; !stopping && !*h.lost; ++attempt) {
                try {
                    run_task(r, t, *h.cancel, *h.lost, *h.acked);
                    break;
                } catch (const RedisError& e) {
                    ++metrics.redis_errors;
                    spdlog::warn("node {}: {} task of job {}: {}; retrying", name, t.kind, t.job, e.what());
                    std::this_thread::sleep_for(std::chrono::milliseconds(std::min(2000, 100 << std::min(attempt, 5))));
                }
            }
            if (t.kind == "tile") task_seconds = 0.8 * task_seconds + 0.2 * std::chrono::duration<double>(Clock::now() - t0).count();
            if (stopping && !*h.acked) hand_back(r, t, consumer);
            std::lock_guard lock(mu);
            held.erase(t.key());
        }
        for (const Task& t : local) hand_back(r, t, consumer);
        std::lock_guard lock(mu);
        for (const Task& t : local) held.erase(t.key());
    }

    void run_task(Redis& r, const Task& t, std::atomic<bool>& cancel, const std::atomic<bool>& lost, std::atomic<bool>& acked) {
        // The job's log (task_log.h): this task, with what this thread logged while it ran it.
        TaskRecord log;
        log.task = t.kind;
        log.node = name;
        log.start = now_s();
        if (t.kind == "tile" || t.kind == "assemble") log.pass = t.pass;
        if (t.kind == "tile") log.tile = t.tile;
        if (t.kind == "frames") log.frame = t.pass;  // the chunk's first frame (an index into the shot's frames)
        t_dropped = false;
        if (hand_over(r, t, lost)) {
            acked = true;
            return;
        }
        log.attempt = t.attempt;
        bool failed = false, acked_here = false;
        {
            TaskLogCapture capture(log);
            std::string retry;  // the task's failure, not the job's: another node may do it
            try {
                // A first delivery needs no count; a task taken over from a silent node counts the
                // takeovers, so a task that kills every node that takes it fails its job.
                if (t.reclaimed) {
                    const std::string what = t.kind == "tile" ? "tile " + std::to_string(t.tile) + " of pass " + std::to_string(t.pass)
                                                              : "the " + t.kind + " task" + (t.kind == "assemble" ? " of pass " + std::to_string(t.pass) : "");
                    const long long taken =
                        r.command({"HINCRBY", keys::deliveries(t.job), t.kind + ":" + std::to_string(t.pass) + ":" + std::to_string(t.tile), "1"}).as_int();
                    log.attempt = int(taken) + 1;
                    if (taken + 1 > cfg.max_deliveries)
                        throw JobFailure(what + " was delivered " + std::to_string(taken + 1) +
                                         " times: the nodes that took it stopped answering (crashed, killed, out of memory?)");
                }
                if (t.kind == "tile") acked_here = tile(r, t, cancel, acked);
                else if (t.kind == "assemble") assemble(r, t);
                else if (t.kind == "start") begin(r, t, cancel);
                else if (t.kind == "frames") shot_chunk(r, t, cancel);
                else spdlog::warn("node {}: unknown task kind '{}' dropped", name, t.kind);
            } catch (const RedisError&) {
                throw;
            } catch (const JobFailure& e) {
                failed = true;
                log.errors.push_back(published(r, t.job, e.what()));
                fail_job(r, t.job, log.errors.back());
            } catch (const api::InvalidJob& e) {
                // The job's own input against a scene every node reads alike (an animation the
                // scene lacks): no other node and no retry does better.
                failed = true;
                log.errors.push_back(published(r, t.job, e.what()));
                fail_job(r, t.job, log.errors.back());
            } catch (const SceneError& e) {
                // A node's own limits or files may refuse what another takes.
                failed = true;
                retry = published(r, t.job, std::string("scene: ") + e.what());
            } catch (const std::exception& e) {
                failed = true;
                retry = published(r, t.job, e.what());
            }
            if (!retry.empty()) {
                log.errors.push_back(retry);
                if (!cancel && !stopping) {
                    task_failed(r, t, retry, lost);
                    acked_here = true;  // the failure script settled the delivery
                }
            }
        }
        log.end = now_s();
        log.outcome = failed ? "failed" : (cancel || lost || stopping) ? "interrupted" : t_dropped ? "dropped" : "done";
        record(r, t.job, log);
        if (acked_here) return;
        if (!stopping && !lost) {
            acked = true;
            ack(r, t);
        }
    }

    // The live nodes that could take a task of `lane`, this one first; the farm's nodes are read
    // at most once a second.
    std::vector<std::string> takers(Redis& r, const std::string& lane) {
        std::vector<FarmNode> ns;
        bool fresh;
        {
            std::lock_guard lock(mu);
            fresh = Clock::now() - peers_read < std::chrono::seconds(1);
            if (fresh) ns = peers;
        }
        if (!fresh) {
            std::vector<std::pair<std::string, std::string>> hash;
            const RedisValue v = r.command({"HGETALL", keys::nodes});
            for (size_t i = 0; i + 1 < v.items.size(); i += 2) hash.emplace_back(v.items[i].text, v.items[i + 1].text);
            ns = parse_farm_nodes(hash);
            std::lock_guard lock(mu);
            peers = ns;
            peers_read = Clock::now();
        }
        const std::vector<std::string> tags = keys::lane_tags(lane);
        const double now = now_s();
        std::vector<std::string> out = {name};
        for (const FarmNode& n : ns)
            if (n.name != name && is_live(n, now) && has_tags(n, tags)) out.push_back(n.name);
        return out;
    }

    // Leaves a task to the other nodes where it should: its job blocklisted this node, or this
    // node failed the task before and a live node that has not can take it. A blocklisted node
    // that finds no other node for the task fails the job with every reason. Returns whether the
    // task left this node.
    bool hand_over(Redis& r, const Task& t, const std::atomic<bool>& lost) {
        bool blocked;
        {
            std::lock_guard lock(mu);
            blocked = blocked_jobs.count(t.job) > 0;
        }
        if (!blocked && !lists(t.avoid, name)) return false;
        if (lost) return true;  // another node holds it now
        std::set<std::string> listed;
        for (const auto& v : r.command({"SMEMBERS", keys::blocklist(t.job)}).items) listed.insert(v.text);
        std::vector<std::string> others;
        for (const std::string& n : takers(r, t.lane()))
            if (n != name && !listed.count(n) && (blocked || !lists(t.avoid, n))) others.push_back(n);
        if (others.empty()) {
            if (!blocked) return false;  // no node that has not failed it: it runs here again
            if (r.eval(kStrand, {keys::job(t.job), keys::failure_reasons(t.job), keys::blocklist(t.job)},
                       {keys::prefix, t.job, redis_number(now_s())}).as_int() == 1)
                spdlog::error("node {}: job {} failed: every live node that could take its tasks is blocklisted for it", name, t.job);
            ack(r, t);
            return true;
        }
        r.eval(kPassOn, {t.stream}, {t.id, t.job, t.kind, std::to_string(t.pass), std::to_string(t.tile), std::to_string(t.attempt), t.avoid, t.run,
                                     t.consumer});
        ++metrics.passed_on;
        t_passed = true;
        return true;
    }

    // A job's error with this node's copies of its files named as the job named them.
    std::string published(Redis& r, const std::string& job, const std::string& text) {
        std::vector<SceneRef> refs;
        try {
            for (const RedisValue& v : r.pipeline({{"GET", keys::job_scene(job)}, {"GET", keys::job_environment(job)}}))
                if (!v.is_nil()) refs.push_back(SceneRef::decode(v.text));
        } catch (const std::exception&) {
            // Redis gone: the copies by their file names alone.
        }
        return cache.as_published(text, refs);
    }

    // A task failed here for a reason that is not the job's: counted against the task and this
    // node, and queued again for another node, or the job fails with every reason (fail_task).
    void task_failed(Redis& r, const Task& t, const std::string& error, const std::atomic<bool>& lost) {
        ++metrics.failed_tasks;
        if (lost) return;  // another node took it over meanwhile: the delivery is not ours to settle
        api::TaskPolicy policy;
        try {
            if (const auto info = job_info(r, t.job)) policy = api::task_policy_of(info->job);
        } catch (const RedisError&) {
            throw;
        } catch (const std::exception&) {
            // The defaults, for a job whose record this node cannot read.
        }
        std::string reason = name + ": " + t.what() + ": " + error;
        if (reason.size() > 400) reason = reason.substr(0, 400) + "...";
        std::vector<std::string> args = {keys::prefix, t.job, t.id, t.kind + ":" + std::to_string(t.pass) + ":" + std::to_string(t.tile),
                                         name, reason, std::to_string(policy.max_retries), std::to_string(policy.blocklist_after),
                                         redis_number(now_s()), t.kind, std::to_string(t.pass), std::to_string(t.tile), t.avoid, t.what(), t.run,
                                         t.consumer};
        for (std::string& n : takers(r, t.lane())) args.push_back(std::move(n));
        const RedisValue v = r.eval(kFailTask,
                                    {keys::job(t.job), keys::failures(t.job), keys::failure_reasons(t.job), keys::blocklist(t.job), t.stream,
                                     keys::node_failed_tasks},
                                    args);
        const long long outcome = v.items.size() == 2 ? v.items[0].as_int() : 0;
        if (v.items.size() == 2 && v.items[1].as_int() == 1) {
            std::lock_guard lock(mu);
            if (blocked_jobs.size() > 4096) blocked_jobs.clear();
            if (blocked_jobs.insert(t.job).second)
                spdlog::warn("node {}: blocklisted for job {}: {} of its tasks failed here; it takes no more of them", name, t.job,
                             policy.blocklist_after);
        }
        if (outcome == 2) spdlog::error("node {}: job {} failed: {} failed and no retry is left", name, t.job, t.what());
        else if (outcome == 1) spdlog::warn("node {}: {} of job {} failed (attempt {}), queued again: {}", name, t.what(), t.job, t.attempt, error);
    }

    // A task that finds its work done or not wanted (a duplicate, a job no longer running).
    void dropped() {
        ++metrics.duplicates;
        t_dropped = true;
    }

    // Appends a task to its job's log in Redis, keeping the newest keys::max_task_records. A log that
    // cannot be written is not the task's failure.
    void record(Redis& r, const std::string& job, const TaskRecord& log) {
        try {
            r.eval(kAppendLog, {keys::task_log(job), keys::task_log_count(job), keys::job(job)},
                   {api::json_text(to_json(log)), std::to_string(keys::max_task_records)});
        } catch (const RedisError& e) {
            spdlog::warn("node {}: job {}: the task's log line was not stored: {}", name, job, e.what());
        }
    }

    void begin(Redis& r, const Task& t, std::atomic<bool>& cancel) {
        const RedisValue v = r.command({"HMGET", keys::job(t.job), "state", "run"});
        const RedisValue st = v.items.size() == 2 ? v.items[0] : RedisValue{};
        // A start of a run before the job's last resume: the resume queued another.
        if (v.items.size() == 2 && (v.items[1].is_nil() ? std::string("0") : v.items[1].text) != t.run) { dropped(); return; }
        const auto info = st.text == "queued" || st.text == "running" ? job_info(r, t.job) : nullptr;
        // A comparison or a shot whose node died or stopped mid-run is still "running": it runs
        // again here (a shot from its first frame not yet written).
        const auto* as_render = info ? std::get_if<api::RenderJob>(&info->job) : nullptr;
        const bool whole = info && (std::holds_alternative<api::ComparisonJob>(info->job) || (as_render && as_render->frames));
        const bool rerun = st.text == "running" && whole;
        if (st.text != "queued" && !rerun) { dropped(); return; }
        if (!info) return;
        ++metrics.starts;
        if (const auto* cj = std::get_if<api::ComparisonJob>(&info->job)) return compare(r, t, *cj, cancel);
        const auto& rj = std::get<api::RenderJob>(info->job);
        if (rj.frames) return begin_shot(r, t, rj, cancel);
        cache.get(r, info->ref, rj.scene_options);  // a scene that does not load fails the job here, once
        const PassPlan& plan = info->plan;
        std::vector<std::string> args = {keys::prefix, t.job, redis_number(now_s())};
        for (std::string& a : farm_run_start(plan.whole_tiles ? plan.targets.back() : pass_target(info->settings, plan, 0),
                                             plan.tiles.size(), now_ms()))
            args.push_back(std::move(a));
        if (r.eval(kBegin, {keys::job(t.job), t.stream}, args).as_int() == 1)
            spdlog::info("node {}: job {} running: {} tiles per pass", name, t.job, plan.tiles.size());
    }

    // A comparison runs whole here: its configurations race each other for equal time, which
    // tiles spread over nodes would not keep equal.
    void compare(Redis& r, const Task& t, const api::ComparisonJob& job, std::atomic<bool>& cancel) {
        const std::string state = r.command({"HGET", keys::job(t.job), "state"}).text;
        if (state != "running" &&
            r.eval(kTransition, {}, {keys::prefix, t.job, "running", "queued", redis_number(now_s()), "", ""}).as_int() != 1)
            return;  // canceled meanwhile
        api::RunOptions opt;
        const auto info = job_info(r, t.job);
        // The comparison loads the scene itself (each configuration builds its own BVH): only
        // the file is needed here.
        opt.scene_source = cache.file_for(r, info->ref);
        opt.scene_name = info->ref.shown();
        opt.load_limits = cfg.load_limits;
        opt.threads = 1;
        opt.job_id = t.job;
        const fs::path dir = job_results_dir(cfg.data_dir, t.job);
        fs::create_directories(dir);
        api::RunCallbacks cb;
        cb.stop = &cancel;
        const api::JobOutcome out = api::run_job(job, opt, api::RunOutputs::in_directory(dir.string()), cb);
        if (out.stopped) return;
        r.eval(kTransition, {}, {keys::prefix, t.job, "succeeded", "running", redis_number(now_s()), "", json_text(out.summary)});
    }

    // A shot is spread over the nodes in chunks of frames, each rendered through the one shot
    // runner (api::run_shot) into the shared results folder. The node that starts it renders
    // the first frame, which measures what opening the scene and a frame cost, and queues the
    // rest as chunks; the node that writes the last chunk writes the contact sheet, preview and
    // report. Every run keeps the frames already written (a chunk taken over from a silent
    // node, a start task delivered again), so each frame is rendered once and the shot's
    // images do not depend on which node rendered what.
    api::RunOptions shot_options(Redis& r, const Task& t, const JobInfo& info) {
        api::RunOptions opt;
        opt.scene_source = cache.file_for(r, info.ref);
        opt.scene_name = info.ref.shown();
        opt.load_limits = cfg.load_limits;
        opt.threads = cfg.threads;
        opt.job_id = t.job;
        opt.resume_frames = true;
        // The frame in hand continues from its checkpoint in the shared folder after a pause, a
        // node's stop or death.
        opt.checkpoint_seconds = cfg.checkpoint_s;
        opt.environment = info.settings.environment;  // published by the API node, loaded with the job
        // The shot's scene, opened once on this node and kept for its next chunks (posing is
        // const: chunks on several threads share it); another shot replaces it. Prototype
        // trees are kept frame to frame within a chunk (the shot runner's own cache).
        std::lock_guard lock(shot_mu);
        if (kept_shot.job != t.job || kept_shot.source != opt.scene_source || !kept_shot.file) {
            kept_shot = {};
            try {
                kept_shot.file = std::make_shared<const tessera::SceneFile>(opt.scene_source, cfg.load_limits, opt.scene_name);
            } catch (const std::exception&) {
                return opt;  // the shot runner opens it and fails the job with the reason
            }
            kept_shot.job = t.job;
            kept_shot.source = opt.scene_source;
            ++metrics.shot_opens;
        }
        opt.scene_file = kept_shot.file;
        return opt;
    }

    // The last shot's scene on this node (shot_options).
    struct KeptShot {
        std::string job, source;
        std::shared_ptr<const tessera::SceneFile> file;
    };
    std::mutex shot_mu;
    KeptShot kept_shot;

    api::RunOutputs shot_outputs(const std::string& id) {
        const fs::path dir = job_results_dir(cfg.data_dir, id);
        fs::create_directories(dir);
        return api::RunOutputs::in_directory(dir.string());
    }

    void begin_shot(Redis& r, const Task& t, const api::RenderJob& job, std::atomic<bool>& cancel) {
        const std::string state = r.command({"HGET", keys::job(t.job), "state"}).text;
        if (state != "running" &&
            r.eval(kTransition, {}, {keys::prefix, t.job, "running", "queued", redis_number(now_s()), "", ""}).as_int() != 1)
            return;  // canceled meanwhile
        const auto info = job_info(r, t.job);
        api::RunOptions opt = shot_options(r, t, *info);
        opt.frame_slice = std::make_pair(size_t(0), size_t(1));
        api::RunCallbacks cb;
        cb.stop = &cancel;
        const api::JobOutcome first = api::run_job(job, opt, shot_outputs(t.job), cb);
        if (first.stopped) return shot_stopped(r, t.job);
        metrics.frames += first.summary.value("frames", 0) - first.summary.value("frames_resumed", 0);
        const size_t total = job.frames->count();
        const size_t live = std::max<size_t>(1, takers(r, t.lane()).size());  // the live nodes that can take its chunks
        const size_t chunk = chunk_frames(first.summary.value("open_s", 0.0), first.summary.value("frames_s", 0.0), total - 1, live,
                                          size_t(job.chunk));
        std::vector<std::string> args = {t.job, t.run};
        for (const auto& [from, count] : plan_chunks(1, total, chunk)) {
            args.push_back(std::to_string(from));
            args.push_back(std::to_string(count));
        }
        if (r.eval(kAddChunks, {keys::shot_chunks(t.job), t.stream}, args).as_int() == 1)
            spdlog::info("node {}: shot {} running: {} frames in chunks of {}", name, t.job, total, chunk);
        if (total == 1) finish_shot(r, t, job, cancel);
    }

    void shot_chunk(Redis& r, const Task& t, std::atomic<bool>& cancel) {
        // Canceled, failed or paused; or a chunk of a run before the last resume (its plan dropped).
        const RedisValue v = r.command({"HMGET", keys::job(t.job), "state", "run"});
        if (v.items.size() != 2 || v.items[0].text != "running" || (v.items[1].is_nil() ? std::string("0") : v.items[1].text) != t.run) {
            dropped();
            return;
        }
        const auto info = job_info(r, t.job);
        if (!info) return;
        const auto& job = std::get<api::RenderJob>(info->job);
        api::RunOptions opt = shot_options(r, t, *info);
        opt.frame_slice = std::make_pair(size_t(std::max(t.pass, 0)), size_t(std::max(t.tile, 0)));
        api::RunCallbacks cb;
        cb.stop = &cancel;
        const api::JobOutcome out = api::run_job(job, opt, shot_outputs(t.job), cb);
        if (out.stopped) return shot_stopped(r, t.job);
        metrics.frames += out.summary.value("frames", 0) - out.summary.value("frames_resumed", 0);
        const RedisValue done = r.eval(kChunkDone, {keys::shot_done(t.job), keys::shot_chunks(t.job), keys::job(t.job)}, {std::to_string(t.pass), t.run});
        // Every chunk written: this node finishes the shot (a finish repeated after a node died
        // mid-way finds every frame written and writes the same files).
        if (done.items.size() == 2 && done.items[0].as_int() >= 0 && done.items[0].as_int() == done.items[1].as_int())
            finish_shot(r, t, job, cancel);
    }

    // A shot's run stopped: a paused job keeps its frame's checkpoint for its resume; a canceled
    // or failed one never continues, and the checkpoint written as it stopped goes.
    void shot_stopped(Redis& r, const std::string& id) {
        const std::string state = r.command({"HGET", keys::job(id), "state"}).text;
        if (state != "paused" && state != "running" && state != "queued") remove_checkpoints(job_results_dir(cfg.data_dir, id));
    }

    void finish_shot(Redis& r, const Task& t, const api::RenderJob& job, std::atomic<bool>& cancel) {
        const auto info = job_info(r, t.job);
        api::RunCallbacks cb;
        cb.stop = &cancel;
        const api::JobOutcome out = api::run_job(job, shot_options(r, t, *info), shot_outputs(t.job), cb);
        if (out.stopped) return;
        r.eval(kTransition, {}, {keys::prefix, t.job, "succeeded", "running", redis_number(now_s()), "", json_text(out.summary)});
        std::lock_guard lock(shot_mu);
        if (kept_shot.job == t.job) kept_shot = {};  // the shot is done: its scene's memory goes back
    }

    // The state of a job's run as a tile needs it (see SeenRun).
    FarmRun run_state(Redis& r, const std::string& id, int pass) {
        {
            std::lock_guard lock(mu);
            auto it = states.find(id);
            if (it != states.end() && it->second.run.state == "running" && it->second.run.pass == pass &&
                Clock::now() - it->second.read < std::chrono::milliseconds(50))
                return it->second.run;
        }
        const FarmRun run = read_run(r, id);
        std::lock_guard lock(mu);
        if (states.size() > 1024) states.clear();
        states[id] = {run, Clock::now()};
        return run;
    }

    static FarmRun read_run(Redis& r, const std::string& id) {
        std::vector<std::string> cmd = {"HMGET", keys::job(id)};
        cmd.insert(cmd.end(), farm_run_fields().begin(), farm_run_fields().end());
        return decode_farm_run(r.command(cmd));
    }

    // Returns whether the task was acknowledged (the commit script does it with the result).
    bool tile(Redis& r, const Task& t, std::atomic<bool>& cancel, std::atomic<bool>& acked) {
        const FarmRun run = run_state(r, t.job, t.pass);
        if (run.state != "running" || run.pass != t.pass) { dropped(); return false; }
        const auto info = job_info(r, t.job);
        if (!info) return false;
        const PassPlan& plan = info->plan;
        if (t.tile < 0 || size_t(t.tile) >= plan.tiles.size()) throw JobFailure("a task names tile " + std::to_string(t.tile) + " of " + std::to_string(plan.tiles.size()));
        const auto& rj = std::get<api::RenderJob>(info->job);
        const auto prepared = cache.get(r, info->ref, rj.scene_options);
        const RenderSettings s = api::lit_settings(info->settings, prepared->scene);
        const TileRect& rect = plan.tiles[size_t(t.tile)];
        Film film = Film::tile(rect.x0, rect.y0, rect.width(), rect.height(), plan.half_buffer, plan.adaptive, plan.aovs);
        if (t.pass > 0) {
            const RedisValue f = r.command({"HGET", keys::film(t.job), "t" + std::to_string(t.tile)});
            if (f.is_nil()) throw JobFailure("the film of tile " + std::to_string(t.tile) + " is missing from Redis");
            film = decode_film(f.text);
            // A guided pass's targets per pixel, which the pass before it set (none: uniform).
            film.goal.clear();
            if (plan.guided) {
                const RedisValue g = r.command({"HGET", keys::film(t.job), "g" + std::to_string(t.tile)});
                if (!g.is_nil()) {
                    film.goal.resize(rect.pixels());
                    size_t at = 0;
                    get_raw(g.text, at, film.goal, "guided targets");
                    if (at != g.text.size()) throw JobFailure("the guided targets of tile " + std::to_string(t.tile) + " are the wrong size");
                }
            }
        }
        const long long deadline = s.time_limit_s > 0 ? run.started_ms + (long long)(s.time_limit_s * 1000.0) : 0;
        auto late = [&] { return deadline && now_ms() > deadline; };
        auto interrupted = [&] { return cancel.load() || stopping.load(); };
        const auto t0 = Clock::now();
        const Camera camera = camera_for(prepared->scene, s);  // the context keeps a reference
        const SeenEmitters seen = seen_emitters(prepared->scene, s, camera, rect.x0, rect.y0, rect.width(), rect.height());
        TileContext ctx(prepared->scene, s, camera, &seen);
        TileCommit commit;
        commit.timed_out = late();
        if (plan.whole_tiles) {
            const WholeTile w = render_whole_tile(ctx, plan, size_t(t.tile), film, info->reference ? &*info->reference : nullptr,
                                                  interrupted, [&] { return double(now_ms() - run.started_ms) / 1000.0; });
            commit.sums = whole_tile_sums_text(w.sums);
        } else if (!commit.timed_out && !interrupted()) {
            commit.timed_out = !render_tile(ctx, rect, film, int(run.target), [&] { return late() || interrupted(); }) && !interrupted();
        }
        if (interrupted()) return false;  // canceled, taken over, or the node stops: nothing stored
        commit.job = t.job;
        commit.task_id = t.id;
        commit.node = name;
        commit.tile = size_t(t.tile);
        commit.pass = t.pass;
        commit.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
        commit.stats = ctx.stats;
        // A whole tile is finished with this task: it ships the resolved pixels (its film where
        // the job has AOVs, which resolve from the whole film's sums as one process's do). A
        // pass-by-pass job's next pass goes on from the whole film.
        film.goal.clear();  // the targets travel in their own field (g<tile>), not twice
        commit.payload = plan.whole_tiles && plan.aovs == 0 ? encode_tile_image(film) : encode_film(film);
        acked = true;
        const long long rc = r.eval(commit_tile(),
                                    {keys::job(t.job), keys::film(t.job), keys::node_tiles(t.job), keys::node_seconds(t.job), t.stream,
                                     keys::sums(t.job)},
                                    commit.arguments())
                                 .as_int();
        if (rc == 1) {
            ++metrics.tiles;
            metrics.rays += commit.stats.rays();
            metrics.render_micros += uint64_t(commit.seconds * 1e6);
        } else {
            dropped();  // another node stored it first: the same film, dropped
        }
        return true;
    }

    void assemble(Redis& r, const Task& t) {
        const FarmRun run = read_run(r, t.job);
        if (run.state != "running" || run.pass != t.pass) { dropped(); return; }
        const auto info = job_info(r, t.job);
        if (!info) return;
        const RenderSettings& s = info->settings;
        const PassPlan& plan = info->plan;
        const size_t n = plan.tiles.size();
        if (size_t(run.tiles_total) != n) throw JobFailure("the run has " + std::to_string(run.tiles_total) + " tiles, the plan " + std::to_string(n));
        // A whole-tile job's tiles are resolved pixels (films where it has AOVs); a pass-by-pass
        // job's are films.
        const bool pixels = plan.whole_tiles && plan.aovs == 0;
        Film film(pixels ? 1 : s.width, pixels ? 1 : s.height, plan.half_buffer, plan.adaptive, pixels ? 0 : plan.aovs);
        Image image(pixels ? s.width : 0, pixels ? s.height : 0);
        const RedisValue tiles = r.command({"HGETALL", keys::film(t.job)});
        size_t found = 0;
        for (size_t i = 0; i + 1 < tiles.items.size(); i += 2) {
            const std::string& field = tiles.items[i].text;
            if (field.empty() || field[0] != 't') continue;
            if (pixels) {
                place_tile(decode_tile_image(tiles.items[i + 1].text), image);
            } else {
                const Film tf = decode_film(tiles.items[i + 1].text);
                copy_tile_into(tf, {tf.x0, tf.y0, tf.x0 + tf.width, tf.y0 + tf.height}, film);
            }
            ++found;
        }
        if (found != n) throw JobFailure("pass " + std::to_string(t.pass) + " has " + std::to_string(found) + " of " + std::to_string(n) + " tiles in Redis");
        const double seconds = double(now_ms() - run.started_ms) / 1000.0;
        ++metrics.assemblies;
        if (plan.whole_tiles) {
            // The curve from every tile's sums per target.
            std::vector<std::vector<TargetSums>> per_tile;
            const RedisValue all = r.command({"HGETALL", keys::sums(t.job)});
            for (size_t i = 0; i + 1 < all.items.size(); i += 2) per_tile.push_back(whole_tile_sums_from_text(all.items[i + 1].text));
            RenderResult result;
            result.curve = whole_tile_curve(plan, per_tile);
            if (!pixels) {
                image = film.resolve();
                result.aovs = film.resolve_aovs(s.aovs);
            }
            const ConvergencePoint last = result.curve.points.empty() ? ConvergencePoint{} : result.curve.points.back();
            return write_results(r, t, *info, std::move(image), film, run, seconds, std::move(result), last);
        }
        const PassEnd end = end_pass(s, plan, film, info->reference ? &*info->reference : nullptr, t.pass, int(run.target),
                                     run.stats.samples, seconds, run.timed_out, false, &denoise_memory);
        // The job's last pass: its maps wait for no next one (another job's would not fit them).
        if (end.stop) denoise_memory.clear();
        if (!end.stop) {
            // Guided sampling's targets for the next pass, a field per tile beside the tiles'
            // films, stored with the pass's advance.
            std::vector<std::string> script_keys = {keys::job(t.job), keys::curve(t.job), t.stream};
            std::vector<std::string> args = {t.job, std::to_string(t.pass), std::to_string(end.next_target),
                                             json_text(api::to_json(end.point)), std::to_string(n)};
            if (!end.goals.empty()) {
                script_keys.push_back(keys::film(t.job));
                for (size_t k = 0; k < n; ++k) {
                    args.push_back("g" + std::to_string(k));
                    args.emplace_back();
                    put_raw(args.back(), tile_goals(end.goals, s.width, plan.tiles[k]));
                }
            }
            r.eval(kAdvance, script_keys, args);
            return;
        }
        RenderResult result;
        for (const auto& p : r.command({"LRANGE", keys::curve(t.job), "0", "-1"}).items)
            result.curve.points.push_back(api::convergence_point_from_json(json::parse(p.text)));
        result.curve.points.push_back(end.point);
        result.curve.stop = *end.stop;
        result.aovs = film.resolve_aovs(s.aovs);
        result.denoised = end.denoised;
        write_results(r, t, *info, film.resolve(), film, run, seconds, std::move(result), end.point);
    }

    // The last pass: the results, then the job's state (a node that dies in between leaves the
    // task to another, which writes the same files again). `buffers` says which film buffers the
    // render kept (the report lists them).
    void write_results(Redis& r, const Task& t, const JobInfo& info, Image image, const Film& buffers, const FarmRun& run,
                       double seconds, RenderResult result, const ConvergencePoint& pt) {
        const auto& rj = std::get<api::RenderJob>(info.job);
        const auto prepared = cache.get(r, info.ref, rj.scene_options);
        const RenderSettings s = api::lit_settings(info.settings, prepared->scene);
        result.image = std::move(image);
        RenderStats& st = result.stats;
        st = run.stats;
        st.render_seconds = seconds;
        describe_render(prepared->scene, s, buffers, result.built, result.left_out);
        describe_denoised(s, result.denoised != nullptr, false, result.left_out);
        const auto shares = r.pipeline({{"HGETALL", keys::node_tiles(t.job)}, {"HGETALL", keys::node_seconds(t.job)}});
        std::map<std::string, api::NodeShare> by_node;
        for (size_t i = 0; i + 1 < shares[0].items.size(); i += 2) {
            auto& ns = by_node[shares[0].items[i].text];
            ns.node = shares[0].items[i].text;
            ns.tiles = size_t(shares[0].items[i + 1].as_int());
        }
        for (size_t i = 0; i + 1 < shares[1].items.size(); i += 2) by_node[shares[1].items[i].text].seconds = std::stod(shares[1].items[i + 1].text);
        st.threads = int(by_node.size());
        api::FinishedRender done{rj, prepared->scene, s, result};
        done.load_s = prepared->load_s;
        done.build_s = prepared->build_s;
        done.before_write_s = seconds;
        done.tiles_done = done.tiles_total = info.plan.tiles.size();
        for (auto& [node, share] : by_node) done.nodes.push_back(share);
        // Written beside the final place and renamed into it: API nodes never serve half a file.
        const fs::path dir = job_results_dir(cfg.data_dir, t.job);
        const fs::path part = dir / (".part-" + name + "-" + std::to_string(std::hash<std::thread::id>{}(std::this_thread::get_id()) % 100000));
        fs::create_directories(part);
        api::RunOptions opt;
        opt.job_id = t.job;
        const api::JobOutcome out = api::write_render(done, opt, api::RunOutputs::in_directory(part.string()));
        for (const auto& e : fs::directory_iterator(part)) {
            // A folder (the passes) of an earlier attempt is replaced whole: rename does not
            // replace a folder that holds files.
            const fs::path to = dir / e.path().filename();
            if (fs::is_directory(e.path()) && fs::is_directory(to)) fs::remove_all(to);
            fs::rename(e.path(), to);
        }
        fs::remove_all(part);
        if (r.eval(kComplete, {keys::job(t.job), keys::curve(t.job)},
                   {keys::prefix, t.job, std::to_string(t.pass), json_text(api::to_json(pt)), redis_number(now_s()), json_text(out.summary)}).as_int() == 1)
            spdlog::info("node {}: job {} succeeded ({} passes, {:.3f} s)", name, t.job, result.curve.points.size(), seconds);
    }

    void beat() {
        Redis r(cfg.redis);
        const auto period = std::chrono::milliseconds(std::max(50, cfg.visibility_ms / 4));
        while (!stopping) {
            try {
                std::vector<Held> now;
                {
                    std::lock_guard lock(mu);
                    for (const auto& [k, h] : held) now.push_back(h);
                }
                for (const Held& h : now) {
                    if (*h.acked) continue;
                    if (r.eval(kRenew, {h.task.stream}, {h.task.id, h.consumer}).as_int() == 0) {
                        if (*h.acked) continue;  // acknowledged meanwhile
                        spdlog::warn("node {}: task of job {} was taken over by another node; dropping it", name, h.task.job);
                        *h.lost = true;
                        *h.cancel = true;
                        continue;
                    }
                    const RedisValue v = r.command({"HMGET", keys::job(h.task.job), "state", "run"});
                    const std::string st = v.items.size() == 2 ? v.items[0].text : "";
                    if (st != "running" && st != "queued") *h.cancel = true;  // canceled, paused (or gone): stop within a row
                    // A comparison's or a shot's task of a run before the job's last resume.
                    const bool whole = h.task.kind == "start" || h.task.kind == "frames";
                    if (whole && v.items.size() == 2 && (v.items[1].is_nil() ? std::string("0") : v.items[1].text) != h.task.run) *h.cancel = true;
                }
                // Failures counted against this node across jobs (the scripts keep them in Redis,
                // so that a node restarted under its name is still known by them).
                const auto counts = r.pipeline({{"HGET", keys::node_failed_tasks, name}, {"HGET", keys::node_blocklisted_jobs, name}});
                const json m = {{"tiles", metrics.tiles.load()}, {"tags", cfg.tags}, {"passed_on", metrics.passed_on.load()},
                                {"failed_tasks", counts[0].is_nil() ? 0 : counts[0].as_int()},
                                {"blocklisted_jobs", counts[1].is_nil() ? 0 : counts[1].as_int()}, {"assemblies", metrics.assemblies.load()}, {"frames", metrics.frames.load()}, {"shot_opens", metrics.shot_opens.load()},
                                {"starts", metrics.starts.load()}, {"duplicates", metrics.duplicates.load()},
                                {"reclaimed", metrics.reclaimed.load()}, {"redis_errors", metrics.redis_errors.load()},
                                {"rays", metrics.rays.load()}, {"render_seconds", double(metrics.render_micros.load()) * 1e-6},
                                {"threads", cfg.threads}, {"scene_cache_hits", cache.hits()}, {"scene_cache_misses", cache.misses()},
                                // Its threads with a task in hand, now (an autoscaler's figure).
                                {"busy", std::min(1.0, double(now.size()) / double(std::max(1, cfg.threads)))},
                                {"last_seen", now_s()}, {"beat_s", std::chrono::duration<double>(period).count()}};
                r.command({"HSET", keys::nodes, name, json_text(m)});
            } catch (const RedisError& e) {
                ++metrics.redis_errors;
            }
            std::unique_lock lock(mu);
            wake.wait_for(lock, period, [&] { return stopping.load(); });
        }
    }
};

RenderNode::RenderNode(NodeConfig config) : impl_(std::make_unique<Impl>(std::move(config))) {}

RenderNode::~RenderNode() { stop(); }

void RenderNode::start() {
    Impl& m = *impl_;
    for (int i = 0; i < std::max(1, m.cfg.threads); ++i) m.threads.emplace_back([&m, i] { m.worker(i); });
    m.heartbeat = std::thread([&m] { m.beat(); });
    spdlog::info("render node {} on {} ({} threads, visibility {} ms)", m.name, m.cfg.redis.redacted(), m.cfg.threads, m.cfg.visibility_ms);
}

void RenderNode::stop() {
    Impl& m = *impl_;
    {
        std::lock_guard lock(m.mu);
        m.stopping = true;
        for (auto& [k, h] : m.held) *h.cancel = true;
    }
    m.wake.notify_all();
    for (auto& t : m.threads) if (t.joinable()) t.join();
    m.threads.clear();
    if (m.heartbeat.joinable()) m.heartbeat.join();
}

const std::string& RenderNode::name() const { return impl_->name; }
NodeMetrics& RenderNode::metrics() { return impl_->metrics; }
void RenderNode::drop_idle_scenes() { impl_->cache.drop_idle(); }
uint64_t RenderNode::scene_cache_hits() const { return impl_->cache.hits(); }
uint64_t RenderNode::scene_cache_misses() const { return impl_->cache.misses(); }

}  // namespace tessera::server
