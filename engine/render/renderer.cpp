#include "engine/render/renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <thread>

#include "engine/core/block_pool.h"
#include "engine/render/checkpoint.h"
#include "engine/render/film.h"
#include "engine/render/passes.h"
#include "engine/render/tile_context.h"
#include "engine/sampling/rng.h"

namespace tessera {

Camera camera_for(const RenderScene& scene, const RenderSettings& settings) {
    Camera camera = make_camera(scene.camera, settings.width, settings.height);
    set_thin_lens(camera, scene.camera, settings.lens_radius, settings.focal_distance);
    return camera;
}

void RenderStats::add(const RenderStats& o) {
    for_each_counter([](const char*, uint64_t& a, uint64_t b) { a += b; }, *this, o);
    max_sample = std::max(max_sample, o.max_sample);
}

using Clock = std::chrono::steady_clock;

RenderResult render(const RenderScene& scene, const RenderSettings& settings, const RenderCallbacks& callbacks) {
    RenderResult result;
    const Image* reference = callbacks.reference && callbacks.reference->width == settings.width &&
                                     callbacks.reference->height == settings.height ? callbacks.reference : nullptr;
    const PassPlan plan = plan_passes(settings, reference != nullptr, bool(callbacks.on_pass));
    const std::vector<TileRect>& tiles = plan.tiles;
    const RenderCheckpoint* resume =
        callbacks.resume && fits(*callbacks.resume, settings.width, settings.height, plan.half_buffer, plan.adaptive, plan.aovs, tiles.size())
            ? callbacks.resume : nullptr;
    // A resumed render's clock starts at the time its checkpoint had rendered (a time limit
    // counts over both).
    const auto t0 = Clock::now() - std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(resume ? resume->seconds : 0.0));
    auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - t0).count(); };
    Film film = resume ? resume->film : Film(settings.width, settings.height, plan.half_buffer, plan.adaptive, plan.aovs);
    BlockPool denoise_memory;  // the denoiser's maps, from one pass to the next
    // A checkpoint's guided targets only where this render guides, and none beyond its cap (a
    // damaged or foreign file would otherwise ask a pixel for billions of samples).
    if (!film.goal.empty() &&
        (!plan.guided || film.goal.size() != film.count.size() ||
         std::any_of(film.goal.begin(), film.goal.end(), [&](uint32_t g) { return g > uint32_t(kGuidedCap) * uint32_t(settings.spp); })))
        film.goal.clear();
    describe_render(scene, settings, film, result.built, result.left_out);
    const Camera camera = camera_for(scene, settings);
    result.stats.tile_seconds.assign(tiles.size(), 0.0);

    int nthreads = settings.threads > 0 ? settings.threads : int(std::max(1u, std::thread::hardware_concurrency()));
    nthreads = std::max(1, std::min<int>(nthreads, int(tiles.size())));
    result.stats.threads = nthreads;

    std::vector<std::unique_ptr<TileContext>> contexts;
    const SeenEmitters seen = seen_emitters(scene, settings, camera, 0, 0, settings.width, settings.height);
    for (int i = 0; i < nthreads; ++i) contexts.push_back(std::make_unique<TileContext>(scene, settings, camera, &seen));
    std::atomic<uint64_t> samples_done{0};
    std::atomic<size_t> tiles_done_total{0};
    bool stop_time = false, stop_cancel = false;

    int target = pass_target(settings, plan, 0), first_pass = 0;
    RenderStats carried;  // counters a checkpoint brought
    std::vector<uint8_t> pass_done(tiles.size(), 0);  // the current pass's finished tiles
    if (resume) {
        first_pass = resume->pass;
        target = resume->target;
        pass_done = resume->tiles_done;
        result.curve.points = resume->points;
        samples_done = resume->samples;
        carried = resume->stats;
        result.resumed_samples = resume->film_samples();
        result.resumed_seconds = resume->seconds;
        tiles_done_total = tiles.size() * size_t(first_pass) + size_t(std::count(pass_done.begin(), pass_done.end(), 1));
        result.built.push_back("resumed from a checkpoint: pass " + std::to_string(first_pass + 1) + ", " +
                               std::to_string(result.resumed_samples) + " samples");
    }
    auto out_of_time = [&] { return settings.time_limit_s > 0 && elapsed() > settings.time_limit_s; };

    // Checkpoints are taken between tiles: a thread that finds one due holds the others before
    // their next tile, waits for the tiles in hand, and copies the film (no pixel half-sampled).
    std::mutex gate;
    std::condition_variable gate_cv;
    int in_tile = 0;
    bool hold = false;
    double last_checkpoint = elapsed();
    int pass = first_pass;
    auto snapshot = [&] {  // every thread is between tiles
        auto c = std::make_unique<RenderCheckpoint>();
        c->pass = pass;
        c->target = target;
        c->tiles_done = pass_done;
        c->points = result.curve.points;
        c->samples = samples_done.load();
        c->seconds = elapsed();
        c->stats = carried;
        for (auto& ctx : contexts) c->stats.add(ctx->stats);
        c->stats.tile_seconds.clear();
        c->film = film;
        return c;
    };
    const bool periodic = callbacks.on_checkpoint && callbacks.checkpoint_seconds > 0;

    for (;; ++pass) {
        std::atomic<size_t> next_tile{0};
        std::atomic<bool> abort_pass{false};
        auto worker = [&](TileContext& ctx) {
            for (;;) {
                if ((callbacks.cancel && callbacks.cancel->load(std::memory_order_relaxed)) || out_of_time()) {
                    abort_pass = true;
                    break;
                }
                size_t i;
                {
                    std::unique_lock<std::mutex> lock(gate);
                    gate_cv.wait(lock, [&] { return !hold; });
                    do i = next_tile.fetch_add(1, std::memory_order_relaxed);
                    while (i < tiles.size() && pass_done[i]);
                    if (i >= tiles.size()) break;
                    ++in_tile;
                }
                const auto ts = Clock::now();
                const uint64_t before = ctx.stats.samples;
                const bool finished = render_tile(ctx, tiles[i], film, target, out_of_time);
                if (!finished) abort_pass = true;
                result.stats.tile_seconds[i] += std::chrono::duration<double>(Clock::now() - ts).count();
                samples_done += ctx.stats.samples - before;
                const size_t done = tiles_done_total.fetch_add(1) + 1;
                // Progress: tiles within the current pass, samples over the whole render.
                if (callbacks.progress) callbacks.progress({done - tiles.size() * size_t(pass), tiles.size(), samples_done.load()});
                bool due = false;
                {
                    std::lock_guard<std::mutex> lock(gate);
                    --in_tile;
                    if (finished) pass_done[i] = 1;
                    if (hold && in_tile == 0) gate_cv.notify_all();
                    due = periodic && !hold && !abort_pass && elapsed() - last_checkpoint >= callbacks.checkpoint_seconds;
                    if (due) hold = true;
                }
                if (due) {
                    // No exception leaves a render thread, and the others are never left held:
                    // a checkpoint that cannot be taken (no memory for the copy) is skipped.
                    std::unique_ptr<RenderCheckpoint> c;
                    {
                        std::unique_lock<std::mutex> lock(gate);
                        gate_cv.wait(lock, [&] { return in_tile == 0; });
                        try {
                            c = snapshot();
                        } catch (...) {
                        }
                        hold = false;
                        last_checkpoint = elapsed();
                    }
                    gate_cv.notify_all();
                    try {
                        if (c) callbacks.on_checkpoint(*c);
                    } catch (...) {
                    }
                }
            }
        };
        std::vector<std::thread> pool;
        for (int i = 1; i < nthreads; ++i) pool.emplace_back(worker, std::ref(*contexts[size_t(i)]));
        worker(*contexts[0]);
        for (auto& th : pool) th.join();
        if (callbacks.cancel && callbacks.cancel->load()) stop_cancel = true;
        if (abort_pass && !stop_cancel) stop_time = true;
        // Stopped by `cancel` (a job paused, a server shutting down): its state before the pass's
        // end, to be continued by running the pass again.
        if (stop_cancel && callbacks.on_checkpoint && !(callbacks.discard && callbacks.discard->load())) {
            try {
                callbacks.on_checkpoint(*snapshot());
            } catch (...) {  // the samples since the last checkpoint are rendered again
            }
        }

        PassEnd end = end_pass(settings, plan, film, reference, pass, target, samples_done.load(), elapsed(), stop_time, stop_cancel,
                               &denoise_memory);
        result.curve.points.push_back(end.point);
        if (end.denoised) result.denoised = end.denoised;
        if (callbacks.on_pass) callbacks.on_pass(PassView{pass, target, end.point, film, end.denoised});
        if (end.stop) {
            result.curve.stop = *end.stop;
            break;
        }
        target = end.next_target;
        film.goal = std::move(end.goals);
        std::fill(pass_done.begin(), pass_done.end(), 0);
    }
    result.stats.add(carried);
    for (auto& c : contexts) result.stats.add(c->stats);
    result.image = film.resolve();
    result.aovs = film.resolve_aovs(settings.aovs);
    result.stats.canceled = stop_cancel;
    describe_denoised(settings, result.denoised != nullptr, stop_cancel, result.left_out);
    result.stats.render_seconds = elapsed();
    return result;
}

}  // namespace tessera
