#include "server/farm/shot_chunks.h"

#include <algorithm>
#include <cmath>

namespace tessera::server {

size_t chunk_frames(double open_s, double frame_s, size_t frames_left, size_t nodes, size_t requested) {
    if (requested > 0) return requested;
    if (frames_left == 0) return 1;
    nodes = std::max<size_t>(nodes, 1);
    const double frame = std::max(frame_s, 1e-4), start = std::max(open_s, 0.0);
    // A chunk of c frames loses start/(c·frame) of its time to starting, and the shot's end
    // leaves nodes idle for about half a chunk each, c·nodes/(2·frames) of the whole: the sum
    // is least at c = √(2·frames·start / (nodes·frame)).
    const double best = std::ceil(std::sqrt(2.0 * double(frames_left) * start / (double(nodes) * frame)));
    const size_t spread = (frames_left + nodes - 1) / nodes;
    size_t chunk = std::clamp<size_t>(std::isfinite(best) ? size_t(std::min(best, double(frames_left))) : frames_left, 1, spread);
    // As many chunks as a whole number of rounds over the nodes, evened out: equal nodes then
    // finish together.
    size_t chunks = (frames_left + chunk - 1) / chunk;
    chunks = (chunks + nodes - 1) / nodes * nodes;
    return std::max<size_t>(1, (frames_left + chunks - 1) / chunks);
}

std::vector<std::pair<size_t, size_t>> plan_chunks(size_t first, size_t end, size_t chunk) {
    std::vector<std::pair<size_t, size_t>> out;
    chunk = std::max<size_t>(chunk, 1);
    for (size_t i = first; i < end; i += chunk) out.emplace_back(i, std::min(chunk, end - i));
    return out;
}

}  // namespace tessera::server
