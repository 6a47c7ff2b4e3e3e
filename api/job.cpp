#include "api/job.h"

#include "api/job_fields.h"

#include <limits>

namespace tessera::api {

using nlohmann::json;

JobLimits JobLimits::none() {
    JobLimits l;
    l.max_pixels = std::numeric_limits<int64_t>::max();
    l.max_dimension = std::numeric_limits<int>::max();
    l.max_spp = std::numeric_limits<int>::max();
    l.max_depth = std::numeric_limits<int>::max();
    l.max_light_rays = std::numeric_limits<int>::max();
    l.max_time_limit_s = std::numeric_limits<double>::max();
    return l;
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

}  // namespace tessera::api
