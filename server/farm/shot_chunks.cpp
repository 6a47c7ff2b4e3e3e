#include "server/farm/shot_chunks.h"

#include <algorithm>
#include <cmath>

namespace tessera::server {

size_t chunk_frames(double open_s, double frame_s, size_t frames_left, size_t nodes, size_t requested) {
    if (requested > 0) return requested;
    if (frames_left == 0) return 1;
    const double frame = std::max(frame_s, 1e-4);
    const double amortised = std::ceil(20.0 * std::max(open_s, 0.0) / frame);
    const size_t spread = (frames_left + std::max<size_t>(nodes, 1) - 1) / std::max<size_t>(nodes, 1);
    const double want = std::min(std::isfinite(amortised) ? amortised : double(frames_left), double(spread));
    return std::max<size_t>(1, size_t(want));
}

std::vector<std::pair<size_t, size_t>> plan_chunks(size_t first, size_t end, size_t chunk) {
    std::vector<std::pair<size_t, size_t>> out;
    chunk = std::max<size_t>(chunk, 1);
    for (size_t i = first; i < end; i += chunk) out.emplace_back(i, std::min(chunk, end - i));
    return out;
}

}  // namespace tessera::server
