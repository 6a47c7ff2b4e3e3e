#pragma once
// The pass driver: the schedule of a render, its tile tasks and the end of each pass, as plain
// functions over plain data. The one-process renderer (renderer.cpp) runs them on its threads;
// a render farm's nodes (server/farm/render_node.cpp) run the same functions on tasks they take from
// Redis, which only carries their inputs and outputs: the same tiles, sample targets and stop
// rules, so a farm's image equals one process's bit for bit.
// A pixel's film entries depend only on its samples, taken in order from its own random streams,
// so where the pass boundaries fall never changes the sums.
#include <functional>
#include <memory>
#include <optional>
#include <cstdint>
#include <string>
#include <vector>

#include "engine/core/block_pool.h"
#include "engine/render/convergence.h"
#include "engine/render/denoise.h"
#include "engine/render/film.h"
#include "engine/render/render_settings.h"

namespace tessera {

struct RenderScene;
class TileContext;
struct Image;

struct TileRect {
    int x0, y0, x1, y1;
    int width() const { return x1 - x0; }
    int height() const { return y1 - y0; }
    size_t pixels() const { return size_t(width()) * size_t(height()); }
};

// Row-major tiles of `size` pixels (the last row and column narrower).
std::vector<TileRect> make_tiles(int width, int height, int size);

// The schedule of a render, fixed by its settings before its first sample.
// Guided sampling starts after the uniform pass of this many samples per pixel (fewer give the
// denoiser's estimate too little to go by), and gives no pixel more than kGuidedCap times the
// pass's mean: enough for the few pixels no filter helps (a crease's heavy-tailed noise; at 16
// times the Duck at 640×480 took twice the time to its target, docs/denoising.md), while one
// wrong estimate can take no more than that of a pass.
inline constexpr int kGuidedFrom = 8;
inline constexpr int kGuidedCap = 64;
// The first uniform pass target that is denoised (the last pass always is): denoising an image
// costs about what 2-4 samples per pixel of the Cornell box do (0.08 s at 320×240 on 2
// threads), so denoising the 2-spp pass (one sample has no halves) would about double its time
// for a preview a few tenths of a second old. Fixed by the target, not by a clock, so that the
// render stops (target_error on the denoised image) at the same pass in every run.
inline constexpr int kDenoiseFrom = 4;
static_assert(kDenoiseFrom <= kGuidedFrom, "guided sampling reads the denoised error of the pass before it");

struct PassPlan {
    bool adaptive = false;
    bool measuring = false;    // an error is measured after each pass
    bool progressive = false;  // several passes (doubling spp, or adaptive batches)
    bool half_buffer = false;  // the film keeps the odd samples (error estimate)
    bool guided = false;       // passes after kGuidedFrom spend their samples by the denoised error
    int max_passes = 1;
    std::vector<TileRect> tiles;
    // No stop rule needs the whole image between passes (the render stops on spp alone): a
    // tile may go through every pass target in one task, measuring its own error after each
    // (a render farm does, without a barrier per pass). Its sums equal pass-by-pass rendering's:
    // a pixel's samples are added in the same order.
    bool whole_tiles = false;
    std::vector<int> targets;  // the uniform pass targets, 1, 2, 4, …, spp (one: spp)
    AovSet aovs = 0;           // the film's AOVs: the job's and what the denoiser reads
};

PassPlan plan_passes(const RenderSettings& settings, bool has_reference, bool observed);
// Whether a render's passes past kGuidedFrom are guided (a denoising render that asks, is not
// the CS184 adaptive sampler's, and goes past that count).
bool guides_samples(const RenderSettings& settings);
// The per-pixel sample target of the pass after one that reached `previous` (0 before the first).
int pass_target(const RenderSettings& settings, const PassPlan& plan, int previous);
// After a pass: why the render stops now, or nothing if another pass follows.
std::optional<StopReason> stop_after_pass(const RenderSettings& settings, const PassPlan& plan, const Film& film,
                                          int target, const ConvergencePoint& point, bool out_of_time, bool canceled);

// The end of a pass, wherever its tiles were rendered: its error point and what follows.
struct PassEnd {
    ConvergencePoint point;
    std::shared_ptr<const Denoised> denoised;  // the pass's denoised image, when the render denoises
    std::vector<uint32_t> goals;  // guided: each pixel's target in the next pass (Film::goal); empty, next_target
    std::optional<StopReason> stop;  // nothing: pass + 1 follows, at next_target
    int next_target = 0;
};
// `film` covers the whole image after pass `pass` (0 first) at `target`; `samples` were taken
// in all, `seconds` since the render started; `out_of_time` if a tile was cut short by the time
// limit, `canceled` if the render was stopped. `memory`: where the denoiser's maps are kept
// from one pass to the next (denoise.h).
PassEnd end_pass(const RenderSettings& settings, const PassPlan& plan, const Film& film, const Image* reference, int pass,
                 int target, uint64_t samples, double seconds, bool out_of_time, bool canceled, BlockPool* memory = nullptr);

// A tile's error sums at one pass target of a whole-tile task, and when it got there (seconds
// since the render started, on the clock the caller gives).
struct TargetSums {
    int target = 0;
    double seconds = 0;
    ErrorSums sums;
};
// A whole-tile task: tile `tile` of the plan into `film` (the tile's own: Film::tile) through
// every pass target, its error sums measured after each (`reference`: the whole image's, or
// null; `clock`: seconds since the render started). `cut` is checked before each row; a cut
// task reports the targets it reached.
struct WholeTile {
    bool cut_short = false;
    std::vector<TargetSums> sums;
};
WholeTile render_whole_tile(TileContext& ctx, const PassPlan& plan, size_t tile, Film& film, const Image* reference,
                            const std::function<bool()>& cut, const std::function<double()>& clock = {});
// The curve of a whole-tile render from every tile's sums: a point per target that every one of
// `tiles` reached, timed when the last of them got there.
ConvergenceCurve whole_tile_curve(const PassPlan& plan, const std::vector<std::vector<TargetSums>>& per_tile);

// What the render builds and leaves out (film buffers, bounces, light paths), for the report.
void describe_render(const RenderScene& scene, const RenderSettings& settings, const Film& film,
                     std::vector<std::string>& built, std::vector<std::string>& left_out);
// A denoising render that ended with no denoised image (before every pixel had the two samples
// the denoiser compares: a time limit) says so in `left_out`, and why.
void describe_denoised(const RenderSettings& settings, bool denoised, bool canceled, std::vector<std::string>& left_out);

// A pass's task: one tile through the pass's target, into `film`, which covers the tile (the
// whole image's, or the tile's own: Film::tile). `out_of_time` is checked before each row: rows
// not started keep the samples of the previous pass. Returns false if it cut the tile short.
bool render_tile(TileContext& ctx, const TileRect& tile, Film& film, int target,
                 const std::function<bool()>& out_of_time = {});

// Copies a tile's entries between two films that both cover it (the image's and the tile's).
void copy_tile_into(const Film& tile_film, const TileRect& tile, Film& image_film);
void copy_tile_from(const Film& image_film, const TileRect& tile, Film& tile_film);
// A tile's part of an image's guided targets (PassEnd::goals), row by row: what a farm's node
// that renders the tile sets as its film's goal.
std::vector<uint32_t> tile_goals(const std::vector<uint32_t>& image_goals, int image_width, const TileRect& tile);

}  // namespace tessera
