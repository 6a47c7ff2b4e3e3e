#pragma once
// How a farm spreads a shot over its render nodes: chunks of consecutive frames, each a task a
// node renders with the scene opened once for the chunk.
#include <cstddef>
#include <utility>
#include <vector>

namespace tessera::server {

// Frames per chunk: `requested` when the job sets one; otherwise enough that opening the scene
// again for a chunk (`open_s`, measured on the first frame) costs at most a twentieth of the
// chunk's rendering (`frame_s` a frame), and few enough that each of `nodes` live nodes gets a
// chunk of the `frames_left`. At least 1.
size_t chunk_frames(double open_s, double frame_s, size_t frames_left, size_t nodes, size_t requested);

// The shot's frame indices [first, end) cut into chunks of `chunk`: (first index, count) each.
std::vector<std::pair<size_t, size_t>> plan_chunks(size_t first, size_t end, size_t chunk);

}  // namespace tessera::server
