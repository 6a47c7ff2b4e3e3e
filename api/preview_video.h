#pragma once
// A shot's preview: its frames' PNGs encoded as an H.264 MP4 by Debian's ffmpeg, run as a
// child process with an argument vector (no shell), its output bounded.
#include <string>
#include <vector>

namespace tessera::api {

struct PreviewResult {
    bool written = false;
    std::string why_not;  // set when not written: ffmpeg is not installed, or what it said
    double seconds = 0;
};

// Encodes `pngs` (in order, all of one size) at `fps` into `mp4`. Never throws: a shot without
// a preview is still a shot, and the reason goes into its report.
PreviewResult write_preview(const std::vector<std::string>& pngs, double fps, const std::string& mp4);

// The ffmpeg on PATH, or "" (TESSERA_FFMPEG names another).
std::string find_ffmpeg();

}  // namespace tessera::api
