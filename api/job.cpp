#include "api/job.h"

#include "api/job_fields.h"
#include "api/json_text.h"
#include "engine/render/film.h"
#include "engine/render/passes.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace tessera::api {

using nlohmann::json;

InvalidJob::InvalidJob(std::string pointer, const std::string& what)
    : std::runtime_error(cut_text(what, 1000)), pointer_(cut_text(std::move(pointer), 200)) {}

JobLimits JobLimits::none() {
    JobLimits l;
    l.max_pixels = std::numeric_limits<int64_t>::max();
    l.max_dimension = std::numeric_limits<int>::max();
    l.max_spp = std::numeric_limits<int>::max();
    l.max_depth = std::numeric_limits<int>::max();
    l.max_light_rays = std::numeric_limits<int>::max();
    l.max_time_limit_s = std::numeric_limits<double>::max();
    l.max_frames = std::numeric_limits<int>::max();
    l.submission = false;
    return l;
}

std::vector<int> FrameSet::frames() const {
    if (!list.empty()) return list;
    std::vector<int> out;
    for (int64_t f = start; f <= end; f += step) out.push_back(int(f));
    return out;
}

bool FrameSet::contains(int frame) const {
    if (!list.empty()) return std::find(list.begin(), list.end(), frame) != list.end();
    return frame >= start && frame <= end && (int64_t(frame) - start) % step == 0;
}

size_t FrameSet::count() const { return list.empty() ? size_t((int64_t(end) - start) / step + 1) : list.size(); }

uint64_t frame_seed(uint64_t seed, int frame) {
    // splitmix64's finaliser over the seed and the frame: neighbouring frames get unrelated seeds.
    uint64_t z = seed + 0x9E3779B97F4A7C15ull * (uint64_t(uint32_t(frame)) + 1);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return (z ^ (z >> 31)) & 0x7FFFFFFFFFFFFFFFull;  // a job's seed field is a non-negative int64
}

RenderSettings RenderJob::frame_settings(int frame) const {
    RenderSettings s = render;
    s.seed = frame_seed(render.seed, frame);
    return s;
}

RenderJob default_render_job() {
    RenderJob job;
    apply_defaults(render_job_fields(), job);
    return job;
}

RenderJob parse_render_job(const json& body, const JobLimits& limits) {
    RenderJob job = default_render_job();
    parse_fields(body, render_job_fields(), job, "", limits);
    const int64_t pixels = int64_t(job.render.width) * job.render.height;
    if (pixels > limits.max_pixels)
        throw InvalidJob("/width", "width × height = " + std::to_string(pixels) + " pixels is over the limit of " +
                                       std::to_string(limits.max_pixels));
    if (job.frames && !job.reference.empty())
        throw InvalidJob("/reference", "a shot cannot be measured against a reference image (a still's); leave out reference or frames");
    if (job.shutter && !job.frames)
        throw InvalidJob("/shutter", "a shutter blurs a shot's motion: it needs frames (a still is the scene at rest)");
    if (job.shutter && job.scene_options.bvh.type == BvhType::embree)
        throw InvalidJob("/shutter", "motion blur is traced by our BVH only: leave out shutter or bvh \"embree\"");
    // Passes and denoising multiply a pixel's film: a job may not keep more than the largest
    // plain job (max_pixels with the error estimate's buffers) would.
    if (job.render.aovs || job.render.denoise) {
        // As the runners render it: they estimate the error to report its curve (job_runner.cpp,
        // render_node.cpp), which keeps the half-sample buffers of a job that does not denoise.
        RenderSettings as_run = job.render;
        as_run.estimate_error = true;
        const PassPlan plan = plan_passes(as_run, !job.reference.empty(), true);
        const double bytes = double(pixels) * double(Film::bytes_per_pixel(plan.half_buffer, plan.adaptive, plan.aovs));
        const double bound = double(limits.max_pixels) * double(Film::bytes_per_pixel(true, false, 0));
        if (bytes > bound)
            throw InvalidJob(job.render.aovs ? "/passes" : "/denoise",
                             "width × height = " + std::to_string(pixels) + " pixels with these passes" +
                                 (job.render.denoise ? " and denoising" : "") + " would keep " + std::to_string(int64_t(bytes / 1048576)) +
                                 " MiB of film, over the " + std::to_string(int64_t(bound / 1048576)) +
                                 " MiB the largest plain job may keep (--max-pixels): ask for fewer passes or pixels");
    }
    if (limits.submission && job.render.denoise && job.render.spp < 2)
        throw InvalidJob("/denoise", "denoising compares each pixel's two halves (its even and odd samples): it needs spp 2 or more");
    if (job.render.integrator == Integrator::normals && (job.render.aovs || job.render.denoise))
        throw InvalidJob(job.render.denoise ? "/denoise" : "/passes",
                         "passes and denoising follow light paths: integrator \"normals\" traces none (leave them out or use \"path\")");
    if (job.frames && limits.submission) {
        // Each frame's time, n / fps (and its shutter's), must be a time an animation can be
        // asked about: fps 1e-302 at frame 10^7 is past any double, and such a job was taken and
        // then failed on every node that tried it.
        const FrameSet& f = *job.frames;
        double far = f.list.empty() ? std::max(std::abs(double(f.start)), std::abs(double(f.end))) : 0.0;
        for (int n : f.list) far = std::max(far, std::abs(double(n)));
        if (job.shutter) far += std::max(std::abs(job.shutter->first), std::abs(job.shutter->second));
        const double t = far / job.fps;
        char reach[32];
        std::snprintf(reach, sizeof reach, "%.3g s", t);
        if (!(t <= kMaxShotSeconds))
            throw InvalidJob("/fps", "frame times reach " + (std::isfinite(t) ? std::string(reach) : std::string("infinity")) +
                                         " (frame / fps): a shot's frames must fall within " + std::to_string(int64_t(kMaxShotSeconds)) +
                                         " s of the animation's start; raise fps or render nearer frames");
    }
    if (job.frames && job.frames->count() > size_t(limits.max_frames))
        throw InvalidJob("/frames", "a shot of " + std::to_string(job.frames->count()) + " frames is over the limit of " +
                                        std::to_string(limits.max_frames));
    return job;
}

ComparisonJob parse_comparison_job(const json& body, const JobLimits& limits) {
    ComparisonJob job;
    apply_defaults(comparison_job_fields(), job);
    parse_fields(body, comparison_job_fields(), job, "", limits);
    return job;
}

json to_json(const RenderJob& job) { return fields_to_json(render_job_fields(), job); }

json to_json(const ComparisonJob& job) {
    json j = fields_to_json(comparison_job_fields(), job);
    j["kind"] = "comparison";
    return j;
}

json to_json(const Job& job) {
    return std::visit([](const auto& j) { return to_json(j); }, job);
}

Job job_from_json(const json& stored) {
    if (stored.is_object() && stored.value("kind", "") == "comparison") {
        json body = stored;
        body.erase("kind");
        return parse_comparison_job(body, JobLimits::none());
    }
    return parse_render_job(stored, JobLimits::none());
}

const std::string& scene_of(const Job& job) {
    return std::visit([](const auto& j) -> const std::string& { return j.scene; }, job);
}

int priority_of(const Job& job) {
    return std::visit([](const auto& j) { return j.priority; }, job);
}

const TaskPolicy& task_policy_of(const Job& job) {
    return std::visit([](const auto& j) -> const TaskPolicy& { return j.tasks; }, job);
}

bool valid_node_tag(const std::string& tag) {
    if (tag.empty() || tag.size() > 32) return false;
    for (size_t i = 0; i < tag.size(); ++i) {
        const char c = tag[i];
        const bool alnum = (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9');
        if (!alnum && (i == 0 || (c != '_' && c != '.' && c != '-'))) return false;
    }
    return true;
}

const std::optional<NotifySpec>& notify_of(const Job& job) {
    return std::visit([](const auto& j) -> const std::optional<NotifySpec>& { return j.notify; }, job);
}

const std::vector<std::string>& after_of(const Job& job) {
    return std::visit([](const auto& j) -> const std::vector<std::string>& { return j.after; }, job);
}

}  // namespace tessera::api
