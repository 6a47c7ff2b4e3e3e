#pragma once
// The pixels next to an edge or a texture's detail, which `tessera bench denoise` reports apart
// (a denoiser must keep them sharp, and it gains least there).
#include <cstdint>
#include <vector>

namespace tessera {

// 1 where a pixel differs from one of its eight neighbours by a jump: in albedo (0.04 in a
// channel), or in normal (0.15, L1) or depth (3 % of the nearer) by a step that neither the step
// before it nor the one after it continues. A floor receding at 3 % of its depth per pixel, or a
// small sphere's normal turning 0.1 per pixel, is smooth, not an edge; a crease, a silhouette
// and the rim of a surface against the void are. A step with neither of those beside it in the
// picture (at its border) counts by its size. Planes: normal 3 per pixel, depth 1, albedo 3.
std::vector<uint8_t> detail_mask(const float* normal, const float* depth, const float* albedo, int w, int h);

}  // namespace tessera
