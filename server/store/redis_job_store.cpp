#include "server/store/redis_job_store.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

#include "server/store/cluster_keys.h"
#include "server/store/cluster_lua.h"
#include "server/store/job_hash.h"

namespace tessera::server {

namespace {

constexpr size_t kMaxListLimit = 1000;

// Fields by name from job_hash.h; the record's own checks and its queueing here.
const RedisScript kInsert{job_hash_lua_prologue() + R"lua(
-- KEYS: job, seq, all jobs, prefix of per-state sets, queue, priorities, the lane's task stream, jobs per lane;
-- ARGV: the fields, then the lane
local lane = ARGV[#job_fields + 1]
if redis.call('EXISTS', KEYS[1]) == 1 then return redis.error_reply('UNIQUE constraint: job id ' .. job.id .. ' exists') end
local seq = redis.call('INCR', KEYS[2])
local hash = {'seq', seq}
for _, name in ipairs(job_fields) do
  hash[#hash + 1] = name
  hash[#hash + 1] = job[name]
end
hash[#hash + 1] = 'lane'
hash[#hash + 1] = lane
redis.call('HSET', KEYS[1], unpack(hash))
if job.state ~= 'succeeded' and job.state ~= 'failed' and job.state ~= 'canceled' then
  redis.call('HINCRBY', KEYS[8], lane, 1)  -- until it ends (transition)
end
redis.call('ZADD', KEYS[3], seq, job.id)
redis.call('ZADD', KEYS[4] .. job.state, seq, job.id)
if job.state == 'queued' then
  redis.call('ZADD', KEYS[5], string.format('%.0f', (1000 - tonumber(job.priority)) * 1e12 + seq), job.id)
  redis.call('ZADD', KEYS[6], job.priority, lane)
  redis.pcall('XGROUP', 'CREATE', KEYS[7], 'nodes', '0', 'MKSTREAM')
  redis.call('XADD', KEYS[7], '*', 'job', job.id, 'kind', 'start', 'pass', '0', 'tile', '0')
end
return seq
)lua"};

const RedisScript kTransition{lua::transition_job};
const RedisScript kPause{lua::pause_job};
const RedisScript kResume{lua::resume_job};
const RedisScript kRelease{lua::release_job};
const RedisScript kAppendLog{lua::append_log};
const RedisScript kReadLog{lua::read_log};
const RedisScript kPruneLanes{lua::prune_lanes};

const RedisScript kRemoveFinal{R"lua(
-- ARGV: prefix, id; KEYS: the job's cluster keys to drop with it
local k = ARGV[1] .. 'job:' .. ARGV[2]
local st = redis.call('HGET', k, 'state')
if st ~= 'succeeded' and st ~= 'failed' and st ~= 'canceled' then return 0 end
redis.call('DEL', k)
redis.call('ZREM', ARGV[1] .. 'jobs', ARGV[2])
redis.call('ZREM', ARGV[1] .. 'jobs:' .. st, ARGV[2])
for i = 1, #KEYS do redis.call('DEL', KEYS[i]) end
return 1
)lua"};

}  // namespace

template <class Fn>
auto RedisJobStore::locked(const char* op, Fn&& fn) const {
    std::lock_guard lock(mu_);
    try {
        return fn();
    } catch (const RedisError& e) {
        throw StoreError(std::string("job store: ") + op + ": " + e.what(), e.out_of_memory);
    }
}

RedisJobStore::RedisJobStore(const RedisUrl& url, int64_t max_bytes) : redis_(url), max_bytes_(max_bytes) {
    locked("connect", [&] { return redis_.command({"PING"}); });
}

RedisJobStore::~RedisJobStore() = default;

void RedisJobStore::set_max_bytes(int64_t max_bytes) {
    std::lock_guard lock(mu_);
    max_bytes_ = max_bytes;
}

namespace {

// The job's lane (cluster_keys.h): its priority and the node tags it requires.
std::string lane_of(const JobRecord& rec) {
    std::vector<std::string> tags;
    try {
        const nlohmann::json spec = nlohmann::json::parse(rec.spec_json);
        if (spec.is_object() && spec.contains("requires") && spec["requires"].is_array())
            for (const auto& t : spec["requires"])
                if (t.is_string()) tags.push_back(t.get<std::string>());
    } catch (const nlohmann::json::exception&) {
        // A record without a readable spec requires nothing: the priority's own lane.
    }
    std::sort(tags.begin(), tags.end());
    return keys::lane(rec.priority, tags);
}

// A stored job's lane; a record written before lanes existed is in its priority's.
std::string stored_lane(Redis& redis, const std::string& id, std::string& priority) {
    const RedisValue v = redis.command({"HMGET", keys::job(id), "priority", "lane"});
    if (v.items.size() < 2 || v.items[0].is_nil()) return "";
    priority = v.items[0].text;
    return v.items[1].is_nil() ? priority : v.items[1].text;
}

}  // namespace

void RedisJobStore::insert(JobRecord& rec) {
    locked("insert", [&] {
        if (max_bytes_ > 0) {
            const std::string info = redis_.command({"INFO", "memory"}).text;
            const size_t at = info.find("used_memory:");
            const long long used = at == std::string::npos ? 0 : std::atoll(info.c_str() + at + 12);
            if (used > max_bytes_)
                throw StoreError("job store: insert: Redis holds " + std::to_string(used) + " bytes, the bound is " +
                                     std::to_string(max_bytes_), true);
        }
        const std::string lane = lane_of(rec);
        // A bounded number of tag sets at once (prune_lanes removes those no job uses).
        if (lane.find('|') != std::string::npos && redis_.command({"ZSCORE", keys::priorities, lane}).is_nil()) {
            long long lanes = 0;  // of tags (a priority's own lane is bounded by the priorities)
            for (const auto& l : redis_.command({"ZRANGE", keys::priorities, "0", "-1"}).items) lanes += l.text.find('|') != std::string::npos;
            if (lanes >= keys::max_tag_lanes)
                throw StoreError("job store: insert: the farm's queue has " + std::to_string(lanes) +
                                     " lanes of required tags, its limit: a job requiring another set of tags waits until one empties",
                                 true);
        }
        std::vector<std::string> args = job_hash_arguments(rec);
        args.push_back(lane);
        const RedisValue seq = redis_.eval(kInsert,
                                           {keys::job(rec.id), keys::seq, keys::all_jobs, keys::jobs_in(""), keys::queue,
                                            keys::priorities, keys::lane_tasks(lane), keys::lane_jobs},
                                           args);
        rec.seq = seq.as_int();
        return 0;
    });
}

std::optional<JobRecord> RedisJobStore::get(const std::string& id) const {
    return locked("get", [&]() -> std::optional<JobRecord> {
        const RedisValue v = redis_.command({"HGETALL", keys::job(id)});
        if (v.items.empty()) return std::nullopt;
        return job_from_hash(v);
    });
}

std::vector<JobRecord> RedisJobStore::records(const std::vector<std::string>& ids) const {
    std::vector<std::vector<std::string>> cmds;
    for (const auto& id : ids) cmds.push_back({"HGETALL", keys::job(id)});
    std::vector<JobRecord> out;
    if (cmds.empty()) return out;
    for (const RedisValue& v : redis_.pipeline(cmds))
        if (!v.items.empty()) out.push_back(job_from_hash(v));  // removed meanwhile: skipped
    return out;
}

std::vector<JobRecord> RedisJobStore::list(std::optional<JobState> state, size_t offset, size_t limit) const {
    limit = std::min(limit, kMaxListLimit);
    return locked("list", [&] {
        if (limit == 0 || offset > size_t(1) << 50) return std::vector<JobRecord>{};
        const std::string key = state ? keys::jobs_in(to_string(*state)) : keys::all_jobs;
        std::vector<std::string> ids;
        for (const auto& v : redis_.command({"ZREVRANGE", key, std::to_string(offset), std::to_string(offset + limit - 1)}).items)
            ids.push_back(v.text);
        return records(ids);
    });
}

std::vector<std::string> RedisJobStore::ids(std::optional<JobState> state, size_t limit) const {
    return locked("ids", [&] {
        std::vector<std::string> out;
        if (limit == 0) return out;
        const std::string key = state ? keys::jobs_in(to_string(*state)) : keys::all_jobs;
        for (const auto& v : redis_.command({"ZREVRANGE", key, "0", std::to_string(limit - 1)}).items) out.push_back(v.text);
        return out;
    });
}

size_t RedisJobStore::count(std::optional<JobState> state) const {
    return locked("count", [&] {
        return size_t(redis_.command({"ZCARD", state ? keys::jobs_in(to_string(*state)) : keys::all_jobs}).as_int());
    });
}

bool RedisJobStore::mark_running(const std::string& id, double started_at) {
    return locked("mark running", [&] {
        return redis_.eval(kTransition, {}, {keys::prefix, id, "running", "queued", redis_number(started_at), "", ""}).as_int() == 1;
    });
}

bool RedisJobStore::finish(const std::string& id, JobState state, double finished_at, const std::string& error,
                           const std::string& report_json) {
    if (!is_final(state)) throw std::invalid_argument("job store: finish: " + std::string(to_string(state)) + " is not a final state");
    return locked("finish", [&] {
        return redis_.eval(kTransition, {}, {keys::prefix, id, to_string(state), "queued,waiting,running,paused", redis_number(finished_at), error, report_json})
                   .as_int() == 1;
    });
}

bool RedisJobStore::pause(const std::string& id) {
    return locked("pause", [&] { return redis_.eval(kPause, {keys::job(id)}, {keys::prefix, id}).as_int() == 1; });
}

bool RedisJobStore::resume(const std::string& id) {
    return locked("resume", [&] {
        std::string priority;
        const std::string lane = stored_lane(redis_, id, priority);
        if (lane.empty()) return false;
        return redis_.eval(kResume, {keys::job(id), keys::film(id), keys::lane_tasks(lane), keys::shot_chunks(id), keys::shot_done(id)},
                           {keys::prefix, id})
                   .as_int() == 1;
    });
}

bool RedisJobStore::release(const std::string& id) {
    return locked("release", [&] {
        std::string priority;
        const std::string lane = stored_lane(redis_, id, priority);
        if (lane.empty()) return false;
        return redis_.eval(kRelease, {keys::priorities, keys::lane_tasks(lane)}, {keys::prefix, id, priority, lane}).as_int() == 1;
    });
}

RedisJobStore::LogLines RedisJobStore::task_log(const std::string& id, size_t from, size_t limit, size_t bytes) const {
    return locked("task log", [&] {
        const RedisValue r = redis_.eval(kReadLog, {keys::task_log(id), keys::task_log_count(id)},
                                         {std::to_string(from), std::to_string(limit), std::to_string(bytes)});
        LogLines out{from, {}};
        if (!r.items.empty()) out.first = size_t(std::max(0ll, r.items[0].as_int()));
        for (size_t i = 1; i < r.items.size(); ++i) out.lines.push_back(r.items[i].text);
        return out;
    });
}

void RedisJobStore::append_task_log(const std::string& id, const std::string& line) {
    locked("task log", [&] {
        redis_.eval(kAppendLog, {keys::task_log(id), keys::task_log_count(id), keys::job(id)}, {line, std::to_string(keys::max_task_records)});
        return 0;
    });
}

std::vector<std::pair<int, size_t>> RedisJobStore::queued_by_priority() const {
    return locked("queue by priority", [&] {
        std::map<int, size_t> by;
        const RedisValue v = redis_.command({"ZRANGE", keys::queue, "0", "-1", "WITHSCORES"});
        for (size_t i = 1; i < v.items.size(); i += 2) {
            const double score = std::stod(v.items[i].text);
            ++by[1000 - int(std::floor(score / 1e12))];
        }
        return std::vector<std::pair<int, size_t>>(by.begin(), by.end());
    });
}

std::vector<RedisJobStore::StreamBacklog> RedisJobStore::task_backlog() const {
    return locked("task backlog", [&] {
        // Summed over a priority's lanes.
        std::map<int, StreamBacklog> by;
        const RedisValue lanes = redis_.command({"ZRANGE", keys::priorities, "0", "-1", "WITHSCORES"});
        for (size_t l = 0; l + 1 < lanes.items.size(); l += 2) {
            StreamBacklog b;
            b.priority = int(std::stod(lanes.items[l + 1].text));
            RedisValue groups;
            try {
                groups = redis_.command({"XINFO", "GROUPS", keys::lane_tasks(lanes.items[l].text)});
            } catch (const RedisError&) {
                continue;  // no stream (yet) for this priority
            }
            for (const RedisValue& g : groups.items) {
                // A flat list of field, value: name, consumers, pending, last-delivered-id, entries-read, lag.
                bool ours = false;
                for (size_t i = 0; i + 1 < g.items.size(); i += 2)
                    if (g.items[i].text == "name") ours = g.items[i + 1].text == keys::group;
                if (!ours) continue;
                for (size_t i = 0; i + 1 < g.items.size(); i += 2) {
                    if (g.items[i].text == "pending") b.pending = g.items[i + 1].as_int();
                    if (g.items[i].text == "lag" && !g.items[i + 1].is_nil()) b.lag = g.items[i + 1].as_int();
                }
            }
            auto [it, first] = by.try_emplace(b.priority, b);
            if (!first) {
                it->second.pending += b.pending;
                it->second.lag = it->second.lag < 0 || b.lag < 0 ? -1 : it->second.lag + b.lag;
            }
        }
        std::vector<StreamBacklog> out;
        for (auto& [p, b] : by) out.push_back(b);
        return out;
    });
}

bool RedisJobStore::claim_once(const std::string& what) {
    return locked("claim", [&] { return !redis_.command({"SET", keys::prefix + "claim:" + what, "1", "NX", "EX", "604800"}).is_nil(); });
}

bool RedisJobStore::requeue(const std::string& id) {
    return locked("requeue", [&] {
        return redis_.eval(kTransition, {}, {keys::prefix, id, "queued", "running", "0", "", ""}).as_int() == 1;
    });
}

int RedisJobStore::requeue_all_running() {
    std::vector<std::string> ids = locked("requeue all", [&] {
        std::vector<std::string> v;
        for (const auto& item : redis_.command({"ZRANGE", keys::jobs_in("running"), "0", "-1"}).items) v.push_back(item.text);
        return v;
    });
    int n = 0;
    for (const auto& id : ids) n += requeue(id) ? 1 : 0;
    return n;
}

std::vector<JobRecord> RedisJobStore::queued_in_order() const {
    return locked("queued", [&] {
        std::vector<std::string> ids;
        for (const auto& v : redis_.command({"ZRANGE", keys::queue, "0", "-1"}).items) ids.push_back(v.text);
        return records(ids);
    });
}

long long RedisJobStore::queue_position(const std::string& id) const {
    return locked("queue position", [&] {
        const RedisValue v = redis_.command({"ZRANK", keys::queue, id});
        return v.is_nil() ? -1LL : v.as_int();
    });
}

bool RedisJobStore::remove_final(const std::string& id) {
    return locked("remove", [&] {
        return redis_.eval(kRemoveFinal,
                           {keys::film(id), keys::deliveries(id), keys::node_tiles(id), keys::node_seconds(id), keys::curve(id),
                            keys::job_scene(id), keys::job_environment(id), keys::sums(id), keys::shot_chunks(id), keys::shot_done(id), keys::task_log(id), keys::task_log_count(id),
                            keys::failures(id), keys::failure_reasons(id), keys::blocklist(id)},
                           {keys::prefix, id})
                   .as_int() == 1;
    });
}

}  // namespace tessera::server

namespace tessera::server {

void RedisJobStore::put_scene(const std::string& job_id, const SceneRef& ref, const std::string* bytes) {
    locked("publish scene", [&] {
        std::vector<std::vector<std::string>> cmds;
        if (bytes) cmds.push_back({"SET", keys::scene(ref.hash), *bytes, "NX"});
        cmds.push_back({"SET", keys::job_scene(job_id), ref.encode()});
        redis_.pipeline(cmds);
        return 0;
    });
}

void RedisJobStore::put_environment(const std::string& job_id, const SceneRef& ref, const std::string& bytes) {
    locked("publish environment", [&] {
        redis_.pipeline({{"SET", keys::scene(ref.hash), bytes, "NX"}, {"SET", keys::job_environment(job_id), ref.encode()}});
        return 0;
    });
}

std::optional<RedisJobStore::LiveProgress> RedisJobStore::live_progress(const std::string& id) const {
    return locked("progress", [&]() -> std::optional<LiveProgress> {
        const RedisValue v = redis_.command({"HMGET", keys::job(id), "tiles_done", "tiles_total", "samples", "pass"});
        if (v.items.size() < 4 || v.items[1].is_nil()) return std::nullopt;
        LiveProgress p;
        p.tiles_done = size_t(v.items[0].as_int());
        p.tiles_total = size_t(v.items[1].as_int());
        p.samples = uint64_t(v.items[2].as_int());
        p.pass = int(v.items[3].as_int());
        return p;
    });
}

std::optional<api::TaskFailures> RedisJobStore::task_failures(const std::string& id) const {
    return locked("task failures", [&]() -> std::optional<api::TaskFailures> {
        const auto v = redis_.pipeline({{"HGET", keys::failures(id), "total"}, {"SMEMBERS", keys::blocklist(id)},
                                        {"LRANGE", keys::failure_reasons(id), "-5", "-1"}});
        if (v[0].is_nil()) return std::nullopt;
        api::TaskFailures f;
        f.failures = v[0].as_int();
        for (const auto& n : v[1].items) f.blocklisted.push_back(n.text);
        std::sort(f.blocklisted.begin(), f.blocklisted.end());
        for (const auto& r : v[2].items) f.latest.push_back(r.text);
        return f;
    });
}

long long RedisJobStore::prune_lanes() {
    return locked("prune lanes", [&] { return redis_.eval(kPruneLanes, {keys::priorities, keys::lane_jobs}, {keys::prefix}).as_int(); });
}

std::string RedisJobStore::lane(const std::string& id) const {
    return locked("lane", [&] {
        std::string priority;
        return stored_lane(redis_, id, priority);
    });
}

std::vector<std::pair<std::string, std::string>> RedisJobStore::nodes() const {
    return locked("nodes", [&] {
        std::vector<std::pair<std::string, std::string>> out;
        const RedisValue v = redis_.command({"HGETALL", keys::nodes});
        for (size_t i = 0; i + 1 < v.items.size(); i += 2) out.emplace_back(v.items[i].text, v.items[i + 1].text);
        return out;
    });
}

}  // namespace tessera::server
