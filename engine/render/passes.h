#pragma once
// The pass schedule of a render, shared by the one-process renderer (renderer.cpp) and render
// nodes that each take tiles of one pass (server/render_node.cpp): the same tiles, the same
// sample targets and the same stop rules, so a farm's image equals one process's bit for bit.
// A pixel's film entries depend only on its samples, taken in order from its own random streams,
// so where the pass boundaries fall never changes the sums.
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "engine/render/convergence.h"
#include "engine/render/film.h"
#include "engine/render/render_settings.h"

namespace tessera {

class RenderScene;
class TileContext;

struct TileRect {
    int x0, y0, x1, y1;
    int width() const { return x1 - x0; }
    int height() const { return y1 - y0; }
    size_t pixels() const { return size_t(width()) * size_t(height()); }
};

// Row-major tiles of `size` pixels (the last row and column narrower).
std::vector<TileRect> make_tiles(int width, int height, int size);

struct PassPlan {
    bool adaptive = false;
    bool measuring = false;    // an error is measured after each pass
    bool progressive = false;  // several passes (doubling spp, or adaptive batches)
    bool half_buffer = false;  // the film keeps the odd samples (error estimate)
    int max_passes = 1;
};

PassPlan plan_passes(const RenderSettings& settings, bool has_reference, bool observed);
// The per-pixel sample target of the pass after one that reached `previous` (0 before the first).
int pass_target(const RenderSettings& settings, const PassPlan& plan, int previous);
// After a pass: why the render stops now, or nothing if another pass follows.
std::optional<StopReason> stop_after_pass(const RenderSettings& settings, const PassPlan& plan, const Film& film,
                                          int target, const ConvergencePoint& point, bool out_of_time, bool canceled);
// What the render builds and leaves out (film buffers, bounces, light paths), for the report.
void describe_render(const RenderScene& scene, const RenderSettings& settings, const Film& film,
                     std::vector<std::string>& built, std::vector<std::string>& left_out);

// Renders one tile of one pass into `film`, which covers the tile: the whole image, or just the
// tile (Film::tile). `out_of_time` is checked before
// each row: rows not started keep the samples of the previous pass. Returns false if it cut the
// tile short.
bool render_tile(TileContext& ctx, const TileRect& tile, Film& film, int target,
                 const std::function<bool()>& out_of_time = {});

// Copies a tile's entries between two films that both cover it (the image's and the tile's).
void copy_tile_into(const Film& tile_film, const TileRect& tile, Film& image_film);
void copy_tile_from(const Film& image_film, const TileRect& tile, Film& tile_film);

}  // namespace tessera
