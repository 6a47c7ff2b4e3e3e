#include "api/result_files.h"

#include <algorithm>

#include "engine/render/aov.h"

namespace tessera::api {

namespace {

// A render's files, a still's or a frame's, with the names its status gives them.
struct RenderFile {
    const char* link;
    const char* file;
};
constexpr RenderFile kRenderFiles[] = {
    {"image_png", "image.png"},         {"image_exr", "image.exr"},         {"rate_png", "rate.png"},
    {"convergence_svg", "convergence.svg"}, {"convergence_csv", "convergence.csv"},
};

bool is_render_file(std::string_view f) {
    return std::any_of(std::begin(kRenderFiles), std::end(kRenderFiles), [&](const RenderFile& r) { return f == r.file; }) ||
           f.starts_with("denoised.") || f.starts_with("passes");
}

}  // namespace

ResultFiles ResultFiles::of(const nlohmann::json& settings, const nlohmann::json& summary) {
    ResultFiles r;
    if (!settings.is_object()) return r;
    if (settings.contains("kind") && settings["kind"] == "comparison") r.kind = Kind::comparison;
    else if (settings.contains("frames") && !settings["frames"].is_null()) r.kind = Kind::shot;
    r.denoise = settings.contains("denoise") && settings["denoise"] == true;
    if (settings.contains("passes") && settings["passes"].is_array())
        for (const auto& p : settings["passes"])
            if (p.is_string()) r.passes.push_back(p.get<std::string>());
    if (summary.is_object()) {
        // A denoising render that ended before two samples a pixel made none (a shot's summary
        // says false unless every frame made one).
        if (summary.contains("denoised") && summary["denoised"] == false) r.denoised = false;
        const auto shot = summary.find("shot");
        if (shot != summary.end() && shot->is_object() && shot->contains("preview") && (*shot)["preview"].is_object() &&
            (*shot)["preview"].contains("written") && (*shot)["preview"]["written"] == false)
            r.preview = false;
    }
    return r;
}

Unoffered ResultFiles::unoffered(std::string_view file, bool frame) const {
    if (frame && kind != Kind::shot) return Unoffered::not_a_shot;
    if (file == "contact_sheet.png" || file == "preview.mp4") return frame || kind != Kind::shot ? Unoffered::not_a_shot : Unoffered::none;
    if (file == "report.json") return Unoffered::none;
    if (kind == Kind::comparison) return file == "convergence.svg" ? Unoffered::none : Unoffered::not_a_render;
    if (file.starts_with("denoised.") && !denoise) return Unoffered::not_denoised;
    if (file.starts_with("passes")) {
        // passes.exr, or passes/<name>.exr
        const bool all = file == "passes.exr";
        const std::string name = all ? std::string() : std::string(file.substr(7, file.size() - 7 - 4));
        if (passes.empty() || (!all && std::find(passes.begin(), passes.end(), name) == passes.end()))
            return Unoffered::no_such_pass;
    }
    if (kind == Kind::shot && !frame && is_render_file(file)) return Unoffered::per_frame;
    return Unoffered::none;
}

std::vector<std::string> ResultFiles::routed(bool frame) {
    std::vector<std::string> f;
    for (const RenderFile& r : kRenderFiles) f.emplace_back(r.file);
    for (const char* name : {"report.json", "denoised.png", "denoised.exr", "passes.exr"}) f.emplace_back(name);
    for (const AovInfo& i : kAovInfo) f.push_back("passes/" + std::string(i.name) + ".exr");
    if (!frame) {
        f.emplace_back("contact_sheet.png");
        f.emplace_back("preview.mp4");
    }
    return f;
}

bool ResultFiles::live(std::string_view file) {
    return file == "image.png" || file == "image.exr" || file == "rate.png" || file == "denoised.png" || file == "denoised.exr";
}

std::vector<std::pair<std::string, std::string>> ResultFiles::links() const {
    std::vector<std::pair<std::string, std::string>> out{{"report", "report.json"}};
    if (kind == Kind::comparison) {
        out.emplace_back("convergence_svg", "convergence.svg");
        return out;
    }
    const std::string at = kind == Kind::shot ? "frames/{n}/" : "";
    const std::string prefix = kind == Kind::shot ? "frame_" : "";
    for (const RenderFile& f : kRenderFiles) out.emplace_back(prefix + f.link, at + f.file);
    if (denoise && denoised) {
        out.emplace_back(prefix + "denoised_png", at + "denoised.png");
        out.emplace_back(prefix + "denoised_exr", at + "denoised.exr");
    }
    if (!passes.empty()) {
        out.emplace_back(prefix + "passes_exr", at + "passes.exr");
        for (const std::string& p : passes) out.emplace_back(prefix + "pass_" + p + "_exr", at + "passes/" + p + ".exr");
    }
    if (kind == Kind::shot) {
        out.emplace_back("frame_report", "frames/{n}/report.json");
        out.emplace_back("frame_exr", "frames/{n}/image.exr");  // the name it had first, kept for clients that read it
        out.emplace_back("contact_sheet", "contact_sheet.png");
        if (preview) out.emplace_back("preview", "preview.mp4");
    }
    return out;
}

}  // namespace tessera::api
