#pragma once
// A render's checkpoint on disk (engine/render/checkpoint.h): written whole or not at all, so a
// server killed at any instant finds either the last checkpoint or the one before it.
#include <optional>
#include <string>

#include "engine/render/checkpoint.h"

namespace tessera::api {

// Writes beside the file, flushes it to the disk, and renames it over the file. False (and the
// file as it was) when the disk refuses: a render goes on without that checkpoint.
bool write_checkpoint(const std::string& path, const RenderCheckpoint& c) noexcept;
// The checkpoint at `path`; nothing when there is none, or when it is damaged (then it is
// removed, and the render starts afresh).
std::optional<RenderCheckpoint> read_checkpoint(const std::string& path);

}  // namespace tessera::api
