#include "api/json_text.h"
#include "api/job_runner.h"

#include "api/checkpoint_file.h"

#include "engine/scene/environment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <tuple>
#include <fstream>
#include <mutex>

#include "api/comparison.h"
#include "api/shot_runner.h"
#include "engine/render/film.h"

namespace tessera::api {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

double seconds_between(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

bool stop_requested(const RunCallbacks& cb) { return cb.stop && cb.stop->load(); }


JobOutcome run_render(const RenderJob& job, const RunOptions& opt, const RunOutputs& out, const RunCallbacks& cb) {
    const auto t0 = Clock::now();
    std::shared_ptr<const PreparedScene> prepared;
    SceneCacheUse cache_use;
    if (opt.prepare) {
        bool hit = false;
        std::tie(prepared, hit) = opt.prepare(opt.scene_source, opt.scene_name, job.scene_options);
        cache_use = {true, hit, prepared->load_s, prepared->build_s};
    } else {
        prepared = prepare_scene(opt.scene_source, opt.load_limits, job.scene_options, opt.scene_name);
    }
    // This job's own time: a hit costs the look-up only.
    const double own_s = seconds_between(t0, Clock::now());
    const double load_s = cache_use.hit ? own_s : prepared->load_s;
    const double build_s = cache_use.hit ? 0.0 : prepared->build_s;
    return render_prepared(job, job.render, ScenePrepared{prepared->scene, load_s, build_s, cache_use}, t0, opt, out, cb);
}

JobOutcome run_comparison_job(const ComparisonJob& job, const RunOptions& opt, const RunOutputs& out, const RunCallbacks& cb) {
    const SceneDescription desc = load_scene(opt.scene_source, opt.load_limits, opt.scene_name);
    RenderSettings base = default_render_job().render;
    base.width = job.width;
    base.height = job.height;
    base.max_depth = job.max_depth;
    base.threads = opt.threads;
    std::vector<ComparisonConfig> configs;
    if (job.standard_configs) {
        configs = standard_configs(base);
    } else {
        for (const ComparisonConfigJob& c : job.configs) configs.push_back({c.label, c.job.render, c.job.scene_options});
    }
    for (auto& c : configs) c.settings.threads = opt.threads;
    const ComparisonResult r =
        run_comparison(desc, configs, base, job.reference_spp, job.seconds, job.reps, job.target_error, cb.stop);
    JobOutcome outcome;
    if (stop_requested(cb)) {
        outcome.stopped = true;
        return outcome;
    }
    outcome.report = {{"settings", to_json(job)}, {"comparison", comparison_json(r, job.seconds, job.target_error)},
                      {"table_markdown", comparison_markdown(r, job.seconds, job.target_error)}};
    write_text(out.report_json, json_text(outcome.report, 2));
    write_text(out.convergence_svg, comparison_svg(r, job.scene + ": relative MSE against time (first run of each)"));
    outcome.summary = {{"comparison", outcome.report["comparison"]}};
    return outcome;
}

}  // namespace

std::shared_ptr<const EnvironmentMap> load_environment(const std::string& path, const std::string& name) {
    const std::string& shown = name.empty() ? path : name;
    const std::string ext = std::filesystem::path(path).extension().string();
    if (ext != ".exr" && ext != ".hdr")
        throw SceneError(SourceLocation{shown, 0, ""}, "an environment map must be a latitude-longitude .exr or .hdr file");
    Image img;
    try {
        img = read_image(path);
    } catch (const std::exception& e) {
        // OpenImageIO names the file it opened: that is the path, said as `shown`.
        std::string why = e.what();
        for (size_t at = why.find(path); !path.empty() && at != std::string::npos; at = why.find(path, at + shown.size()))
            why.replace(at, path.size(), shown);
        throw SceneError(SourceLocation{shown, 0, ""}, "cannot read the environment map: " + why);
    }
    try {
        return std::make_shared<const EnvironmentMap>(build_environment(img.width, img.height, img.rgb, shown));
    } catch (const std::invalid_argument& e) {
        throw SceneError(SourceLocation{shown, 0, ""}, e.what());
    }
}

// A scene without lights (most glTF models) is lit by a uniform white sky of radiance 1, and
// the report says so, rather than rendered black.
std::shared_ptr<const EnvironmentMap> default_environment() {
    static const auto env = std::make_shared<const EnvironmentMap>(
        build_environment(1, 1, {1.f, 1.f, 1.f}, "default uniform white sky of radiance 1 (the scene has no lights)"));
    return env;
}

RenderSettings lit_settings(RenderSettings settings, const RenderScene& scene) {
    if (!settings.environment && !scene.has_lights()) settings.environment = default_environment();
    return settings;
}

std::shared_ptr<PreparedScene> prepare_scene(const std::string& source, const LoadLimits& limits, const RenderSceneOptions& options,
                                             const std::string& name) {
    auto p = std::make_shared<PreparedScene>();
    const auto t0 = Clock::now();
    const SceneDescription desc = load_scene(source, limits, name);
    p->files_read = desc.files_read;
    const auto t1 = Clock::now();
    p->scene = build_render_scene(desc, options);
    p->load_s = seconds_between(t0, t1);
    p->build_s = seconds_between(t1, Clock::now());
    // What the scene cache counts against its budget: geometry, its acceleration structure, the
    // decoded texels (a textured model's largest part) and the objects' and materials' names
    // (Cryptomatte's: a file may give long ones to many meshes).
    size_t texel_bytes = 0, name_bytes = 0;
    for (const auto& img : p->scene.images) texel_bytes += img->rgba.size();
    for (const auto* names : {&p->scene.object_names, &p->scene.material_names})
        for (const std::string& n : *names) name_bytes += sizeof(std::string) + n.capacity() + sizeof(uint32_t);
    p->bytes = p->scene.triangle_accel_bytes() + p->scene.triangle_count() * 160 + p->scene.spheres.size() * 64 + texel_bytes +
               name_bytes + 4096;
    return p;
}

namespace {

// A Cryptomatte AOV's header attributes (its layer, hash, conversion and manifest of the scene's
// names); none for another AOV.
Metadata crypto_meta(const RenderScene& scene, Aov a) {
    if (a == Aov::crypto_object) return crypto_metadata(aov_info(a).layer, scene.object_names);
    if (a == Aov::crypto_material) return crypto_metadata(aov_info(a).layer, scene.material_names);
    return {};
}

}  // namespace

JobOutcome write_render(const FinishedRender& done, const RunOptions& opt, const RunOutputs& out) {
    const auto t_write = Clock::now();
    const RenderJob& job = done.job;
    const RenderResult& result = done.result;
    const RenderStats& st = result.stats;
    Metadata meta = {{"tessera:scene", job.scene}, {"tessera:settings", json_text(to_json(job))},
                     {"tessera:samples", std::to_string(st.samples)},
                     {"tessera:render_seconds", std::to_string(st.render_seconds)}};
    if (!opt.job_id.empty()) meta.insert(meta.begin(), {"tessera:job", opt.job_id});
    try {
        // The folder is made again here: one removed while the job rendered (a user freeing space
        // by hand) costs nothing but the write.
        if (!out.directory.empty()) std::filesystem::create_directories(out.directory);
        if (!out.png.empty()) write_png(out.png, result.image, out.tone, meta);
        if (!out.exr.empty()) write_exr(out.exr, result.image, meta);
        if (!out.rate_png.empty()) write_rate_png(out.rate_png, result.image, done.settings.spp, meta);
        if (!result.aovs.empty()) {
            Metadata layers = meta;
            for (const AovPlane& a : result.aovs) layers = with(std::move(layers), crypto_meta(done.scene, a.aov));
            if (!out.passes_exr.empty()) write_layers_exr(out.passes_exr, result.image, result.aovs, layers);
            if (!out.passes_dir.empty()) {
                std::filesystem::create_directories(out.passes_dir);
                for (const AovPlane& a : result.aovs)
                    write_aov_exr((std::filesystem::path(out.passes_dir) / (std::string(aov_info(a.aov).name) + ".exr")).string(),
                                  result.image.width, result.image.height, a, with(meta, crypto_meta(done.scene, a.aov)));
            }
        }
        if (result.denoised) {
            if (!out.denoised_exr.empty()) write_exr(out.denoised_exr, result.denoised->image, meta);
            if (!out.denoised_png.empty()) write_png(out.denoised_png, result.denoised->image, out.tone, meta);
        }
        write_text(out.convergence_csv, convergence_csv(result.curve));
        if (!out.convergence_svg.empty()) {
            const std::string who = opt.job_id.empty() ? std::string("Render") : "Job " + opt.job_id;
            std::vector<ConvergenceCurve> curves{result.curve};
            std::vector<std::string> labels{job.reference.empty() ? "estimated (half buffers)" : "against job " + job.reference};
            // A denoising job's second series: its denoised image at each pass.
            ConvergenceCurve denoised;
            for (const ConvergencePoint& p : result.curve.points) {
                if (p.denoised_est_rel_mse < 0) continue;
                ConvergencePoint q = p;
                q.rel_mse = p.denoised_rel_mse;
                q.est_rel_mse = p.denoised_est_rel_mse;
                denoised.points.push_back(q);
            }
            if (!denoised.points.empty()) {
                curves.push_back(denoised);
                labels.push_back(job.reference.empty() ? "denoised, estimated (independent halves)" : "denoised, against job " + job.reference);
            }
            write_text(out.convergence_svg, convergence_svg(curves, labels, who + ": error against time (" + job.scene + ")"));
        }
    } catch (const std::exception& e) {
        // Whatever the image library says, the user is told it was the writing of results that failed.
        throw std::runtime_error(std::string("cannot write results: ") + e.what());
    }
    const double write_s = seconds_between(t_write, Clock::now());

    RenderReport rep;
    rep.job = job;
    rep.stats = st;
    rep.tiles_done = done.tiles_done;
    rep.tiles_total = done.tiles_total;
    rep.nodes = done.nodes;
    rep.scene_cache = done.scene_cache;
    rep.recovered_samples = result.resumed_samples;
    rep.recovered_render_s = result.resumed_seconds;
    const RenderScene& scene = done.scene;
    rep.triangles = scene.triangle_count();
    rep.spheres = scene.spheres.size();
    rep.bvh = scene.tri_bvh_stats;
    rep.accel_bytes = scene.triangle_accel_bytes();
    rep.scene_build = scene.report;
    if (done.settings.environment) {
        // The scene's "no lights" is not this render's: the environment lights it.
        auto& w = rep.scene_build.warnings;
        w.erase(std::remove_if(w.begin(), w.end(), [](const std::string& s) { return s.find("no lights") != std::string::npos; }), w.end());
        rep.scene_build.built.push_back("environment light: " + done.settings.environment->source + " (" +
                                        std::to_string(done.settings.environment->width) + "x" +
                                        std::to_string(done.settings.environment->height) + ", sampled by luminance)");
    }
    rep.render_built = result.built;
    rep.render_left_out = result.left_out;
    rep.denoised = result.denoised != nullptr;
    rep.curve = result.curve;
    float smin = INFINITY, smax = 0;
    for (float c : result.image.sample_count) { smin = std::min(smin, c); smax = std::max(smax, c); }
    rep.spp_min = smin;
    rep.spp_max = smax;
    double mean = 0;
    for (float v : result.image.rgb) mean += v;
    rep.mean_radiance = result.image.rgb.empty() ? 0.0 : mean / double(result.image.rgb.size());
    rep.timings = {done.load_s, done.build_s, st.render_seconds, write_s, done.before_write_s + write_s};
    JobOutcome outcome;
    outcome.report = to_json(rep);
    write_text(out.report_json, json_text(outcome.report, 2));
    outcome.summary = status_summary(rep);
    outcome.render = std::move(rep);
    if (opt.keep_image) outcome.image = std::make_shared<const Image>(result.image);
    return outcome;
}

JobOutcome render_prepared(const RenderJob& job, const RenderSettings& render_settings, const ScenePrepared& prepared,
                           std::chrono::steady_clock::time_point t0, const RunOptions& opt, const RunOutputs& out,
                           const RunCallbacks& cb) {
    const RenderScene& scene = prepared.scene;
    const double load_s = prepared.load_s, build_s = prepared.build_s;
    const SceneCacheUse cache_use = prepared.cache;

    // The runner's settings: the job's, with how this runner runs it.
    RenderSettings settings = render_settings;
    settings.threads = opt.threads;
    settings.estimate_error = opt.record_convergence;
    // The time limit counts from the job's start (loading included); the renderer stops at it
    // and keeps the samples it has.
    if (job.render.time_limit_s > 0)
        settings.time_limit_s = std::max(1e-3, job.render.time_limit_s - seconds_between(t0, Clock::now()));
    Image reference;
    RenderCallbacks rcb;
    rcb.cancel = cb.stop;
    rcb.discard = cb.discard;
    std::atomic<size_t> tiles_done{0}, tiles_total{0};  // written by the render threads
    rcb.progress = [&](const RenderProgress& p) {
        tiles_done = p.tiles_done;
        tiles_total = p.tiles_total;
        if (cb.progress) cb.progress(p);
    };
    // Two images take turns: the one handed out last is still shown; the other is reused once
    // no one holds it any more (a request may still be encoding it: then a new one is made).
    std::shared_ptr<Image> pass_images[2];
    if (cb.pass)
        rcb.on_pass = [&](const PassView& v) {
            std::shared_ptr<Image>& img = pass_images[v.index % 2];
            if (!img || img.use_count() > 1) img = std::make_shared<Image>();
            v.film.resolve_into(*img);
            std::shared_ptr<const Image> denoised;
            if (v.denoised) denoised = std::shared_ptr<const Image>(v.denoised, &v.denoised->image);
            cb.pass(PassSnapshot{v.index, v.spp, v.point, img, denoised});
        };
    if (opt.environment) settings.environment = opt.environment;
    else if (!opt.environment_file.empty()) settings.environment = load_environment(opt.environment_file, opt.environment_name);
    settings = lit_settings(std::move(settings), scene);
    if (!opt.reference_image.empty()) {
        if (!std::filesystem::exists(opt.reference_image)) throw std::runtime_error("the reference job's image was deleted");
        reference = read_image(opt.reference_image);
        rcb.reference = &reference;
    }
    std::optional<RenderCheckpoint> resume;
    if (!out.checkpoint.empty()) {
        resume = read_checkpoint(out.checkpoint);
        if (resume) rcb.resume = &*resume;
        // One write at a time: a write slower than the interval skips the next checkpoint rather
        // than race it on the same file.
        rcb.on_checkpoint = [&, writing = std::make_shared<std::mutex>()](const RenderCheckpoint& c) {
            // A canceled job's film is thrown away (the renderer skips the stop's checkpoint;
            // a periodic one taken as the cancel came is not written either).
            if (cb.discard && cb.discard->load()) return;
            std::unique_lock<std::mutex> lock(*writing, std::try_to_lock);
            if (lock.owns_lock()) write_checkpoint(out.checkpoint, c);
        };
        rcb.checkpoint_seconds = opt.checkpoint_seconds;
    }
    const RenderResult result = render(scene, settings, rcb);
    resume.reset();
    const auto t_rendered = Clock::now();
    JobOutcome outcome;
    if (stop_requested(cb)) {
        outcome.stopped = true;
        return outcome;
    }

    FinishedRender done{job, scene, settings, result};
    done.load_s = load_s;
    done.build_s = build_s;
    done.scene_cache = cache_use;
    done.before_write_s = seconds_between(t0, t_rendered);
    done.tiles_done = tiles_done;
    done.tiles_total = tiles_total;
    JobOutcome written = write_render(done, opt, out);
    // The results are written: the render is not continued from here again.
    if (!out.checkpoint.empty()) {
        std::filesystem::remove(out.checkpoint);
        std::filesystem::remove(out.checkpoint + ".part");
    }
    return written;
}

void write_text(const std::string& path, const std::string& text) {
    if (path.empty()) return;
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << text;
    out.flush();
    if (!out) throw std::runtime_error("cannot write " + path);
}

RunOutputs RunOutputs::in_directory(const std::string& dir) {
    const std::filesystem::path d(dir);
    RunOutputs o;
    o.directory = dir;
    o.png = (d / "image.png").string();
    o.exr = (d / "image.exr").string();
    o.rate_png = (d / "rate.png").string();
    o.convergence_csv = (d / "convergence.csv").string();
    o.convergence_svg = (d / "convergence.svg").string();
    o.report_json = (d / "report.json").string();
    o.passes_exr = (d / "passes.exr").string();
    o.passes_dir = (d / "passes").string();
    o.denoised_exr = (d / "denoised.exr").string();
    o.denoised_png = (d / "denoised.png").string();
    o.contact_sheet_png = (d / "contact_sheet.png").string();
    o.preview_mp4 = (d / "preview.mp4").string();
    o.checkpoint = (d / "checkpoint.tck").string();
    o.frame = [dir](int frame) { return in_directory((std::filesystem::path(dir) / "frames" / std::to_string(frame)).string()); };
    return o;
}

JobOutcome run_job(const Job& job, const RunOptions& options, const RunOutputs& outputs, const RunCallbacks& callbacks) {
    if (const auto* r = std::get_if<RenderJob>(&job)) {
        if (r->frames) return run_shot(*r, options, outputs, callbacks);
        return run_render(*r, options, outputs, callbacks);
    }
    return run_comparison_job(std::get<ComparisonJob>(job), options, outputs, callbacks);
}

}  // namespace tessera::api
