#include "engine/render/renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>
#include <thread>

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
    const auto t0 = Clock::now();
    auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - t0).count(); };
    RenderResult result;
    const Image* reference = callbacks.reference && callbacks.reference->width == settings.width &&
                                     callbacks.reference->height == settings.height ? callbacks.reference : nullptr;
    const PassPlan plan = plan_passes(settings, reference != nullptr, bool(callbacks.on_pass));
    Film film(settings.width, settings.height, plan.half_buffer, plan.adaptive, plan.aovs);
    describe_render(scene, settings, film, result.built, result.left_out);
    const Camera camera = camera_for(scene, settings);
    const std::vector<TileRect>& tiles = plan.tiles;
    result.stats.tile_seconds.assign(tiles.size(), 0.0);

    int nthreads = settings.threads > 0 ? settings.threads : int(std::max(1u, std::thread::hardware_concurrency()));
    nthreads = std::max(1, std::min<int>(nthreads, int(tiles.size())));
    result.stats.threads = nthreads;

    std::vector<std::unique_ptr<TileContext>> contexts;
    for (int i = 0; i < nthreads; ++i) contexts.push_back(std::make_unique<TileContext>(scene, settings, camera));
    std::atomic<uint64_t> samples_done{0};
    std::atomic<size_t> tiles_done_total{0};
    bool stop_time = false, stop_cancel = false;

    int target = pass_target(settings, plan, 0);
    auto out_of_time = [&] { return settings.time_limit_s > 0 && elapsed() > settings.time_limit_s; };
    for (int pass = 0;; ++pass) {
        std::atomic<size_t> next_tile{0};
        std::atomic<bool> abort_pass{false};
        auto worker = [&](TileContext& ctx) {
            for (;;) {
                if ((callbacks.cancel && callbacks.cancel->load(std::memory_order_relaxed)) || out_of_time()) {
                    abort_pass = true;
                    break;
                }
                const size_t i = next_tile.fetch_add(1, std::memory_order_relaxed);
                if (i >= tiles.size()) break;
                const auto ts = Clock::now();
                const uint64_t before = ctx.stats.samples;
                if (!render_tile(ctx, tiles[i], film, target, out_of_time)) abort_pass = true;
                result.stats.tile_seconds[i] += std::chrono::duration<double>(Clock::now() - ts).count();
                samples_done += ctx.stats.samples - before;
                const size_t done = tiles_done_total.fetch_add(1) + 1;
                // Progress: tiles within the current pass, samples over the whole render.
                if (callbacks.progress) callbacks.progress({done - tiles.size() * size_t(pass), tiles.size(), samples_done.load()});
            }
        };
        std::vector<std::thread> pool;
        for (int i = 1; i < nthreads; ++i) pool.emplace_back(worker, std::ref(*contexts[size_t(i)]));
        worker(*contexts[0]);
        for (auto& th : pool) th.join();
        if (callbacks.cancel && callbacks.cancel->load()) stop_cancel = true;
        if (abort_pass && !stop_cancel) stop_time = true;

        const PassEnd end = end_pass(settings, plan, film, reference, pass, target, samples_done.load(), elapsed(), stop_time, stop_cancel);
        result.curve.points.push_back(end.point);
        if (end.denoised) result.denoised = end.denoised;
        if (callbacks.on_pass) callbacks.on_pass(PassView{pass, target, end.point, film, end.denoised});
        if (end.stop) {
            result.curve.stop = *end.stop;
            break;
        }
        target = end.next_target;
    }
    for (auto& c : contexts) result.stats.add(c->stats);
    result.image = film.resolve();
    result.aovs = film.resolve_aovs(settings.aovs);
    result.stats.canceled = stop_cancel;
    result.stats.render_seconds = elapsed();
    return result;
}

}  // namespace tessera
