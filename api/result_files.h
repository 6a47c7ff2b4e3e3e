#pragma once
// What results a job has, decided once from its settings and summary: its status links to them
// and the server serves them, or says why it never will, by this one rule.
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace tessera::api {

// Why a job never has a result file (a file it may still be making is not one of these).
enum class Unoffered {
    none,          // it has it, or will
    not_a_shot,    // a still's or comparison's contact sheet, preview or frames
    per_frame,     // a shot's images are per frame
    not_a_render,  // a comparison has its report and plot alone
    not_denoised,  // the job did not ask to denoise
    no_such_pass,  // the job did not ask for that pass (or for any)
};

struct ResultFiles {
    enum class Kind { still, shot, comparison } kind = Kind::still;
    bool denoise = false;             // asked for
    bool denoised = true;             // false once the summary says none was made
    std::vector<std::string> passes;  // asked for, by name
    bool preview = true;              // false once a shot's summary says none was written

    // From a job's settings (its JSON as stored) and, once it has ended, its summary.
    static ResultFiles of(const nlohmann::json& settings, const nlohmann::json& summary = nullptr);

    // Why the job never has `file` (a name under the job, or under one of its frames'
    // folders where `frame`): none where it has or will have it.
    Unoffered unoffered(std::string_view file, bool frame) const;

    // What a status links to, name and path under the job ("frames/{n}/..." for a frame's).
    std::vector<std::pair<std::string, std::string>> links() const;

    // Every name the API's routes take for a job's results (`frame`: under a frame's folder),
    // whatever the job: what the server's routes are built from.
    static std::vector<std::string> routed(bool frame);
    // Whether `file` is an image a running render shows its latest pass by at the job's own URL
    // (a running shot's current frame too, though its finished images are per frame).
    static bool live(std::string_view file);
};

}  // namespace tessera::api
