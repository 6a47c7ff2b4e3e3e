#pragma once
// A render stopped between tiles, to be continued later: by a server that restarts after a crash
// or `kill -9`, or a job paused and resumed. Samples depend only on (seed, pixel, sample index)
// and a pixel continues from its count (tile_context.h), so a render resumed from its checkpoint
// ends with the same image, bit for bit, as one never stopped: the pass it was in is run again
// without the tiles it had finished.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "engine/render/convergence.h"
#include "engine/render/film.h"
#include "engine/render/film_codec.h"  // ByteSink
#include "engine/render/renderer.h"

namespace tessera {

struct RenderCheckpoint {
    int pass = 0;                      // the pass it stopped in (0 first)
    int target = 0;                    // that pass's per-pixel sample target
    std::vector<uint8_t> tiles_done;   // that pass's tiles finished, by their index in the plan
    std::vector<ConvergencePoint> points;  // the passes finished before
    uint64_t samples = 0;              // samples taken so far
    double seconds = 0;                // render time so far
    RenderStats stats;                 // counters so far (rays, samples, ...; no tile times)
    Film film{0, 0, false, false};

    // The samples it holds (what a resumed render does not take again).
    uint64_t film_samples() const;
};

// As bytes, with a checksum: decode_checkpoint throws std::runtime_error for bytes this build did
// not write whole (a torn or damaged file): the render then starts afresh. The sink's form
// streams them (to a file: no copy of the film in memory beside the checkpoint's own).
void encode_checkpoint(const RenderCheckpoint& c, const ByteSink& out);
std::string encode_checkpoint(const RenderCheckpoint& c);
RenderCheckpoint decode_checkpoint(std::string_view bytes);

// Whether a checkpoint continues a render of these settings and plan: the film's size and
// buffers, the pass's tiles and target; a checkpoint that does not is ignored.
bool fits(const RenderCheckpoint& c, int width, int height, bool half_buffer, bool adaptive, AovSet aovs, size_t tiles);

}  // namespace tessera
