#include "server/render_node.h"

#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>

#include <spdlog/spdlog.h>

#include "api/json_text.h"
#include "api/job.h"
#include "api/job_runner.h"
#include "engine/camera/camera.h"
#include "engine/core/scene_error.h"
#include "engine/io/image_io.h"
#include "engine/render/passes.h"
#include "engine/render/tile_context.h"
#include "engine/scene/environment.h"
#include "server/cluster_keys.h"
#include "server/cluster_lua.h"
#include "server/film_codec.h"
#include "server/scene_cache.h"

// A tile's error sums at one pass target of a straight-through job travel named: one list of
// fields for both directions, and reading uses at(), so sums from a node of another version fail
// the job naming the missing field, not silently. (In ErrorSums' namespace, where the JSON
// library looks for it.)
namespace tessera {
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(ErrorSums, spp, est, rel, mse, mae, pixels, est_pixels, half_buffer, reference, deep_outer,
                                   deep, deep_log_split, deep_pixels, shallow_outer, shallow, shallow_log_split, shallow_pixels)
}  // namespace tessera

namespace tessera::server {
using api::json_text;

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

using Clock = std::chrono::steady_clock;

double now_s() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }
long long now_ms() {
    return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
}

std::string num(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

struct Task {
    std::string stream, id, job, kind;
    int pass = 0, tile = 0;
    bool reclaimed = false;  // taken over from a silent node (not a first delivery)
    std::string key() const { return stream + " " + id; }
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
    }
    return t;
}

const RedisScript kBegin{lua::transition + lua::add_tiles + R"lua(
-- KEYS: job, stream; ARGV: prefix, id, now (s), now (ms), first target, tiles
if redis.call('HGET', KEYS[1], 'state') ~= 'queued' then return 0 end
transition(ARGV[1], ARGV[2], 'running', 'queued', ARGV[3], '', '')
redis.call('HSET', KEYS[1], 'pass', 0, 'target', ARGV[5], 'tiles_total', ARGV[6], 'tiles_done', 0, 'started_ms', ARGV[4],
           'samples', 0, 'rays_camera', 0, 'rays_shadow', 0, 'rays_bounce', 0, 'nodes_visited', 0, 'prim_tests', 0,
           'nonfinite', 0, 'max_sample', '0', 'timed_out', 0)
add_tiles(KEYS[2], ARGV[2], 0, tonumber(ARGV[6]))
return 1
)lua"};

const RedisScript kCommitTile{lua::commit_tile};

const RedisScript kAdvance{lua::add_tiles + R"lua(
-- KEYS: job, curve, stream; ARGV: id, pass, next target, point, tiles
if redis.call('HGET', KEYS[1], 'state') ~= 'running' then return 0 end
if tonumber(redis.call('HGET', KEYS[1], 'pass')) ~= tonumber(ARGV[2]) then return 0 end
redis.call('RPUSH', KEYS[2], ARGV[4])
local next = tonumber(ARGV[2]) + 1
redis.call('HSET', KEYS[1], 'pass', next, 'target', ARGV[3], 'tiles_done', 0)
add_tiles(KEYS[3], ARGV[1], next, tonumber(ARGV[5]))
return 1
)lua"};

const RedisScript kComplete{lua::transition + R"lua(
-- KEYS: job, curve; ARGV: prefix, id, pass, point, now, summary
if redis.call('HGET', KEYS[1], 'state') ~= 'running' then return 0 end
if tonumber(redis.call('HGET', KEYS[1], 'pass')) ~= tonumber(ARGV[3]) then return 0 end
redis.call('RPUSH', KEYS[2], ARGV[4])
return transition(ARGV[1], ARGV[2], 'succeeded', 'running', ARGV[5], '', ARGV[6])
)lua"};

const RedisScript kTransition{lua::transition + R"lua(
return transition(ARGV[1], ARGV[2], ARGV[3], ARGV[4], ARGV[5], ARGV[6], ARGV[7])
)lua"};

// Renews a claim only while it is still this consumer's: a node resumed after a long stop must
// not take back a task another node has claimed meanwhile.
const RedisScript kRenew{R"lua(
-- KEYS: stream; ARGV: id, consumer
local p = redis.call('XPENDING', KEYS[1], 'nodes', ARGV[1], ARGV[1], 1, ARGV[2])
if #p == 0 then return 0 end
redis.call('XCLAIM', KEYS[1], 'nodes', ARGV[2], 0, ARGV[1], 'JUSTID')
return 1
)lua"};

json point_json(const ConvergencePoint& p) {
    return {{"seconds", p.seconds}, {"spp_mean", p.spp_mean}, {"rel_mse", p.rel_mse}, {"mse", p.mse}, {"mae", p.mae},
            {"est_rel_mse", p.est_rel_mse}};
}

ConvergencePoint point_from(const json& j) {
    ConvergencePoint p;
    p.seconds = j.value("seconds", 0.0);
    p.spp_mean = j.value("spp_mean", 0.0);
    p.rel_mse = j.value("rel_mse", -1.0);
    p.mse = j.value("mse", -1.0);
    p.mae = j.value("mae", -1.0);
    p.est_rel_mse = j.value("est_rel_mse", -1.0);
    return p;
}

// A job as a node runs it: parsed once per node (the stored job never changes).
struct JobInfo {
    api::Job job;
    SceneRef ref;
    RenderSettings settings;  // a render job's, as nodes render it
    PassPlan plan;
    std::optional<Image> reference;
    // No stop rule needs the whole image between passes (the job stops on spp): each tile is
    // rendered through every pass target on the node that takes it, in one task, measuring its
    // own error after each target. The sums match pass-by-pass rendering's (samples are added
    // in the same order), without a barrier per pass.
    bool straight = false;
    std::vector<int> targets;  // the pass targets, 1, 2, 4, …, spp
};

TileRect tile_rect(const RenderSettings& s, int index) {
    const int size = std::max(1, s.tile_size);
    const int per_row = (s.width + size - 1) / size;
    const int x = (index % per_row) * size, y = (index / per_row) * size;
    return {x, y, std::min(x + size, s.width), std::min(y + size, s.height)};
}

int tile_count(const RenderSettings& s) {
    const int size = std::max(1, s.tile_size);
    return ((s.width + size - 1) / size) * ((s.height + size - 1) / size);
}

// A job's settings as its scene renders them: a scene without lights gets the default sky, as
// the one-process server's runner gives it, so the farm's image is the same.
RenderSettings lit(const RenderSettings& job, const RenderScene& scene) {
    RenderSettings s = job;
    if (!s.environment && !scene.has_lights()) s.environment = api::default_environment();
    return s;
}

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
    struct RunState {
        std::string state;
        long long pass = -1, target = 0, started_ms = 0;
        Clock::time_point read;
    };
    std::map<std::string, RunState> states;

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
        const auto v = r.pipeline({{"HGET", keys::job(id), "spec"}, {"GET", keys::job_scene(id)}, {"GET", keys::job_environment(id)}});
        if (v[0].is_nil()) return nullptr;
        auto info = std::make_shared<JobInfo>();
        info->job = api::job_from_json(json::parse(v[0].text));
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
                // Named by the API node's path, as one process's report names it.
                auto map = std::make_shared<EnvironmentMap>(*api::load_environment(cache.file_for(r, env)));
                map->source = env.source;
                info->settings.environment = std::move(map);
            }
            if (!rj->reference.empty()) {
                const fs::path ref = fs::path(cfg.data_dir) / "jobs" / rj->reference / "image.exr";
                if (!fs::exists(ref)) throw JobFailure("the reference job's image was deleted");
                info->reference = read_image(ref.string());
            }
            info->plan = plan_passes(info->settings, info->reference.has_value(), false);
            const RenderSettings& s = info->settings;
            info->straight = !info->plan.adaptive && s.target_error <= 0 && s.time_limit_s <= 0;
            for (int t = 0, k = 0; k < info->plan.max_passes; ++k) {
                t = pass_target(s, info->plan, t);
                info->targets.push_back(t);
                if (t >= s.spp) break;
            }
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
        if (r.eval(kTransition, {}, {keys::prefix, id, "failed", "queued,running", num(now_s()), why, ""}).as_int() == 1)
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
        for (const auto& p : r.command({"ZREVRANGEBYSCORE", keys::priorities, "+inf", "-inf"}).items) s.push_back(keys::tasks(std::stoll(p.text)));
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
            const Task t = local.front();
            local.pop_front();
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
        try {
            // A first delivery needs no count; a task taken over from a silent node counts the
            // takeovers, so a task that kills every node that takes it fails its job.
            if (t.reclaimed) {
                const std::string what = t.kind == "tile" ? "tile " + std::to_string(t.tile) + " of pass " + std::to_string(t.pass)
                                                          : "the " + t.kind + " task" + (t.kind == "assemble" ? " of pass " + std::to_string(t.pass) : "");
                const long long taken =
                    r.command({"HINCRBY", keys::deliveries(t.job), t.kind + ":" + std::to_string(t.pass) + ":" + std::to_string(t.tile), "1"}).as_int();
                if (taken + 1 > cfg.max_deliveries)
                    throw JobFailure(what + " was delivered " + std::to_string(taken + 1) +
                                     " times: the nodes that took it stopped answering (crashed, killed, out of memory?)");
            }
            if (t.kind == "tile") {
                if (tile(r, t, cancel, acked)) return;
            } else if (t.kind == "assemble") assemble(r, t);
            else if (t.kind == "start") begin(r, t, cancel);
            else spdlog::warn("node {}: unknown task kind '{}' dropped", name, t.kind);
        } catch (const RedisError&) {
            throw;
        } catch (const SceneError& e) {
            fail_job(r, t.job, std::string("scene: ") + e.what());
        } catch (const std::exception& e) {
            fail_job(r, t.job, e.what());
        }
        if (!stopping && !lost) {
            acked = true;
            ack(r, t);
        }
    }

    void begin(Redis& r, const Task& t, std::atomic<bool>& cancel) {
        const RedisValue st = r.command({"HGET", keys::job(t.job), "state"});
        const auto info = st.text == "queued" || st.text == "running" ? job_info(r, t.job) : nullptr;
        // A comparison whose node died or stopped mid-run is still "running": it runs again here.
        const bool rerun = st.text == "running" && info && std::holds_alternative<api::ComparisonJob>(info->job);
        if (st.text != "queued" && !rerun) { ++metrics.duplicates; return; }
        if (!info) return;
        ++metrics.starts;
        if (const auto* cj = std::get_if<api::ComparisonJob>(&info->job)) return compare(r, t, *cj, cancel);
        const auto& rj = std::get<api::RenderJob>(info->job);
        cache.get(r, info->ref, rj.scene_options);  // a scene that does not load fails the job here, once
        const int n = tile_count(info->settings);
        if (r.eval(kBegin, {keys::job(t.job), t.stream},
                   {keys::prefix, t.job, num(now_s()), std::to_string(now_ms()),
                    std::to_string(info->straight ? info->settings.spp : pass_target(info->settings, info->plan, 0)),
                    std::to_string(n)}).as_int() == 1)
            spdlog::info("node {}: job {} running: {} tiles per pass", name, t.job, n);
    }

    // A comparison runs whole here: its configurations race each other for equal time, which
    // tiles spread over nodes would not keep equal.
    void compare(Redis& r, const Task& t, const api::ComparisonJob& job, std::atomic<bool>& cancel) {
        const std::string state = r.command({"HGET", keys::job(t.job), "state"}).text;
        if (state != "running" &&
            r.eval(kTransition, {}, {keys::prefix, t.job, "running", "queued", num(now_s()), "", ""}).as_int() != 1)
            return;  // canceled meanwhile
        api::RunOptions opt;
        const auto info = job_info(r, t.job);
        // The comparison loads the scene itself (each configuration builds its own BVH): only
        // the file is needed here.
        opt.scene_source = cache.file_for(r, info->ref);
        opt.load_limits = cfg.load_limits;
        opt.threads = 1;
        opt.job_id = t.job;
        const fs::path dir = fs::path(cfg.data_dir) / "jobs" / t.job;
        fs::create_directories(dir);
        api::RunCallbacks cb;
        cb.stop = &cancel;
        const api::JobOutcome out = api::run_job(job, opt, api::RunOutputs::in_directory(dir.string()), cb);
        if (out.stopped) return;
        r.eval(kTransition, {}, {keys::prefix, t.job, "succeeded", "running", num(now_s()), "", json_text(out.summary)});
    }

    // The state of a job's run as a tile needs it (see run_state).
    RunState run_state(Redis& r, const std::string& id, int pass) {
        {
            std::lock_guard lock(mu);
            auto it = states.find(id);
            if (it != states.end() && it->second.state == "running" && it->second.pass == pass &&
                Clock::now() - it->second.read < std::chrono::milliseconds(50))
                return it->second;
        }
        const RedisValue v = r.command({"HMGET", keys::job(id), "state", "pass", "target", "started_ms"});
        RunState st;
        st.state = v.items[0].text;
        st.pass = v.items[1].is_nil() ? -1 : v.items[1].as_int();
        st.target = v.items[2].is_nil() ? 0 : v.items[2].as_int();
        st.started_ms = v.items[3].is_nil() ? 0 : v.items[3].as_int();
        st.read = Clock::now();
        std::lock_guard lock(mu);
        if (states.size() > 1024) states.clear();
        states[id] = st;
        return st;
    }

    // Returns whether the task was acknowledged (the commit script does it with the result).
    bool tile(Redis& r, const Task& t, std::atomic<bool>& cancel, std::atomic<bool>& acked) {
        const RunState js = run_state(r, t.job, t.pass);
        if (js.state != "running" || js.pass != t.pass) { ++metrics.duplicates; return false; }
        const int target = int(js.target);
        const long long started_ms = js.started_ms;
        const auto info = job_info(r, t.job);
        if (!info) return false;
        const auto& rj = std::get<api::RenderJob>(info->job);
        const auto prepared = cache.get(r, info->ref, rj.scene_options);
        const RenderSettings s = lit(info->settings, prepared->scene);
        const TileRect rect = tile_rect(s, t.tile);
        Film film = Film::tile(rect.x0, rect.y0, rect.width(), rect.height(), info->plan.half_buffer, info->plan.adaptive);
        if (t.pass > 0) {
            const RedisValue f = r.command({"HGET", keys::film(t.job), "t" + std::to_string(t.tile)});
            if (f.is_nil()) throw JobFailure("the film of tile " + std::to_string(t.tile) + " is missing from Redis");
            film = decode_film(f.text);
        }
        const long long deadline = s.time_limit_s > 0 ? started_ms + (long long)(s.time_limit_s * 1000.0) : 0;
        auto late = [&] { return deadline && now_ms() > deadline; };
        auto interrupted = [&] { return cancel.load() || stopping.load(); };
        const auto t0 = Clock::now();
        const Camera camera = camera_for(prepared->scene, s);  // the context keeps a reference
        TileContext ctx(prepared->scene, s, camera);
        bool timed_out = late();
        json sums;  // straight through: per pass target, the tile's error sums and when it got there
        if (info->straight) {
            const Image* ref = info->reference ? &*info->reference : nullptr;
            for (int k : info->targets) {
                if (!render_tile(ctx, rect, film, k, interrupted)) break;
                const ErrorSums e = error_sums(film, ref);
                json j = e;
                j["target"] = k;
                j["at_ms"] = now_ms();
                sums.push_back(std::move(j));
            }
        } else if (!timed_out && !interrupted()) {
            timed_out = !render_tile(ctx, rect, film, target, [&] { return late() || interrupted(); }) && !interrupted();
        }
        if (interrupted()) return false;  // canceled, taken over, or the node stops: nothing stored
        const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
        const RenderStats& st = ctx.stats;
        // A job rendered straight through is finished with this tile: it ships the resolved
        // pixels. A pass-by-pass job's next pass goes on from the whole film.
        const std::string payload = info->straight ? encode_tile_image(film) : encode_film(film);
        acked = true;
        const long long rc = r.eval(kCommitTile,
                                    {keys::job(t.job), keys::film(t.job), keys::node_tiles(t.job), keys::node_seconds(t.job), t.stream,
                                     keys::sums(t.job)},
                                    {t.job, std::to_string(t.tile), std::to_string(t.pass), payload, name, num(seconds),
                                     timed_out ? "1" : "0", std::to_string(st.samples), std::to_string(st.camera_rays),
                                     std::to_string(st.shadow_rays), std::to_string(st.bounce_rays),
                                     std::to_string(st.traversal.nodes_visited), std::to_string(st.traversal.prim_tests),
                                     std::to_string(st.nonfinite_samples), num(st.max_sample), sums.is_null() ? std::string() : json_text(sums),
                                     t.id, keys::group})
                                .as_int();
        if (rc == 1) {
            ++metrics.tiles;
            metrics.rays += st.rays();
            metrics.render_micros += uint64_t(seconds * 1e6);
        } else {
            ++metrics.duplicates;  // another node stored it first: the same film, dropped
        }
        return true;
    }

    void assemble(Redis& r, const Task& t) {
        const RedisValue v = r.command({"HMGET", keys::job(t.job), "state", "pass", "target", "tiles_total", "started_ms", "timed_out",
                                        "samples", "rays_camera", "rays_shadow", "rays_bounce", "nodes_visited", "prim_tests",
                                        "nonfinite", "max_sample"});
        if (v.items[0].text != "running" || v.items[1].is_nil() || v.items[1].as_int() != t.pass) { ++metrics.duplicates; return; }
        const auto info = job_info(r, t.job);
        if (!info) return;
        const RenderSettings& s = info->settings;
        const PassPlan& plan = info->plan;
        const int target = int(v.items[2].as_int());
        const int n = int(v.items[3].as_int());
        // A straight-through job's tiles are resolved pixels; a pass-by-pass job's are films.
        Film film(info->straight ? 1 : s.width, info->straight ? 1 : s.height, plan.half_buffer, plan.adaptive);
        Image image(info->straight ? s.width : 0, info->straight ? s.height : 0);
        const RedisValue tiles = r.command({"HGETALL", keys::film(t.job)});
        int found = 0;
        for (size_t i = 0; i + 1 < tiles.items.size(); i += 2) {
            const std::string& field = tiles.items[i].text;
            if (field.empty() || field[0] != 't') continue;
            if (info->straight) {
                place_tile(decode_tile_image(tiles.items[i + 1].text), image);
            } else {
                const Film tf = decode_film(tiles.items[i + 1].text);
                copy_tile_into(tf, {tf.x0, tf.y0, tf.x0 + tf.width, tf.y0 + tf.height}, film);
            }
            ++found;
        }
        if (found != n) throw JobFailure("pass " + std::to_string(t.pass) + " has " + std::to_string(found) + " of " + std::to_string(n) + " tiles in Redis");
        const long long started_ms = v.items[4].as_int();
        const double seconds = double(now_ms() - started_ms) / 1000.0;
        if (info->straight) return finish_straight(r, t, *info, std::move(image), film, v, n, started_ms);
        ConvergencePoint pt;
        if (plan.measuring) pt = measure_error(film, info->reference ? &*info->reference : nullptr);
        else pt.spp_mean = double(v.items[6].as_int()) / (double(s.width) * s.height);
        pt.seconds = seconds;
        std::optional<StopReason> stop = stop_after_pass(s, plan, film, target, pt, v.items[5].as_int() == 1, false);
        if (!stop && t.pass + 1 >= plan.max_passes) stop = StopReason::spp;
        ++metrics.assemblies;
        if (!stop) {
            r.eval(kAdvance, {keys::job(t.job), keys::curve(t.job), t.stream},
                   {t.job, std::to_string(t.pass), std::to_string(pass_target(s, plan, target)), json_text(point_json(pt)), std::to_string(n)});
            return;
        }
        RenderResult result;
        for (const auto& p : r.command({"LRANGE", keys::curve(t.job), "0", "-1"}).items) result.curve.points.push_back(point_from(json::parse(p.text)));
        result.curve.points.push_back(pt);
        result.curve.stop = *stop;
        write_results(r, t, *info, film.resolve(), film, v, n, seconds, std::move(result), pt);
    }

    // A straight-through job's only assembly: the curve from every tile's sums per pass target
    // (a point's time is when the last tile reached that target).
    void finish_straight(Redis& r, const Task& t, const JobInfo& info, Image image, const Film& buffers, const RedisValue& v, int n,
                         long long started_ms) {
        std::vector<ErrorSums> total(info.targets.size());
        std::vector<long long> reached(info.targets.size(), started_ms);
        std::vector<int> tiles_at(info.targets.size(), 0);
        const RedisValue all = r.command({"HGETALL", keys::sums(t.job)});
        for (size_t i = 0; i + 1 < all.items.size(); i += 2) {
            const json per = json::parse(all.items[i + 1].text);
            for (size_t k = 0; k < per.size() && k < total.size(); ++k) {
                const json& p = per[k];
                total[k].add(p.get<ErrorSums>());
                reached[k] = std::max(reached[k], p.at("at_ms").get<long long>());
                ++tiles_at[k];
            }
        }
        RenderResult result;
        for (size_t k = 0; k < total.size(); ++k) {
            if (tiles_at[k] != n) break;  // a tile stopped short (cannot happen without a time limit)
            ConvergencePoint pt = total[k].point();
            pt.seconds = double(reached[k] - started_ms) / 1000.0;
            result.curve.points.push_back(pt);
        }
        result.curve.stop = StopReason::spp;
        const ConvergencePoint last = result.curve.points.empty() ? ConvergencePoint{} : result.curve.points.back();
        write_results(r, t, info, std::move(image), buffers, v, n, double(now_ms() - started_ms) / 1000.0, std::move(result), last);
    }

    // The last pass: the results, then the job's state (a node that dies in between leaves the
    // task to another, which writes the same files again). `buffers` says which film buffers the
    // render kept (the report lists them).
    void write_results(Redis& r, const Task& t, const JobInfo& info, Image image, const Film& buffers, const RedisValue& v, int n,
                       double seconds, RenderResult result, const ConvergencePoint& pt) {
        const auto& rj = std::get<api::RenderJob>(info.job);
        const auto prepared = cache.get(r, info.ref, rj.scene_options);
        const RenderSettings s = lit(info.settings, prepared->scene);
        result.image = std::move(image);
        RenderStats& st = result.stats;
        st.samples = uint64_t(v.items[6].as_int());
        st.camera_rays = uint64_t(v.items[7].as_int());
        st.shadow_rays = uint64_t(v.items[8].as_int());
        st.bounce_rays = uint64_t(v.items[9].as_int());
        st.traversal.nodes_visited = uint64_t(v.items[10].as_int());
        st.traversal.prim_tests = uint64_t(v.items[11].as_int());
        st.nonfinite_samples = uint64_t(v.items[12].as_int());
        st.max_sample = std::stof(v.items[13].text);
        st.render_seconds = seconds;
        describe_render(prepared->scene, s, buffers, result.built, result.left_out);
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
        done.tiles_done = done.tiles_total = size_t(n);
        for (auto& [node, share] : by_node) done.nodes.push_back(share);
        // Written beside the final place and renamed into it: API nodes never serve half a file.
        const fs::path dir = fs::path(cfg.data_dir) / "jobs" / t.job;
        const fs::path part = dir / (".part-" + name + "-" + std::to_string(std::hash<std::thread::id>{}(std::this_thread::get_id()) % 100000));
        fs::create_directories(part);
        api::RunOptions opt;
        opt.job_id = t.job;
        const api::JobOutcome out = api::write_render(done, opt, api::RunOutputs::in_directory(part.string()));
        for (const auto& e : fs::directory_iterator(part)) fs::rename(e.path(), dir / e.path().filename());
        fs::remove_all(part);
        if (r.eval(kComplete, {keys::job(t.job), keys::curve(t.job)},
                   {keys::prefix, t.job, std::to_string(t.pass), json_text(point_json(pt)), num(now_s()), json_text(out.summary)}).as_int() == 1)
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
                    const std::string st = r.command({"HGET", keys::job(h.task.job), "state"}).text;
                    if (st != "running" && st != "queued") *h.cancel = true;  // canceled (or gone): stop within a row
                }
                const json m = {{"tiles", metrics.tiles.load()}, {"assemblies", metrics.assemblies.load()},
                                {"starts", metrics.starts.load()}, {"duplicates", metrics.duplicates.load()},
                                {"reclaimed", metrics.reclaimed.load()}, {"redis_errors", metrics.redis_errors.load()},
                                {"rays", metrics.rays.load()}, {"render_seconds", double(metrics.render_micros.load()) * 1e-6},
                                {"threads", cfg.threads}, {"scene_cache_hits", cache.hits()}, {"scene_cache_misses", cache.misses()},
                                {"last_seen", now_s()}};
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

}  // namespace tessera::server
