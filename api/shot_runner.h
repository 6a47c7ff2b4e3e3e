#pragma once
// A shot: the frames of a scene's animation rendered one after another through the same path as
// a still (render_prepared), the scene file parsed once and posed per frame, each frame written
// to its own outputs, then a contact sheet and the shot's report.
#include "api/job_runner.h"

namespace tessera::api {

// Throws SceneError (the scene does not read: a run may be tried again), InvalidJob (an
// animation the scene lacks or cannot play: final) and std::runtime_error (a result that cannot
// be written); a stop ends it between or inside frames, writing no report.
JobOutcome run_shot(const RenderJob& job, const RunOptions& options, const RunOutputs& outputs, const RunCallbacks& callbacks);

// Frame `frame`'s outputs under a CLI pattern: the run of '#' in `pattern` becomes the frame
// number padded with zeros to its length ("out_####.exr", 7 -> "out_0007.exr"); without '#',
// "_<frame>" goes before the extension.
std::string frame_path(const std::string& pattern, int frame);

}  // namespace tessera::api
