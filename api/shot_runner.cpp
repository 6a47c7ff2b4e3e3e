#include "api/shot_runner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>

#include "api/job_status.h"
#include "api/json_text.h"
#include "api/preview_video.h"
#include "engine/camera/camera.h"
#include "engine/geometry/aabb.h"
#include "engine/io/image_io.h"
#include "engine/io/scene_loader.h"
#include "engine/scene/instancing.h"
#include "engine/scene/prototype_cache.h"
#include "engine/render/image.h"

namespace tessera::api {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

double seconds_between(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

// The contact sheet: every frame (or an even subset of at most kMaxTiles) box-filtered down to a
// thumbnail, in rows, linear values (the PNG writer applies the tone curve).
class ContactSheet {
public:
    static constexpr int kMaxTiles = 400, kThumbWidth = 192;

    ContactSheet(size_t frames, int width, int height) {
        stride_ = std::max<size_t>(1, (frames + kMaxTiles - 1) / kMaxTiles);
        tiles_ = (frames + stride_ - 1) / stride_;
        scale_ = std::max(1, (width + kThumbWidth - 1) / kThumbWidth);
        tw_ = std::max(1, width / scale_);
        th_ = std::max(1, height / scale_);
        columns_ = std::max<size_t>(1, size_t(std::ceil(std::sqrt(double(tiles_)))));
        const size_t rows = (tiles_ + columns_ - 1) / columns_;
        sheet_ = Image(int(columns_) * tw_, int(rows) * th_);
    }

    void add(size_t index, const Image& img) {
        if (index % stride_) return;
        const size_t tile = index / stride_;
        const int x0 = int(tile % columns_) * tw_, y0 = int(tile / columns_) * th_;
        for (int y = 0; y < th_; ++y)
            for (int x = 0; x < tw_; ++x) {
                float sum[3] = {0, 0, 0};
                int n = 0;
                for (int dy = 0; dy < scale_; ++dy)
                    for (int dx = 0; dx < scale_; ++dx) {
                        const int sx = x * scale_ + dx, sy = y * scale_ + dy;
                        if (sx >= img.width || sy >= img.height) continue;
                        const float* p = img.pixel(sx, sy);
                        for (int c = 0; c < 3; ++c) sum[c] += p[c];
                        ++n;
                    }
                float* q = sheet_.pixel(x0 + x, y0 + y);
                for (int c = 0; c < 3; ++c) q[c] = n ? sum[c] / float(n) : 0.f;
                sheet_.sample_count[size_t(y0 + y) * size_t(sheet_.width) + size_t(x0 + x)] = 1.f;
            }
    }

    const Image& image() const { return sheet_; }

private:
    size_t stride_ = 1, tiles_ = 0, columns_ = 1;
    int scale_ = 1, tw_ = 1, th_ = 1;
    Image sheet_;
};

// A frame an earlier run of this job wrote whole: its line in the shot's report, its samples and
// its image, read back from its own report and EXR.
struct WrittenFrame {
    json entry;
    uint64_t samples = 0;
    double render_s = 0;
    std::shared_ptr<const Image> image;
};

std::optional<WrittenFrame> written_frame(const RunOutputs& out, const RenderJob& job, int frame) {
    if (out.report_json.empty() || !std::filesystem::exists(out.report_json)) return std::nullopt;
    json report;
    try {
        std::ifstream in(out.report_json);
        report = json::parse(in);
    } catch (const std::exception&) {
        return std::nullopt;  // unreadable: rendered again
    }
    if (!report.is_object() || !report.contains("stats") || !report.contains("timings")) return std::nullopt;
    WrittenFrame w;
    w.entry = {{"timings", report["timings"]}, {"stats", report["stats"]}, {"progress", report.value("progress", json(nullptr))},
               {"frame", frame}, {"time_s", double(frame) / job.fps}, {"seed", frame_seed(job.render.seed, frame)},
               {"seconds", report["timings"].value("total_s", 0.0)}, {"resumed", true}};
    w.samples = uint64_t(std::llround(report["stats"].value("spp_mean", 0.0) * double(job.render.width) * job.render.height));
    w.render_s = report["timings"].value("render_s", 0.0);
    if (job.render.denoise) w.entry["denoised"] = !out.denoised_exr.empty() && std::filesystem::exists(out.denoised_exr);
    if (!out.exr.empty() && std::filesystem::exists(out.exr)) {
        try {
            w.image = std::make_shared<const Image>(read_image(out.exr));
        } catch (const std::exception&) {
        }
    }
    return w;
}

}  // namespace

std::string frame_path(const std::string& pattern, int frame) {
    const size_t first = pattern.find('#');
    const std::string number = std::to_string(std::abs(frame));
    if (first == std::string::npos) {
        const std::filesystem::path p(pattern);
        return (p.parent_path() / (p.stem().string() + "_" + std::to_string(frame) + p.extension().string())).string();
    }
    size_t last = first;
    while (last < pattern.size() && pattern[last] == '#') ++last;
    const size_t width = last - first;
    std::string padded = number.size() < width ? std::string(width - number.size(), '0') + number : number;
    if (frame < 0) padded = "-" + padded;
    return pattern.substr(0, first) + padded + pattern.substr(last);
}

// A deforming mesh's tree (RenderSceneOptions::world_tree): built at every kRefitGroup-th
// frame number and refitted for the frames up to the next, so that a frame's tree, and so its
// image, depends on its number alone (the same rendered alone, in any range, or by any node),
// and a refitted tree is at most kRefitGroup − 1 frames from the pose it was built for. A frame
// whose group's first frame this run has not built builds it first (a chunk starting within a
// group; sparse frames). Measured with `tessera bench shot --deform` (docs/benchmarks.md).
namespace {
constexpr int kRefitGroup = 8;
int refit_anchor(int frame) { return frame >= 0 ? frame - frame % kRefitGroup : -((-frame + kRefitGroup - 1) / kRefitGroup) * kRefitGroup; }
}  // namespace

namespace {

// A shot's `animation` the scene read whole does not have: the job's input, final, not a scene
// that failed to read (which a run may retry: a file being replaced).
void check_animation(const std::string& name, bool by_index, const std::vector<AnimationSummary>& list) {
    if (name.empty() || chosen_animation(list, name, by_index)) return;
    std::string names;
    for (size_t i = 0; i < list.size() && i < 20; ++i)
        names += (i ? ", " : "") + (list[i].name.empty() ? "#" + std::to_string(i) : "'" + list[i].name + "'");
    if (list.size() > 20) names += ", …";
    const std::string asked = by_index ? "at index " + name : "'" + name.substr(0, 80) + "'";
    throw InvalidJob("/animation", "the scene has no animation " + asked + ": it has " +
                                       (list.empty() ? std::string("none") : std::to_string(list.size()) + " (" + names + ")"));
}

}  // namespace

JobOutcome run_shot(const RenderJob& job, const RunOptions& opt, const RunOutputs& out, const RunCallbacks& cb) {
    const auto t_start = Clock::now();
    const std::vector<int> frames = job.frames->frames();
    const std::shared_ptr<const SceneFile> opened =
        opt.scene_file ? opt.scene_file : std::make_shared<const SceneFile>(opt.scene_source, opt.load_limits, opt.scene_name);
    const SceneFile& file = *opened;
    const double open_s = seconds_between(t_start, Clock::now());
    check_animation(job.animation, job.animation_index, file.animations());

    // A scene without a camera is framed once, at rest, and seen from there in every frame: a
    // camera re-framed per frame would follow the bounds of a moving model and jump.
    // Prototype trees kept from frame to frame: a placement that moves rebuilds nothing.
    PrototypeCache prototypes;
    std::optional<CameraDesc> held_camera;
    {
        const SceneDescription rest = file.at(std::nullopt);
        if (!rest.camera) {
            const Aabb bounds = scene_bounds(rest);
            CameraDesc cam;
            if (frame_camera(std::nullopt, bounds, cam)) held_camera = cam;
        }
    }

    // Frame n posed: at its moment, or at its shutter's opening and closing (motion blur: the
    // engine blurs what moves between them, emitters and lights included).
    struct Posed {
        SceneDescription desc;
        std::optional<SceneDescription> closing;
    };
    // The file was read whole: a pose it cannot make (an animation it cannot play, a rotation
    // interpolated to nothing) it never will, so the job fails once, not as a read to retry.
    auto at = [&](double time_s) {
        try {
            return file.at(ScenePose{time_s, job.animation, job.animation_index});
        } catch (const SceneError& e) {
            throw InvalidJob("/animation", std::string("scene: ") + e.what());
        }
    };
    auto pose = [&](int n) {
        Posed p;
        if (job.shutter) {
            p.desc = at((double(n) + job.shutter->first) / job.fps);
            p.closing = at((double(n) + job.shutter->second) / job.fps);
            if (!p.closing->camera && held_camera) p.closing->camera = held_camera;
        } else {
            p.desc = at(double(n) / job.fps);
        }
        if (!p.desc.camera && held_camera) p.desc.camera = held_camera;
        return p;
    };
    std::optional<int> kept_anchor;  // the frame whose world tree the cache keeps

    RunOptions frame_opt = opt;
    frame_opt.prepare = nullptr;  // each frame is posed anew; the cache holds stills
    frame_opt.keep_image = true;
    ContactSheet sheet(frames.size(), job.render.width, job.render.height);
    json entries = json::array();
    std::vector<std::string> pngs;  // each frame's, for the preview
    uint64_t samples_before = 0;
    double render_s = 0, frames_s = 0;
    JobOutcome outcome;
    size_t resumed = 0;
    const size_t first = opt.frame_slice ? std::min(opt.frame_slice->first, frames.size()) : 0;
    const size_t end = opt.frame_slice ? std::min(frames.size(), first + opt.frame_slice->second) : frames.size();
    for (size_t i = first; i < end; ++i) {
        if (cb.stop && cb.stop->load()) {
            outcome.stopped = true;
            return outcome;
        }
        const int n = frames[i];
        const auto t0 = Clock::now();
        const double time_s = double(n) / job.fps;
        RunOutputs frame_out = out.frame ? out.frame(n) : RunOutputs{};
        frame_out.tone = out.tone;
        if (opt.resume_frames) {
            if (auto kept = written_frame(frame_out, job, n)) {
                // report.json is a frame's last file: one that has it is whole.
                samples_before += kept->samples;
                if (kept->image) sheet.add(i, *kept->image);
                if (!frame_out.png.empty()) pngs.push_back(frame_out.png);
                frames_s += kept->entry["seconds"].get<double>();
                render_s += kept->render_s;
                entries.push_back(kept->entry);
                ++resumed;
                if (cb.frame) cb.frame(FrameDone{i, n, 0.0, kept->entry, true});
                continue;
            }
        }
        Posed posed = pose(frames[i]);
        const auto t_posed = Clock::now();
        RenderSceneOptions scene_options = job.scene_options;
        if (scene_options.world_tree == RenderSceneOptions::WorldTree::automatic && scene_options.bvh.type != BvhType::embree) {
            const int anchor = refit_anchor(frames[i]);
            if (anchor == frames[i]) {
                scene_options.world_tree = RenderSceneOptions::WorldTree::keep;
            } else {
                if (kept_anchor != anchor) {
                    // This run starts within a group: its first frame's tree, built as that
                    // frame builds it (none where that frame has no world-space triangles or
                    // cannot be built: then each frame of the group is built as a still is).
                    prototypes.world.reset();
                    RenderSceneOptions keep = job.scene_options;
                    keep.world_tree = RenderSceneOptions::WorldTree::keep;
                    try {
                        const Posed a = pose(anchor);
                        build_render_scene(a.desc, keep, &prototypes, a.closing ? &*a.closing : nullptr);
                    } catch (const std::exception&) {
                        prototypes.world.reset();
                    }
                }
                scene_options.world_tree = RenderSceneOptions::WorldTree::refit;
            }
            kept_anchor = anchor;
        }
        const RenderScene scene = build_render_scene(posed.desc, scene_options, &prototypes, posed.closing ? &*posed.closing : nullptr);
        const double pose_s = seconds_between(t0, t_posed) + (i == 0 ? open_s : 0.0);
        const double build_s = seconds_between(t_posed, Clock::now());

        RunCallbacks frame_cb = cb;
        frame_cb.progress = [&](const RenderProgress& p) {
            if (!cb.progress) return;
            RenderProgress whole = p;
            whole.samples_done += samples_before;
            cb.progress(whole);
        };
        frame_cb.frame = nullptr;
        RenderJob frame_job = job;
        frame_job.render = job.frame_settings(n);
        const JobOutcome done = render_prepared(frame_job, frame_job.render, ScenePrepared{scene, pose_s, build_s, {}}, t0,
                                                frame_opt, frame_out, frame_cb);
        if (done.stopped) {
            outcome.stopped = true;
            return outcome;
        }
        samples_before += done.render->stats.samples;
        render_s += done.render->stats.render_seconds;
        const double frame_s = seconds_between(t0, Clock::now());
        frames_s += frame_s;
        if (done.image) sheet.add(i, *done.image);
        if (!frame_out.png.empty()) pngs.push_back(frame_out.png);
        json entry = done.summary;
        entry["frame"] = n;
        entry["time_s"] = time_s;
        entry["seed"] = frame_job.render.seed;
        entry["seconds"] = frame_s;
        entries.push_back(entry);
        if (cb.frame) cb.frame(FrameDone{i, n, frame_s, entry});
    }

    if (opt.frame_slice) {
        // A chunk: its frames are written; the shot's last chunk writes what covers them all.
        outcome.summary = {{"frames", end - first}, {"frames_resumed", resumed}, {"open_s", open_s}, {"frames_s", frames_s},
                           {"scene_opened", !opt.scene_file}};
        return outcome;
    }
    if (!out.contact_sheet_png.empty()) {
        if (!out.directory.empty()) std::filesystem::create_directories(out.directory);
        write_png(out.contact_sheet_png, sheet.image(), out.tone);
    }
    json preview = nullptr;
    if (!out.preview_mp4.empty()) {
        const PreviewResult p = write_preview(pngs, job.fps, out.preview_mp4);
        preview = {{"written", p.written}, {"seconds", p.seconds}};
        if (!p.written) preview["why_not"] = p.why_not;
    }
    json animations = json::array();
    for (const AnimationSummary& a : file.animations())
        animations.push_back({{"name", a.name}, {"start_s", a.start_s}, {"end_s", a.end_s}, {"channels", a.channels}});
    const double total_s = seconds_between(t_start, Clock::now());
    json shot = {{"frames", entries},
                 {"frames_total", frames.size()},
                 {"frames_done", frames.size()},
                 {"fps", job.fps},
                 {"animation", animation_json(job)},
                 {"animations", animations},
                 {"preview", preview},
                 {"timings", {{"open_s", open_s}, {"render_s", render_s}, {"frames_s", frames_s}, {"total_s", total_s},
                              {"mean_frame_s", frames.empty() ? 0.0 : frames_s / double(frames.size())}}}};
    if (file.animations().empty()) shot["warnings"] = json::array({"the scene has no animation: every frame shows it at rest"});
    shot["frames_resumed"] = resumed;
    outcome.report = {{"settings", to_json(job)}, {"shot", shot}};
    write_text(out.report_json, json_text(outcome.report, 2));
    outcome.summary = {{"shot", {{"frames_total", frames.size()}, {"frames_done", frames.size()},
                                 {"mean_frame_s", shot["timings"]["mean_frame_s"]}, {"timings", shot["timings"]}}}};
    // The status's progress counts every frame's samples and tiles, as it did while the shot ran.
    uint64_t samples_done = 0, tiles_done = 0, tiles_total = 0;
    for (const json& e : entries)
        if (const auto p = e.find("progress"); p != e.end() && p->is_object()) {
            samples_done += p->value("samples_done", uint64_t{0});
            tiles_done += p->value("tiles_done", uint64_t{0});
            tiles_total += p->value("tiles_total", uint64_t{0});
        }
    outcome.summary["progress"] = {{"fraction", 1.0}, {"tiles_done", tiles_done}, {"tiles_total", tiles_total}, {"samples_done", samples_done}};
    // What the status links to: the preview where it was made, each frame's denoised image
    // where every frame made one (a frame whose time ran out before two samples a pixel has none).
    outcome.summary["shot"]["preview"] = preview;
    if (job.render.denoise) {
        bool every = true;
        for (const json& e : entries) every = every && e.value("denoised", false);
        outcome.summary["denoised"] = every;
    }
    if (frames.size() <= kStatusFrameList) {
        json summary_frames = json::array();
        for (const json& e : entries)
            summary_frames.push_back({{"frame", e["frame"]}, {"seconds", e["seconds"]}, {"state", "succeeded"}});
        outcome.summary["shot"]["frames"] = summary_frames;
    }
    return outcome;
}

}  // namespace tessera::api
