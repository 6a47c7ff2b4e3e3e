#include "engine/render/renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>
#include <thread>

#include "engine/render/film.h"
#include "engine/render/tile_context.h"
#include "engine/sampling/rng.h"

namespace tessera {

void RenderStats::add(const RenderStats& o) {
    camera_rays += o.camera_rays;
    shadow_rays += o.shadow_rays;
    bounce_rays += o.bounce_rays;
    traversal.nodes_visited += o.traversal.nodes_visited;
    traversal.prim_tests += o.traversal.prim_tests;
    samples += o.samples;
    nonfinite_samples += o.nonfinite_samples;
    max_sample = std::max(max_sample, o.max_sample);
}

namespace {

using Clock = std::chrono::steady_clock;

struct Tile { int x0, y0, x1, y1; };

std::vector<Tile> make_tiles(int w, int h, int size) {
    std::vector<Tile> tiles;
    for (int y = 0; y < h; y += size)
        for (int x = 0; x < w; x += size) tiles.push_back({x, y, std::min(x + size, w), std::min(y + size, h)});
    return tiles;
}

}  // namespace

RenderResult render(const RenderScene& scene, const RenderSettings& settings, const RenderCallbacks& callbacks) {
    const auto t0 = Clock::now();
    auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - t0).count(); };
    RenderResult result;
    const bool adaptive = settings.adaptive.has_value();
    const Image* reference = callbacks.reference && callbacks.reference->width == settings.width &&
                                     callbacks.reference->height == settings.height ? callbacks.reference : nullptr;
    const bool measuring = settings.estimate_error || settings.target_error > 0 || callbacks.on_pass || reference;
    // Passes of doubling spp only when something is measured or a time limit may cut the
    // render short; otherwise one pass (nothing to report in between).
    const bool progressive = measuring || settings.time_limit_s > 0;
    Film film(settings.width, settings.height, settings.estimate_error || (settings.target_error > 0 && !reference), adaptive);
    film.describe(result.built, result.left_out);
    if (settings.integrator == Integrator::path) {
        (settings.max_depth > 1 ? result.built : result.left_out)
            .push_back(settings.max_depth > 1 ? "indirect bounces up to depth " + std::to_string(settings.max_depth)
                                              : std::string("indirect bounces (max_depth <= 1)"));
        if (!scene.has_lights()) result.left_out.push_back("direct lighting: no lights or emitters, no shadow rays");
        else if (settings.direct == DirectLighting::mis) result.built.push_back("MIS: light and BSDF samples");
        if (settings.russian_roulette <= 0.f || settings.max_depth <= 1) result.left_out.push_back("Russian roulette");
    } else {
        result.left_out.push_back("light transport (normal shading)");
    }
    const Camera camera = make_camera(scene.camera, settings.width, settings.height);
    const std::vector<Tile> tiles = make_tiles(settings.width, settings.height, std::max(1, settings.tile_size));
    result.stats.tile_seconds.assign(tiles.size(), 0.0);

    int nthreads = settings.threads > 0 ? settings.threads : int(std::max(1u, std::thread::hardware_concurrency()));
    nthreads = std::max(1, std::min<int>(nthreads, int(tiles.size())));
    result.stats.threads = nthreads;

    std::vector<std::unique_ptr<TileContext>> contexts;
    for (int i = 0; i < nthreads; ++i) contexts.push_back(std::make_unique<TileContext>(scene, settings, camera));
    std::atomic<uint64_t> samples_done{0};
    std::atomic<size_t> tiles_done_total{0};
    bool stop_time = false, stop_cancel = false;

    // Passes: uniform sampling doubles the samples per pixel (1, 2, 4, …, spp); adaptive
    // sampling runs one batch per pass on the pixels that have not converged.
    int target = 0;
    const int max_passes = adaptive ? (settings.spp + std::max(1, settings.adaptive->batch) - 1) / std::max(1, settings.adaptive->batch) + 1
                                    : 64;
    for (int pass = 0; pass < max_passes; ++pass) {
        target = adaptive ? settings.spp : (progressive ? std::min(settings.spp, target == 0 ? 1 : target * 2) : settings.spp);
        std::atomic<size_t> next_tile{0};
        std::atomic<bool> abort_pass{false};
        auto worker = [&](TileContext& ctx) {
            for (;;) {
                if ((callbacks.cancel && callbacks.cancel->load(std::memory_order_relaxed)) ||
                    (settings.time_limit_s > 0 && elapsed() > settings.time_limit_s)) {
                    abort_pass = true;
                    break;
                }
                const size_t i = next_tile.fetch_add(1, std::memory_order_relaxed);
                if (i >= tiles.size()) break;
                const Tile& t = tiles[i];
                const auto ts = Clock::now();
                const uint64_t before = ctx.stats.samples;
                for (int y = t.y0; y < t.y1; ++y) {
                    // Rows keep the samples of the previous pass when the time runs out mid-tile.
                    if (settings.time_limit_s > 0 && elapsed() > settings.time_limit_s) { abort_pass = true; break; }
                    for (int x = t.x0; x < t.x1; ++x) ctx.render_pixel(x, y, film, target);
                }
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

        ConvergencePoint pt;
        if (measuring) pt = measure_error(film, reference);
        else pt.spp_mean = double(samples_done.load()) / (double(settings.width) * settings.height);
        pt.seconds = elapsed();
        result.curve.points.push_back(pt);
        if (callbacks.on_pass) callbacks.on_pass(pt);

        bool all_done = !adaptive ? target >= settings.spp
                                  : std::all_of(film.done.begin(), film.done.end(), [](uint8_t d) { return d != 0; });
        if (stop_cancel) { result.curve.stop = StopReason::canceled; break; }
        if (stop_time) { result.curve.stop = StopReason::time_limit; break; }
        const double err = pt.rel_mse >= 0 ? pt.rel_mse : pt.est_rel_mse;
        if (settings.target_error > 0 && err >= 0 && err <= settings.target_error) { result.curve.stop = StopReason::target_error; break; }
        if (all_done) {
            result.curve.stop = adaptive && std::any_of(film.count.begin(), film.count.end(), [&](uint32_t c) { return int(c) < settings.spp; })
                                    ? StopReason::converged : StopReason::spp;
            break;
        }
    }
    for (auto& c : contexts) result.stats.add(c->stats);
    result.image = film.resolve();
    result.stats.canceled = stop_cancel;
    result.stats.render_seconds = elapsed();
    return result;
}

}  // namespace tessera
