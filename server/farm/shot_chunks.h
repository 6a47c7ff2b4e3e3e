#pragma once
// How a farm spreads a shot over its render nodes: chunks of consecutive frames, each a task a
// node renders with the scene opened once for the chunk.
#include <cstddef>
#include <utility>
#include <vector>

namespace tessera::server {

// Frames per chunk: `requested` when the job sets one; otherwise the size that balances what
// starting a chunk costs (`open_s`, opening the scene as measured on the first frame: a bound,
// since a node keeps the scene across a shot's chunks and starts each with its trees to build)
// against the nodes left idle at the shot's end (`frame_s` a frame, `nodes` live), evened out
// to whole rounds of chunks over the nodes. Every node gets work; at least 1.
size_t chunk_frames(double open_s, double frame_s, size_t frames_left, size_t nodes, size_t requested);

// The shot's frame indices [first, end) cut into chunks of `chunk`: (first index, count) each.
std::vector<std::pair<size_t, size_t>> plan_chunks(size_t first, size_t end, size_t chunk);

}  // namespace tessera::server
