#pragma once
// Renders a RenderScene: the image is cut into tiles that worker threads take from a shared
// counter; each pixel sample draws from its own random stream (sampling/rng.h), so the image
// is the same bit for bit whatever the thread count or tile order.
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "engine/render/convergence.h"
#include "engine/render/denoise.h"
#include "engine/render/image.h"
#include "engine/render/render_settings.h"
#include "engine/scene/render_scene.h"

namespace tessera {

struct RenderStats {
    uint64_t camera_rays = 0;
    uint64_t shadow_rays = 0;
    uint64_t bounce_rays = 0;
    TraversalCounters traversal;
    uint64_t samples = 0;
    uint64_t nonfinite_samples = 0;  // NaN/Inf radiance samples, dropped from the film
    float max_sample = 0.f;          // largest luminance of one sample (fireflies show here)
    double render_seconds = 0.0;
    int threads = 0;
    bool canceled = false;
    std::vector<double> tile_seconds;

    uint64_t rays() const { return camera_rays + shadow_rays + bounce_rays; }
    void add(const RenderStats& o);
};

// The counters of RenderStats that add up over tiles and nodes, each with its one name: adding,
// a render farm's Redis fields and its decoding all read this list. Calls f(name, s.field...)
// for every counter, over one or more RenderStats (const or not).
template <class F, class... Stats>
void for_each_counter(F&& f, Stats&... s) {
    f("samples", s.samples...);
    f("rays_camera", s.camera_rays...);
    f("rays_shadow", s.shadow_rays...);
    f("rays_bounce", s.bounce_rays...);
    f("nodes_visited", s.traversal.nodes_visited...);
    f("prim_tests", s.traversal.prim_tests...);
    f("nonfinite", s.nonfinite_samples...);
}

struct RenderProgress {
    size_t tiles_done = 0;
    size_t tiles_total = 0;
    uint64_t samples_done = 0;
};

struct Film;
struct RenderCheckpoint;

// What a finished pass shows: its number (0 first), its per-pixel sample target, its error point
// and the film as it stands (valid during the call only: the next pass adds to it).
struct PassView {
    int index = 0;
    int spp = 0;
    const ConvergencePoint& point;
    const Film& film;
    std::shared_ptr<const Denoised> denoised;  // the pass's denoised image, when the render denoises
};

struct RenderCallbacks {
    // Called after each tile from the worker that finished it (keep it cheap and thread-safe).
    std::function<void(const RenderProgress&)> progress;
    // Checked between tiles: a set flag stops the render after the pass it is in (pixels keep
    // the samples they have).
    const std::atomic<bool>* cancel = nullptr;
    // Called after every pass from the calling thread, with the error so far and the film (a
    // server shows a running job's latest pass from it).
    std::function<void(const PassView&)> on_pass;
    // An image of the same size to measure the error against (converged render); optional.
    const Image* reference = nullptr;
    // A checkpoint of an earlier render of the same scene and settings to continue from
    // (checkpoint.h); ignored, and the render starts afresh, when it does not fit them.
    const RenderCheckpoint* resume = nullptr;
    // Called with the render's state between tiles (every tile finished, none begun): every
    // checkpoint_seconds of rendering (0: never), and once more when `cancel` stops it. From a
    // render thread, with the others rendering on; the copy is the callee's.
    std::function<void(const RenderCheckpoint&)> on_checkpoint;
    double checkpoint_seconds = 0;
    // Set with `cancel` when the render's state is thrown away (a canceled job): no checkpoint
    // is copied or handed over at the stop (a large film's copy would only hold the stop up).
    const std::atomic<bool>* discard = nullptr;
};

struct RenderResult {
    Image image;
    RenderStats stats;
    ConvergenceCurve curve;
    std::vector<AovPlane> aovs;                // the AOVs the settings asked for
    std::shared_ptr<const Denoised> denoised;  // the last pass's, when the render denoises
    // What this render built and left out (film buffers, bounce and light paths), for the report.
    std::vector<std::string> built, left_out;
    // Continued from a checkpoint: the samples and render seconds it brought (0 when not).
    uint64_t resumed_samples = 0;
    double resumed_seconds = 0;
};

RenderResult render(const RenderScene& scene, const RenderSettings& settings, const RenderCallbacks& callbacks = {});

// The camera a render of `settings` sees the scene through: its size and thin lens.
Camera camera_for(const RenderScene& scene, const RenderSettings& settings);

}  // namespace tessera
