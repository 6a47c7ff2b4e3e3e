#include "server/farm/farm_queue.h"

#include "api/json_text.h"

#include <algorithm>
#include <chrono>

#include <spdlog/spdlog.h>

#include "server/queue/local_queue.h"
#include "server/store/job_results.h"
#include "server/store/scene_ref.h"

namespace tessera::server {
using nlohmann::json;

std::unique_ptr<JobQueue> open_job_queue(const ServiceConfig& config) {
    if (!config.redis_url.empty()) return std::make_unique<FarmQueue>(config);
    QueueConfig local = config;
    local.scene_cache_mb = config.node.scene_cache_mb;
    local.scene_cache_idle_s = config.node.scene_cache_idle_s;
    local.tags = config.node.tags;
    return std::make_unique<LocalQueue>(local);
}

FarmQueue::FarmQueue(const ServiceConfig& config) : JobQueue(config) {
    const RedisUrl url = RedisUrl::parse(config.redis_url);
    auto rs = std::make_unique<RedisJobStore>(url, config_.max_store_bytes);
    redis_ = rs.get();
    store_ = std::move(rs);
    if (config.render_locally) {
        NodeConfig nc = config.node;
        nc.redis = url;
        nc.data_dir = config_.data_dir;
        nc.threads = config_.render_threads > 0 ? config_.render_threads : int(std::max(1u, std::thread::hardware_concurrency()));
        nc.load_limits = config_.load_limits;
        nc.checkpoint_s = config_.checkpoint_s;
        node_ = std::make_unique<RenderNode>(nc);
        node_->start();
    }
    std::optional<Look> first;
    try {
        first = look();
    } catch (const std::exception& e) {
        spdlog::warn("events: cannot read the farm's jobs: {}", e.what());
    }
    start_notifier("api");
    watcher_ = std::thread([this, first = std::move(first)]() mutable { watch(std::move(first)); });
}

void FarmQueue::record_task(const std::string& job, const TaskRecord& task) {
    try {
        redis_->append_task_log(job, api::json_text(to_json(task)));
    } catch (const std::exception& e) {
        spdlog::warn("job {}: a notification's log line was not stored: {}", job, e.what());
    }
}

bool FarmQueue::claim_notification(const std::string& id, const std::string& event) { return redis_->claim_once("notified:" + id + ":" + event); }

FarmQueue::~FarmQueue() { shutdown(); }

void FarmQueue::shutdown() {
    stop_notifier();
    accepting_ = false;
    {
        std::lock_guard<std::mutex> lock(stop_mutex_);
        stopping_ = true;
    }
    stop_cv_.notify_all();
    if (watcher_.joinable()) watcher_.join();
    events_.close();
    // The node hands its tasks in hand back to the others.
    if (node_) node_->stop();
    node_.reset();
}

std::vector<std::pair<std::string, std::string>> FarmQueue::render_nodes() { return redis_->nodes(); }

SceneCacheCounts FarmQueue::scene_cache_counts() const {
    if (!node_) return {};
    return {node_->scene_cache_hits(), node_->scene_cache_misses()};
}

void FarmQueue::release_memory() {
    if (node_) node_->drop_idle_scenes();
    JobQueue::release_memory();
}

std::string FarmQueue::store_unreachable() {
    try {
        store_->count(JobState::queued);
    } catch (const StoreError& e) {
        return std::string("Redis does not answer: ") + e.what();
    }
    return "";
}

void FarmQueue::publish_scene(const std::string& id, const std::string& scene) {
    const auto entry = catalog_.find(scene.substr(0, scene.find('?')));
    if (!entry)
        throw QueueError(QueueErrorKind::not_found, "unknown-scene", "Unknown scene", "no scene named '" + scene + "'")
            .with_field("/scene");
    if (entry->source == "builtin") {
        redis_->put_scene(id, SceneRef{scene, "", "", scene}, nullptr);
        return;
    }
    const auto file = read_scene_file(entry->path);
    if (!file)
        throw QueueError(QueueErrorKind::unavailable, "scene-unreadable", "Scene unreadable", "cannot read scene '" + scene + "'")
            .with_retry_after(10);
    SceneRef ref = file->ref;
    ref.name = entry->shown;
    redis_->put_scene(id, ref, &file->bytes);
}

void FarmQueue::publish_environment(const std::string& id, const std::string& name) {
    const auto entry = catalog_.find_environment(name);
    if (!entry)
        throw QueueError(QueueErrorKind::not_found, "unknown-environment", "Unknown environment map",
                         "no environment map named '" + name + "'").with_field("/environment");
    const auto file = read_scene_file(entry->path);
    if (!file)
        throw QueueError(QueueErrorKind::unavailable, "scene-unreadable", "Scene unreadable",
                         "cannot read environment map '" + name + "'").with_retry_after(10);
    SceneRef ref = file->ref;
    ref.name = entry->shown;
    redis_->put_environment(id, ref, file->bytes);
}

api::JobStatus FarmQueue::enqueue(const api::Job& job, JobRecord rec) {
    try {
        // Jobs waiting for others count too: each will be queued.
        const size_t queued_now = store_->count(JobState::queued) + store_->count(JobState::waiting);
        if (queued_now >= config_.max_queued)
            throw QueueError(QueueErrorKind::queue_full, "queue-full", "The queue is full",
                             "the queue holds " + std::to_string(queued_now) + " jobs (queued or waiting), its limit").with_retry_after(10);
        publish_scene(rec.id, api::scene_of(job));
        if (const auto* rj = std::get_if<api::RenderJob>(&job); rj && !rj->environment.empty())
            publish_environment(rec.id, rj->environment);
        store_->insert(rec);  // durable in Redis, and its first task queued, before it is acknowledged
        store_wrote();
    } catch (const StoreError& e) {
        throw refused_submission(e);
    }
    // The watcher publishes "created" when it sees the job.
    queued(rec.id, job, rec.priority);
    return status_of(rec);
}

namespace {

double now_unix() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }

// Why no live node can take a job's tasks now; "" when one can.
std::string unplaceable(const std::vector<FarmNode>& nodes, const std::vector<std::string>& need, const api::TaskFailures* failures) {
    const double now = now_unix();
    std::vector<const FarmNode*> live;
    for (const FarmNode& n : nodes)
        if (is_live(n, now)) live.push_back(&n);
    if (live.empty()) return "no render node is live (none has sent a heartbeat in the last " + std::to_string(int(kNodeLiveSeconds)) + " s)";
    std::string offered;
    size_t tagged = 0, able = 0;
    for (const FarmNode* n : live) {
        if (!has_tags(*n, need)) {
            offered += (offered.empty() ? "" : ", ") + n->name + " [" + api::json_text(n->tags).substr(1);
            offered.pop_back();
            offered += "]";
            continue;
        }
        ++tagged;
        const bool listed = failures && std::find(failures->blocklisted.begin(), failures->blocklisted.end(), n->name) != failures->blocklisted.end();
        if (!listed) ++able;
    }
    if (able > 0) return "";
    if (tagged == 0)
        return "no live render node has every tag the job requires (" + api::json_text(need) + "); live nodes: " + offered;
    return "every live render node that has its tags is blocklisted for it";
}

}  // namespace

std::vector<FarmNode> FarmQueue::farm_nodes() {
    std::lock_guard lock(nodes_mutex_);
    if (std::chrono::steady_clock::now() - nodes_read_ > std::chrono::seconds(1)) {
        nodes_ = parse_farm_nodes(redis_->nodes());
        nodes_read_ = std::chrono::steady_clock::now();
    }
    return nodes_;
}

nlohmann::json FarmQueue::node_report() {
    nlohmann::json out = nlohmann::json::array();
    const double now = now_unix();
    try {
        for (const FarmNode& n : parse_farm_nodes(redis_->nodes())) out.push_back(to_json(n, now));
    } catch (const StoreError& e) {
        throw store_refusal(e);
    }
    return out;
}

void FarmQueue::add_live(api::JobStatus& st, const JobRecord& rec, bool) {
    try {
        st.task_failures = redis_->task_failures(rec.id);  // kept until the job is removed
        if (rec.state == JobState::queued || rec.state == JobState::running) {
            std::vector<std::string> need;
            if (st.settings.is_object() && st.settings.contains("requires") && st.settings["requires"].is_array())
                for (const auto& t : st.settings["requires"]) need.push_back(t.get<std::string>());
            std::sort(need.begin(), need.end());
            st.unplaceable = unplaceable(farm_nodes(), need, st.task_failures ? &*st.task_failures : nullptr);
        }
        if (rec.state == JobState::queued) {
            // Not in the run order any more: taken meanwhile, starting.
            const long long pos = redis_->queue_position(rec.id);
            st.queue_position = pos >= 0 ? size_t(pos) : 0;
        } else if (rec.state == JobState::running) {
            if (const auto p = redis_->live_progress(rec.id))
                st.live_progress = api::job_progress(api::job_from_json(st.settings), p->samples, p->tiles_done, p->tiles_total);
        }
    } catch (const std::exception&) {
        // Progress is a courtesy (a store refusal, a record of another version): the record
        // itself was read.
    }
}

api::JobStatus FarmQueue::cancel(const std::string& id) {
    status(id);  // not_found for unknown ids
    // Queued or running alike: nodes drop its tasks, and stop a tile in hand within a row.
    try {
        if (store_->finish(id, JobState::canceled, unix_time_s(), "", "")) {
            spdlog::info("job {} canceled", id);
            remove_checkpoints(job_dir(id));  // a shot's frames' (a node stopping writes one as it goes)
        }
    } catch (const StoreError& e) {
        throw store_refusal(e);
    }
    publish_state(id);  // its end's event and notification, whatever the watcher sees
    settle_waiting();
    return status(id);
}

api::JobStatus FarmQueue::pause(const std::string& id) {
    const api::JobStatus st = status(id);
    if (is_final(st.state)) throw job_finished(id, to_string(st.state), "paused");
    if (st.state == JobState::waiting) throw waiting_job(id);
    try {
        // A still keeps its film in Redis; a shot its frames written and the frame in hand's
        // checkpoint in the shared folder; a comparison, a race at equal time, runs again whole.
        if (store_->pause(id)) spdlog::info("job {} paused; its nodes drop its tasks and keep what they rendered", id);
    } catch (const StoreError& e) {
        throw store_refusal(e);
    }
    return status(id);
}

api::JobStatus FarmQueue::resume(const std::string& id) {
    const api::JobStatus st = status(id);
    if (is_final(st.state)) throw job_finished(id, to_string(st.state), "resumed");
    try {
        if (store_->resume(id)) spdlog::info("job {} resumed", id);
    } catch (const StoreError& e) {
        throw store_refusal(e);
    }
    return status(id);
}

LogPage FarmQueue::job_log(const std::string& id, size_t from, size_t limit) {
    status(id);
    try {
        const auto got = redis_->task_log(id, from, limit, kMaxLogPageBytes);
        LogPage page{{}, got.first + got.lines.size()};
        for (const std::string& line : got.lines) page.ndjson += line + "\n";
        return page;
    } catch (const StoreError& e) {
        throw store_refusal(e);
    }
}

size_t FarmQueue::queue_depth() { return store_->count(JobState::queued); }

std::map<int, size_t, std::greater<int>> FarmQueue::queued_by_priority() {
    std::map<int, size_t, std::greater<int>> by;
    for (const auto& [priority, n] : redis_->queued_by_priority()) by[priority] = n;
    return by;
}

std::vector<JobQueue::TaskBacklog> FarmQueue::task_backlog() {
    std::vector<TaskBacklog> out;
    for (const auto& b : redis_->task_backlog()) out.push_back({b.priority, b.lag, b.pending});
    return out;
}

FarmQueue::Look FarmQueue::look() {
    // A look reads ids only (three sorted-set ranges) and the progress of running jobs.
    Look now;
    for (const std::string& id : redis_->ids(JobState::queued, 1000)) now[id] = {Seen::queued, 0};
    for (const std::string& id : redis_->ids(JobState::running, 1000)) {
        const auto p = redis_->live_progress(id);
        now[id] = {Seen::running, p ? p->samples : 0};
    }
    // The newest jobs, whatever their state: one that came and went between two looks.
    for (const std::string& id : redis_->ids(std::nullopt, 50)) now.emplace(id, std::pair{Seen::other, uint64_t(0)});
    return now;
}

void FarmQueue::watch(std::optional<Look> first) {
    // What each job looked like at the last look, kept up to date even while no one listens,
    // so that nothing is missed in the gap while a client reconnects. Records are read for the
    // jobs that changed, and only when someone listens. Without a first look (Redis was not
    // there at start), the first one here is the baseline.
    bool baseline = !first;
    Look seen = first ? std::move(*first) : Look{};
    for (;;) {
        {
            std::unique_lock<std::mutex> lock(stop_mutex_);
            if (stop_cv_.wait_for(lock, std::chrono::milliseconds(300), [&] { return stopping_; })) return;
        }
        settle_waiting();  // jobs whose dependencies ended on the nodes
        if (std::chrono::steady_clock::now() - lanes_pruned_ > std::chrono::seconds(30)) {
            lanes_pruned_ = std::chrono::steady_clock::now();
            try {
                if (const long long n = redis_->prune_lanes()) spdlog::info("{} lane(s) of required tags no job uses were removed", n);
            } catch (const std::exception& e) {
                spdlog::warn("lanes: {}", e.what());
            }
        }
        try {
            Look now = look();
            const bool listening = events_.subscribers() > 0;
            std::vector<std::pair<std::string, const char*>> changes;
            // Unfinished before, out of sight now: it finished, and 50 newer jobs came since.
            for (const auto& [id, before] : seen)
                if (!now.count(id) && before.first != Seen::other) changes.push_back({id, "state"});
            if (!baseline)
                for (const auto& [id, state] : now) {
                    auto it = seen.find(id);
                    if (it == seen.end()) changes.push_back({id, "created"});
                    else if (it->second.first != state.first) changes.push_back({id, "state"});
                    else if (state.first == Seen::running && it->second.second != state.second) changes.push_back({id, "progress"});
                }
            seen = std::move(now);
            baseline = false;
            // Records are read for listeners, and for a job's end (its notification, which one
            // API node sends: claim_notification).
            for (const auto& [id, type] : changes) {
                if (!listening && std::string(type) == "progress") continue;
                const std::optional<JobRecord> rec = store_->get(id);
                if (!rec) continue;
                const api::JobStatus st = status_of(*rec);
                if (api::is_final(st.state)) notify(st);
                if (!listening) continue;
                publish(type, st);
                // New to us after it started: created, then the state it has reached.
                if (std::string(type) == "created" && rec->state != JobState::queued) publish("state", st);
            }
        } catch (const std::exception& e) {
            spdlog::warn("events: cannot read the farm's jobs: {}", e.what());
        }
    }
}

}  // namespace tessera::server
