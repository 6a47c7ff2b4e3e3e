#include "engine/render/renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>
#include <thread>

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
}

namespace {

struct Tile { int x0, y0, x1, y1; };

std::vector<Tile> make_tiles(int w, int h, int size) {
    std::vector<Tile> tiles;
    for (int y = 0; y < h; y += size)
        for (int x = 0; x < w; x += size) tiles.push_back({x, y, std::min(x + size, w), std::min(y + size, h)});
    return tiles;
}

}  // namespace

RenderResult render(const RenderScene& scene, const RenderSettings& settings, const RenderCallbacks& callbacks) {
    const auto t0 = std::chrono::steady_clock::now();
    RenderResult result;
    result.image = Image(settings.width, settings.height);
    const Camera camera = make_camera(scene.camera, settings.width, settings.height);
    const std::vector<Tile> tiles = make_tiles(settings.width, settings.height, std::max(1, settings.tile_size));
    result.stats.tile_seconds.assign(tiles.size(), 0.0);

    int nthreads = settings.threads > 0 ? settings.threads : int(std::max(1u, std::thread::hardware_concurrency()));
    nthreads = std::max(1, std::min<int>(nthreads, int(tiles.size())));
    result.stats.threads = nthreads;

    std::atomic<size_t> next_tile{0};
    std::atomic<size_t> tiles_done{0};
    std::atomic<uint64_t> samples_done{0};
    std::atomic<bool> canceled{false};
    std::mutex stats_mutex;

    auto worker = [&]() {
        TileContext ctx(scene, settings, camera);
        for (;;) {
            if (callbacks.cancel && callbacks.cancel->load(std::memory_order_relaxed)) { canceled = true; break; }
            const size_t i = next_tile.fetch_add(1, std::memory_order_relaxed);
            if (i >= tiles.size()) break;
            const Tile& t = tiles[i];
            const auto ts = std::chrono::steady_clock::now();
            const uint64_t before = ctx.stats.samples;
            for (int y = t.y0; y < t.y1; ++y)
                for (int x = t.x0; x < t.x1; ++x) ctx.render_pixel(x, y, result.image);
            result.stats.tile_seconds[i] = std::chrono::duration<double>(std::chrono::steady_clock::now() - ts).count();
            samples_done += ctx.stats.samples - before;
            const size_t done = tiles_done.fetch_add(1) + 1;
            if (callbacks.progress) callbacks.progress({done, tiles.size(), samples_done.load()});
        }
        std::lock_guard<std::mutex> lock(stats_mutex);
        result.stats.add(ctx.stats);
    };

    std::vector<std::thread> pool;
    for (int i = 1; i < nthreads; ++i) pool.emplace_back(worker);
    worker();
    for (auto& th : pool) th.join();
    result.stats.canceled = canceled;
    result.stats.render_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return result;
}

}  // namespace tessera
