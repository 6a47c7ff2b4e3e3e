#pragma once
// The one path from a typed job to its result files and report: load the scene, build it,
// render (or run the comparison), write the images and the report. `tessera render`, the
// server's workers and the coming render nodes all run jobs through here, so a job renders
// the same image whoever runs it.
#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>

#include "api/job.h"
#include "api/report.h"
#include "engine/io/image_io.h"
#include "engine/io/scene_loader.h"
#include "engine/scene/render_scene.h"

namespace tessera {
class SceneFile;  // engine/io/scene_loader.h
}  // namespace tessera

namespace tessera::api {

// A scene loaded and built for rendering; a cache shares one between jobs (read-only).
struct PreparedScene {
    RenderScene scene;
    double load_s = 0, build_s = 0;
    size_t bytes = 0;  // estimated memory
    std::vector<std::string> files_read;  // SceneDescription::files_read: what else an edit can change
};
// Loads and builds a scene (a file path, or builtin:NAME[?params]). Throws SceneError. `name`
// is what its errors, warnings and origins call the file (load_scene's); empty: the path.
std::shared_ptr<PreparedScene> prepare_scene(const std::string& source, const LoadLimits& limits, const RenderSceneOptions& options,
                                             const std::string& name = {});

// Where a runner's scenes come from when it keeps them between jobs: the scene for `source`
// (called `name` in what it reports) built with `options`, and whether it was there already (a hit).
using ScenePreparer = std::function<std::pair<std::shared_ptr<const PreparedScene>, bool>(
    const std::string& source, const std::string& name, const RenderSceneOptions& options)>;

// A lat-long environment map read from an .exr or .hdr file. Throws SceneError naming the
// file (unreadable, another format, negative or non-finite pixels) by `name` (empty: its path),
// which the map's report line uses too.
std::shared_ptr<const EnvironmentMap> load_environment(const std::string& path, const std::string& name = {});
// What lights a scene without lights when the job names no environment: a uniform white sky of
// radiance 1 (most glTF models carry no lights), the same on one process and on a render farm.
std::shared_ptr<const EnvironmentMap> default_environment();
// The settings a scene renders with: `settings`, lit by default_environment() when neither the
// job nor the scene has a light. One process and a render farm's nodes both render through it.
RenderSettings lit_settings(RenderSettings settings, const RenderScene& scene);

// How this runner runs the job: not part of the job (the same job gives the same image with
// any of these).
struct RunOptions {
    std::string scene_source;       // what load_scene takes: a file path, or builtin:NAME[?params]
    // What the job's errors, log and report call its files (a server's catalog names them by
    // their place in it: nothing a client reads shows the server's folders); empty: their paths.
    std::string scene_name, environment_name;
    LoadLimits load_limits;
    int threads = 0;                // 0: all cores
    std::string job_id;             // names the job in metadata and plot titles; "" for none
    std::string reference_image;    // the reference job's EXR (RenderJob::reference, resolved)
    std::string environment_file;   // RenderJob::environment, resolved to a file; empty: none
    std::shared_ptr<const EnvironmentMap> environment;  // or loaded already (a render node's): used first
    bool record_convergence = true; // keep the half buffers and report the estimated error
    ScenePreparer prepare;          // a server's cache of prepared scenes; unset: prepared for this job
    bool keep_image = false;        // JobOutcome::image holds the rendered image (a shot's contact sheet)
    // A shot: frames already written by an earlier run of the same job (a node that died, a
    // server that restarted) are kept, not rendered again; frames are independent, so the shot
    // ends with the same images.
    bool resume_frames = false;
    // A farm's chunk of a shot: only frames[first, first + count) (indices into the shot's
    // frames), and no contact sheet, preview or report (the shot's last chunk writes those).
    std::optional<std::pair<size_t, size_t>> frame_slice;
    // A shot's scene opened already (a render node's, kept across the chunks of a shot it
    // renders): used instead of opening the file again.
    std::shared_ptr<const SceneFile> scene_file;
    // Checkpoints (RunOutputs::checkpoint): the render's state is written every this many seconds
    // of rendering (0: only when it is stopped), and a render finding one continues from it.
    double checkpoint_seconds = 0;
};

// Where the results go; an empty path is not written.
struct RunOutputs {
    std::string png, exr, rate_png, convergence_csv, convergence_svg, report_json;
    // The job's passes: all in one multilayer EXR, and each alone as <passes_dir>/<name>.exr;
    // the denoised image (a job that denoises).
    std::string passes_exr, passes_dir, denoised_exr, denoised_png;
    ToneCurve tone = ToneCurve::srgb;
    std::string directory;          // in_directory's folder, made again before writing if it went away
    // A shot's: frame n's outputs (in_directory: frames/<n>/ under the same names), and the
    // contact sheet of every frame.
    std::function<RunOutputs(int frame)> frame;
    std::string contact_sheet_png;
    std::string preview_mp4;        // a shot's frames as a video (ffmpeg; needs each frame's png)
    // The render's checkpoint (engine/render/checkpoint.h): continued from when it is there,
    // written atomically while it renders and when it is stopped, removed once its results are
    // written. Empty: none kept.
    std::string checkpoint;
    // Every result file in `dir` under the server's names (image.png, image.exr, ...).
    static RunOutputs in_directory(const std::string& dir);
};

// A running render's latest finished pass, as a server shows it before the job ends.
struct PassSnapshot {
    int index = 0;        // 0 for the first pass
    int spp = 0;          // the pass's per-pixel sample target
    ConvergencePoint point;
    std::shared_ptr<const Image> image;  // linear RGB with per-pixel sample counts
    // The pass's denoised image (a job that denoises; none before the 4-spp pass but the last).
    std::shared_ptr<const Image> denoised;
};

// A shot's frame, finished and written.
struct FrameDone {
    size_t index = 0;      // its place in the shot (0 first)
    int frame = 0;         // its number
    double seconds = 0;    // posing, building, rendering and writing it
    nlohmann::json entry;  // its line in the shot's report
    bool kept = false;     // written by an earlier run of the job (resume_frames), not rendered now
};

struct RunCallbacks {
    std::function<void(const RenderProgress&)> progress;  // from render threads: cheap, thread-safe; a shot's samples count over all its frames
    std::function<void(const FrameDone&)> frame;          // after each frame of a shot
    std::function<void(const PassSnapshot&)> pass;        // after each pass of a render job (not set: none made)
    const std::atomic<bool>* stop = nullptr;             // set: end early, write nothing but the checkpoint
    const std::atomic<bool>* discard = nullptr;          // set with `stop`: the job is canceled, so not even the checkpoint
};

struct JobOutcome {
    bool stopped = false;            // `stop` ended the job; nothing was written but its checkpoint
    nlohmann::json report;           // report.json's content
    nlohmann::json summary;          // what the job's status shows (status_summary)
    std::optional<RenderReport> render;  // a render job's typed report
    std::shared_ptr<const Image> image;  // RunOptions::keep_image: the image as written
};

// What a finished render leaves: its result files and report, written from the render's result.
// run_job ends with it, and so does a render farm's last pass with the film its nodes filled.
struct FinishedRender {
    FinishedRender(const RenderJob& j, const RenderScene& sc, const RenderSettings& st, const RenderResult& r)
        : job(j), scene(sc), settings(st), result(r) {}
    const RenderJob& job;
    const RenderScene& scene;
    const RenderSettings& settings;  // as rendered (threads, error estimate)
    const RenderResult& result;
    double load_s = 0, build_s = 0;  // preparing the scene
    double before_write_s = 0;       // from the job's start to the end of rendering
    size_t tiles_done = 0, tiles_total = 0;
    std::vector<NodeShare> nodes;
    SceneCacheUse scene_cache;
};
JobOutcome write_render(const FinishedRender& done, const RunOptions& options, const RunOutputs& outputs);

// Writes a result's text whole or throws naming the file (a full disk must fail the job, not
// leave a truncated report behind a success). An empty path writes nothing.
void write_text(const std::string& path, const std::string& text);

// A scene ready to render, and what readying it cost this job.
struct ScenePrepared {
    const RenderScene& scene;
    double load_s = 0, build_s = 0;
    SceneCacheUse cache;
};
// One image of a prepared scene with `render` (the job's settings, or a shot frame's), timed
// from `t0`: a still's whole path after loading, and each frame of a shot.
JobOutcome render_prepared(const RenderJob& job, const RenderSettings& render, const ScenePrepared& scene,
                           std::chrono::steady_clock::time_point t0, const RunOptions& options, const RunOutputs& outputs,
                           const RunCallbacks& callbacks);

// Throws SceneError for a scene that does not load, std::runtime_error (or a filesystem
// error) for a result that cannot be written; the caller decides what the job's state becomes.
JobOutcome run_job(const Job& job, const RunOptions& options, const RunOutputs& outputs, const RunCallbacks& callbacks = {});

}  // namespace tessera::api
