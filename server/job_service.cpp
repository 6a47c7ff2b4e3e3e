#include "server/job_service.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>

#include <spdlog/spdlog.h>

#include "engine/io/image_io.h"
#include "engine/io/scene_loader.h"
#include "engine/render/renderer.h"
#include "engine/scene/procedural.h"
#include "api/comparison.h"
#include "server/problem.h"

namespace tessera::server {
namespace fs = std::filesystem;
using api::ComparisonConfig;
using api::ComparisonResult;
using api::standard_configs;
using api::run_comparison;
using api::comparison_json;
using api::comparison_markdown;
using api::comparison_svg;
using nlohmann::json;

namespace {

double now_s() {
    return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

std::string new_id() {
    static thread_local std::mt19937_64 rng(std::random_device{}() ^ uint64_t(now_s() * 1e6));
    static const char* hex = "0123456789abcdef";
    std::string s(16, '0');
    uint64_t v = rng();
    for (auto& c : s) { c = hex[v & 15]; v >>= 4; }
    return s;
}

bool valid_id(const std::string& id) {
    return id.size() == 16 && id.find_first_not_of("0123456789abcdef") == std::string::npos;
}

json or_null(double v) { return v > 0 ? json(v) : json(nullptr); }

const std::vector<std::string> kResultFiles = {"image.png", "image.exr", "rate.png", "report.json"};

}  // namespace

JobService::JobService(ServiceConfig config)
    : config_(std::move(config)),
      store_((fs::create_directories(config_.data_dir), (fs::path(config_.data_dir) / "tessera.db").string())),
      catalog_(config_.project_scenes, config_.scene_dirs, (fs::path(config_.data_dir) / "uploads").string()) {
    const int requeued = store_.requeue_all_running();
    if (requeued) spdlog::warn("{} job(s) were running when the server stopped; queued again", requeued);
    for (const JobRecord& r : store_.queued_in_order()) queue_.insert({r.priority, r.seq, r.id});
    if (!queue_.empty()) spdlog::info("{} queued job(s) restored", queue_.size());
    for (int i = 0; i < std::max(1, config_.concurrent_jobs); ++i) workers_.emplace_back([this] { worker(); });
}

JobService::~JobService() { shutdown(); }

void JobService::shutdown() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        accepting_ = false;
        if (stopping_ && workers_.empty()) return;
        stopping_ = true;
        for (auto& [id, r] : running_) { r->shutdown = true; r->stop = true; }
    }
    cv_.notify_all();
    for (auto& w : workers_) if (w.joinable()) w.join();
    workers_.clear();
}

std::string JobService::job_dir(const std::string& id) const { return (fs::path(config_.data_dir) / "jobs" / id).string(); }

json JobService::submit(const json& body) {
    if (!accepting_) throw Problem(503, "shutting-down", "The server is shutting down", "no new jobs are accepted").with_retry_after(5);
    api::JobSpec spec;
    try {
        spec = api::parse_job(body, config_.job_limits);
    } catch (const api::InvalidJob& e) {
        throw Problem(400, "invalid-field", "Invalid job", e.what()).with_field(e.pointer());
    }
    // Built-in names may carry parameters (builtin:displaced_sphere?triangles=N): checked now,
    // not when the job runs.
    const std::string base = spec.scene.substr(0, spec.scene.find('?'));
    if (!catalog_.find(base))
        throw Problem(404, "unknown-scene", "Unknown scene",
                      "no scene named '" + spec.scene + "' (GET /v1/scenes lists them)").with_field("/scene");
    if (base.rfind("builtin:", 0) == 0) {
        try {
            check_builtin_name(spec.scene);
        } catch (const SceneError& e) {
            throw Problem(400, "invalid-field", "Invalid job", e.detail()).with_field("/scene");
        }
    } else if (base != spec.scene) {
        throw Problem(404, "unknown-scene", "Unknown scene", "only built-in scenes take parameters").with_field("/scene");
    }
    if (!spec.reference.empty()) {
        auto ref = store_.get(spec.reference);
        if (!ref) throw Problem(400, "invalid-field", "Invalid job", "no job " + spec.reference + " to use as reference").with_field("/reference");
        if (ref->state != JobState::succeeded)
            throw Problem(409, "not-finished", "The reference job has not succeeded", "job " + spec.reference + " is " + to_string(ref->state)).with_field("/reference");
        const json rs = json::parse(ref->spec_json);
        if (rs["width"] != spec.render.width || rs["height"] != spec.render.height)
            throw Problem(400, "invalid-field", "Invalid job", "the reference is " + rs["width"].dump() + "×" + rs["height"].dump() +
                                                                  ", the job " + std::to_string(spec.render.width) + "×" + std::to_string(spec.render.height)).with_field("/reference");
    }
    return enqueue(api::to_json(spec).dump(), spec.priority, spec.scene);
}

json JobService::enqueue(const std::string& spec_json, int priority, const std::string& scene) {
    JobRecord rec;
    rec.id = new_id();
    rec.state = JobState::queued;
    rec.spec_json = spec_json;
    rec.priority = priority;
    rec.created_at = now_s();
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (queue_.size() >= config_.max_queued)
            throw Problem(429, "queue-full", "The queue is full",
                          "the queue holds " + std::to_string(queue_.size()) + " jobs, its limit").with_retry_after(10);
        store_.insert(rec);  // durable before it is acknowledged
        queue_.insert({rec.priority, rec.seq, rec.id});
    }
    cv_.notify_one();
    ++metrics_.jobs_submitted;
    spdlog::info("job {} queued (scene {}, priority {})", rec.id, scene, rec.priority);
    return status_json(rec);
}

json JobService::submit_comparison(const json& body) {
    if (!accepting_) throw Problem(503, "shutting-down", "The server is shutting down", "no new jobs are accepted").with_retry_after(5);
    if (!body.is_object()) throw Problem(400, "invalid-field", "Invalid comparison", "the body must be a JSON object").with_field("");
    json spec = {{"kind", "comparison"}, {"width", 160}, {"height", 120}, {"max_depth", 5}, {"seconds", 2.0}, {"reps", 3},
                 {"reference_spp", 1024}, {"target_error", 0.01}, {"priority", 0}, {"configs", "standard"}};
    auto bad = [](const std::string& ptr, const std::string& what) {
        return Problem(400, "invalid-field", "Invalid comparison", ptr + " " + what).with_field(ptr);
    };
    for (const auto& [k, v] : body.items()) {
        const std::string ptr = "/" + k;
        if (k == "scene") { if (!v.is_string()) throw bad(ptr, "must be a scene name"); spec[k] = v; }
        else if (k == "width" || k == "height") { if (!v.is_number_integer() || v.get<int64_t>() < 8 || v.get<int64_t>() > 1024) throw bad(ptr, "must be an integer in [8, 1024]"); spec[k] = v; }
        else if (k == "max_depth") { if (!v.is_number_integer() || v.get<int64_t>() < 0 || v.get<int64_t>() > 100) throw bad(ptr, "must be an integer in [0, 100]"); spec[k] = v; }
        else if (k == "seconds") { if (!v.is_number() || !(v.get<double>() > 0 && v.get<double>() <= 600)) throw bad(ptr, "must be a number in (0, 600]"); spec[k] = v; }
        else if (k == "reps") { if (!v.is_number_integer() || v.get<int64_t>() < 1 || v.get<int64_t>() > 20) throw bad(ptr, "must be an integer in [1, 20]"); spec[k] = v; }
        else if (k == "reference_spp") { if (!v.is_number_integer() || v.get<int64_t>() < 1 || v.get<int64_t>() > 65536) throw bad(ptr, "must be an integer in [1, 65536]"); spec[k] = v; }
        else if (k == "target_error") { if (!v.is_number() || !(v.get<double>() > 0)) throw bad(ptr, "must be a positive number"); spec[k] = v; }
        else if (k == "priority") { if (!v.is_number_integer() || std::abs(v.get<int64_t>()) > 1000) throw bad(ptr, "must be an integer in [-1000, 1000]"); spec[k] = v; }
        else if (k == "configs") {
            if (v.is_string() && v == "standard") continue;
            if (!v.is_array() || v.empty() || v.size() > 32) throw bad(ptr, "must be \"standard\" or an array of 1 to 32 configurations");
            for (size_t i = 0; i < v.size(); ++i) {
                const std::string p = ptr + "/" + std::to_string(i);
                if (!v[i].is_object() || !v[i].contains("label") || !v[i]["label"].is_string()) throw bad(p, "needs a \"label\"");
                json fields = v[i];
                fields.erase("label");
                for (const char* forbidden : {"scene", "width", "height", "spp", "seed", "time_limit_s", "target_error", "reference", "priority"})
                    if (fields.contains(forbidden)) throw bad(p + "/" + forbidden, "is set by the comparison, not per configuration");
                fields["scene"] = "x";
                try {
                    api::parse_job(fields, config_.job_limits);
                } catch (const api::InvalidJob& e) {
                    throw Problem(400, "invalid-field", "Invalid comparison", e.what()).with_field(p + e.pointer());
                }
            }
            spec[k] = v;
        } else {
            throw bad(ptr, "is not a comparison field (scene, width, height, max_depth, seconds, reps, reference_spp, target_error, priority, configs)");
        }
    }
    if (!spec.contains("scene")) throw bad("/scene", "is required");
    const std::string scene = spec["scene"];
    if (!catalog_.find(scene.substr(0, scene.find('?'))))
        throw Problem(404, "unknown-scene", "Unknown scene", "no scene named '" + scene + "'").with_field("/scene");
    return enqueue(spec.dump(), spec["priority"].get<int>(), scene);
}

json JobService::status(const std::string& id) {
    if (!valid_id(id)) throw Problem(404, "not-found", "No such job", "no job with id '" + id + "'");
    auto rec = store_.get(id);
    if (!rec) throw Problem(404, "not-found", "No such job", "no job with id '" + id + "'");
    return status_json(*rec);
}

json JobService::status_json(const JobRecord& rec) {
    json j;
    j["id"] = rec.id;
    j["state"] = to_string(rec.state);
    j["settings"] = json::parse(rec.spec_json);
    j["priority"] = rec.priority;
    j["created_at"] = or_null(rec.created_at);
    j["started_at"] = or_null(rec.started_at);
    j["finished_at"] = or_null(rec.finished_at);
    j["attempts"] = rec.attempts;
    j["error"] = rec.error.empty() ? json(nullptr) : json(rec.error);
    j["queue_position"] = nullptr;
    json progress = {{"fraction", is_final(rec.state) && rec.state == JobState::succeeded ? 1.0 : 0.0},
                     {"tiles_done", 0}, {"tiles_total", 0}, {"samples_done", 0}};
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (rec.state == JobState::queued) {
            size_t pos = 0;
            for (const auto& k : queue_) {
                if (k.id == rec.id) { j["queue_position"] = pos; break; }
                ++pos;
            }
        }
        auto it = running_.find(rec.id);
        if (it != running_.end()) {
            const size_t done = it->second->tiles_done, total = it->second->tiles_total;
            const double budget = it->second->sample_budget;
            progress = {{"fraction", budget > 0 ? std::min(1.0, double(it->second->samples.load()) / budget) : 0.0},
                        {"tiles_done", done}, {"tiles_total", total}, {"samples_done", it->second->samples.load()}};
        }
    }
    j["progress"] = progress;
    json report = rec.report_json.empty() ? json::object() : json::parse(rec.report_json, nullptr, false);
    if (report.is_discarded()) report = json::object();
    if (rec.state == JobState::succeeded && report.contains("progress")) j["progress"] = report["progress"];
    json timings = {{"queued_s", nullptr}, {"load_s", nullptr}, {"bvh_s", nullptr}, {"render_s", nullptr},
                    {"write_s", nullptr}, {"total_s", nullptr}};
    if (rec.started_at > 0) timings["queued_s"] = rec.started_at - rec.created_at;
    if (report.contains("timings")) for (auto& [k, v] : report["timings"].items()) timings[k] = v;
    j["timings"] = timings;
    j["stats"] = report.contains("stats") ? report["stats"] : json(nullptr);
    const std::string self = "/v1/jobs/" + rec.id;
    j["links"] = {{"self", self}, {"image_png", self + "/image.png"}, {"image_exr", self + "/image.exr"},
                  {"rate_png", self + "/rate.png"}, {"report", self + "/report.json"}};
    return j;
}

json JobService::list(const std::string& state, size_t offset, size_t limit) {
    std::optional<JobState> filter;
    if (!state.empty()) {
        JobState s;
        if (!parse_job_state(state, s))
            throw Problem(400, "invalid-parameter", "Invalid query parameter",
                          "state must be queued, running, succeeded, failed or canceled").with_field("state");
        filter = s;
    }
    json jobs = json::array();
    for (const JobRecord& r : store_.list(filter, offset, limit)) jobs.push_back(status_json(r));
    return {{"jobs", jobs}, {"total", store_.count(filter)}, {"offset", offset}, {"limit", limit}};
}

json JobService::cancel(const std::string& id) {
    json current = status(id);  // 404 for unknown ids
    bool was_queued = false;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        for (auto it = queue_.begin(); it != queue_.end(); ++it)
            if (it->id == id) { queue_.erase(it); was_queued = true; break; }
        auto r = running_.find(id);
        if (r != running_.end()) { r->second->cancel = true; r->second->stop = true; }
    }
    if (was_queued && store_.finish(id, JobState::canceled, now_s(), "", ""))
        spdlog::info("job {} canceled while queued", id);
    return status(id);
}

void JobService::delete_results(const std::string& id) {
    const json s = status(id);
    JobState st;
    parse_job_state(s["state"].get<std::string>(), st);
    if (!is_final(st)) throw Problem(409, "not-finished", "The job is not finished", "cancel it first or wait");
    std::error_code ec;
    fs::remove_all(job_dir(id), ec);
    spdlog::info("job {} results deleted", id);
}

std::string JobService::result_path(const std::string& id, const std::string& file) {
    const json s = status(id);
    const std::string state = s["state"];
    if (state == "queued" || state == "running")
        throw Problem(409, "not-finished", "The job is not finished", "job " + id + " is " + state + "; poll /v1/jobs/" + id);
    const fs::path p = fs::path(job_dir(id)) / file;
    if (!fs::exists(p))
        throw Problem(410, "gone", "No such result",
                      state == "succeeded" ? "the results of job " + id + " were deleted" : "job " + id + " " + state + " without results");
    return p.string();
}

size_t JobService::queue_depth() {
    std::lock_guard<std::mutex> lock(mutex_);
    return queue_.size();
}

std::map<std::string, size_t> JobService::counts_by_state() {
    std::map<std::string, size_t> m;
    for (JobState s : {JobState::queued, JobState::running, JobState::succeeded, JobState::failed, JobState::canceled})
        m[to_string(s)] = store_.count(s);
    return m;
}

void JobService::worker() {
    for (;;) {
        JobRecord rec;
        std::shared_ptr<Running> running;
        {
            std::unique_lock<std::mutex> lock(mutex_);
            cv_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
            if (stopping_) return;
            const QueueKey key = *queue_.begin();
            queue_.erase(queue_.begin());
            if (!store_.mark_running(key.id, now_s())) continue;  // canceled meanwhile
            rec = *store_.get(key.id);
            running = std::make_shared<Running>();
            running_[key.id] = running;
        }
        spdlog::info("job {} running (attempt {})", rec.id, rec.attempts);
        run_job(rec, *running);
        std::lock_guard<std::mutex> lock(mutex_);
        running_.erase(rec.id);
    }
}

void JobService::run_comparison_job(const JobRecord& rec, Running& running) {
    const json spec = json::parse(rec.spec_json);
    std::string error;
    try {
        const std::string scene = spec["scene"];
        auto entry = catalog_.find(scene.substr(0, scene.find('?')));
        if (!entry) throw std::runtime_error("scene '" + scene + "' is no longer in the catalog");
        const SceneDescription desc = load_scene(entry->source == "builtin" ? scene : entry->path, config_.load_limits);
        RenderSettings base;
        base.width = spec["width"].get<int>();
        base.height = spec["height"].get<int>();
        base.max_depth = spec["max_depth"].get<int>();
        base.threads = config_.render_threads;
        std::vector<ComparisonConfig> configs;
        if (spec["configs"].is_string()) {
            configs = standard_configs(base);
        } else {
            for (const json& c : spec["configs"]) {
                json fields = c;
                fields.erase("label");
                fields["scene"] = scene;
                const api::JobSpec js = api::parse_job(fields, config_.job_limits);
                ComparisonConfig cc{c["label"].get<std::string>(), js.render, js.scene_options};
                cc.settings.threads = config_.render_threads;
                configs.push_back(cc);
            }
        }
        for (auto& c : configs) c.settings.threads = config_.render_threads;
        const double seconds = spec["seconds"].get<double>(), target = spec["target_error"].get<double>();
        running.sample_budget = 0;
        const ComparisonResult r = run_comparison(desc, configs, base, spec["reference_spp"].get<int>(), seconds,
                                                  spec["reps"].get<int>(), target, &running.stop);
        if (running.shutdown) { store_.requeue(rec.id); return; }
        if (running.cancel) { store_.finish(rec.id, JobState::canceled, now_s(), "", ""); return; }
        const fs::path dir = job_dir(rec.id);
        fs::create_directories(dir);
        json report = {{"settings", spec}, {"comparison", comparison_json(r, seconds, target)},
                       {"table_markdown", comparison_markdown(r, seconds, target)}};
        std::ofstream(dir / "report.json") << report.dump(2);
        std::ofstream(dir / "convergence.svg") << comparison_svg(r, scene + ": relative MSE against time (first run of each)");
        store_.finish(rec.id, JobState::succeeded, now_s(), "", json{{"comparison", report["comparison"]}}.dump());
        spdlog::info("comparison job {} succeeded", rec.id);
    } catch (const std::exception& e) {
        error = e.what();
        store_.finish(rec.id, JobState::failed, now_s(), error, "");
        spdlog::error("comparison job {} failed: {}", rec.id, error);
    }
}

void JobService::run_job(const JobRecord& rec, Running& running) {
    if (json::parse(rec.spec_json).value("kind", "") == "comparison") {
        run_comparison_job(rec, running);
        return;
    }
    using Clock = std::chrono::steady_clock;
    const auto t0 = Clock::now();
    auto secs = [](Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); };
    std::string error;
    json report;
    try {
        const api::JobSpec spec = api::parse_job(json::parse(rec.spec_json), config_.job_limits);
        const std::string base = spec.scene.substr(0, spec.scene.find('?'));
        auto entry = catalog_.find(base);
        if (!entry) throw std::runtime_error("scene '" + spec.scene + "' is no longer in the catalog");
        const SceneDescription desc = load_scene(entry->source == "builtin" ? spec.scene : entry->path, config_.load_limits);
        const auto t_loaded = Clock::now();
        const RenderScene scene = build_render_scene(desc, spec.scene_options);
        const auto t_built = Clock::now();
        RenderSettings settings = spec.render;
        settings.threads = config_.render_threads;
        running.sample_budget = double(settings.spp) * settings.width * settings.height;
        settings.estimate_error = true;  // every job records its convergence curve
        Image reference_image;
        RenderCallbacks cb;
        cb.cancel = &running.stop;
        if (!spec.reference.empty()) {
            const fs::path ref = fs::path(job_dir(spec.reference)) / "image.exr";
            if (!fs::exists(ref)) throw std::runtime_error("the reference job's image was deleted");
            reference_image = read_image(ref.string());
            cb.reference = &reference_image;
        }
        const double limit = spec.time_limit_s;
        cb.progress = [&](const RenderProgress& p) {
            running.tiles_done = p.tiles_done;
            running.tiles_total = p.tiles_total;
            running.samples = p.samples_done;
        };
        // The time limit counts from the job's start (loading included); the renderer stops
        // at it and keeps the samples it has.
        if (limit > 0) settings.time_limit_s = std::max(1e-3, limit - secs(t0, Clock::now()));
        const RenderResult result = render(scene, settings, cb);
        const auto t_rendered = Clock::now();
        if (running.shutdown) {
            store_.requeue(rec.id);
            spdlog::warn("job {} interrupted by shutdown; queued again", rec.id);
            return;
        }
        if (running.cancel) {
            store_.finish(rec.id, JobState::canceled, now_s(), "", "");
            spdlog::info("job {} canceled while running", rec.id);
            return;
        }

        const fs::path dir = job_dir(rec.id);
        fs::create_directories(dir);
        const RenderStats& st = result.stats;
        const Metadata meta = {{"tessera:job", rec.id}, {"tessera:scene", spec.scene}, {"tessera:settings", rec.spec_json},
                               {"tessera:samples", std::to_string(st.samples)}};
        write_png((dir / "image.png").string(), result.image, ToneCurve::srgb, meta);
        write_exr((dir / "image.exr").string(), result.image, meta);
        write_rate_png((dir / "rate.png").string(), result.image, settings.spp, meta);
        {
            std::ofstream(dir / "convergence.csv") << convergence_csv(result.curve);
            std::ofstream(dir / "convergence.svg")
                << convergence_svg({result.curve}, {spec.reference.empty() ? "estimated (half buffers)" : "against job " + spec.reference},
                                   "Job " + rec.id + ": error against time (" + spec.scene + ")");
        }
        const auto t_written = Clock::now();

        float smin = INFINITY, smax = 0;
        for (float c : result.image.sample_count) { smin = std::min(smin, c); smax = std::max(smax, c); }
        const double npx = double(settings.width) * settings.height;
        const double per_ray = st.rays() ? 1.0 / double(st.rays()) : 0.0;
        report["settings"] = json::parse(rec.spec_json);
        report["timings"] = {{"load_s", secs(t0, t_loaded)}, {"bvh_s", secs(t_loaded, t_built)},
                             {"render_s", st.render_seconds}, {"write_s", secs(t_rendered, t_written)},
                             {"total_s", secs(t0, Clock::now())}};
        report["stats"] = {{"rays_camera", st.camera_rays}, {"rays_shadow", st.shadow_rays}, {"rays_bounce", st.bounce_rays},
                           {"mrays_per_s", st.render_seconds > 0 ? double(st.rays()) / st.render_seconds * 1e-6 : 0.0},
                           {"bvh_nodes", scene.tri_bvh_stats.node_count}, {"bvh_depth", scene.tri_bvh_stats.depth},
                           {"bvh_sah_cost", scene.tri_bvh_stats.sah_cost}, {"bvh_bytes", scene.triangle_accel_bytes()},
                           {"nodes_per_ray", double(st.traversal.nodes_visited) * per_ray},
                           {"prim_tests_per_ray", double(st.traversal.prim_tests) * per_ray},
                           {"spp_mean", double(st.samples) / npx}, {"spp_min", smin}, {"spp_max", smax},
                           {"nonfinite_samples", st.nonfinite_samples}, {"max_sample_luminance", st.max_sample},
                           {"threads", st.threads}};
        report["scene"] = {{"name", spec.scene}, {"triangles", scene.triangle_count()}, {"spheres", scene.spheres.size()},
                           {"built", scene.report.built}, {"left_out", scene.report.left_out},
                           {"warnings", scene.report.warnings}, {"build_s", scene.report.seconds}};
        json points = json::array();
        for (const ConvergencePoint& p : result.curve.points) {
            json jp = {{"seconds", p.seconds}, {"spp_mean", p.spp_mean}};
            jp["est_rel_mse"] = p.est_rel_mse >= 0 ? json(p.est_rel_mse) : json(nullptr);
            if (p.rel_mse >= 0) { jp["rel_mse"] = p.rel_mse; jp["mse"] = p.mse; jp["mae"] = p.mae; }
            points.push_back(jp);
        }
        report["convergence"] = {
            {"stop_reason", to_string(result.curve.stop)},
            {"error_measure", spec.reference.empty()
                                  ? "estimated relative MSE from the even- and odd-sample half buffers: mean ((A-B)^2/4)/(x^2+0.01)"
                                  : "relative MSE against job " + spec.reference + ": mean (x-r)^2/(r^2+0.01); the half-buffer estimate too"},
            {"points", points}};
        report["render"] = {{"built", result.built}, {"left_out", result.left_out}};
        report["progress"] = {{"fraction", 1.0}, {"tiles_done", running.tiles_done.load()},
                              {"tiles_total", running.tiles_total.load()}, {"samples_done", st.samples}};
        {
            std::ofstream out(dir / "report.json");
            out << report.dump(2);
        }
        metrics_.rays += st.rays();
        metrics_.render_micros += uint64_t(st.render_seconds * 1e6);
    } catch (const SceneError& e) {
        error = std::string("scene: ") + e.what();
    } catch (const std::exception& e) {
        error = e.what();
    }
    if (!error.empty()) {
        store_.finish(rec.id, JobState::failed, now_s(), error, report.is_null() ? "" : report.dump());
        spdlog::error("job {} failed: {}", rec.id, error);
        return;
    }
    store_.finish(rec.id, JobState::succeeded, now_s(), "", report.dump());
    spdlog::info("job {} succeeded in {:.3f} s", rec.id, report["timings"]["total_s"].get<double>());
}

}  // namespace tessera::server
