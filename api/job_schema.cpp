#include "api/job_schema.h"

#include <cmath>

#include "api/job_fields.h"

namespace tessera::api {
namespace {

using json = nlohmann::ordered_json;

template <class Job>
json property(const Field<Job>& f, const JobLimits& limits) {
    json p = {{"description", std::string(f.help)}};
    switch (f.kind) {
        case FieldKind::integer:
            p["type"] = "integer";
            p["minimum"] = f.min_int;
            // A limit's maximum, or the field's own (kept exact: 2^63 − 1 does not survive a double).
            p["maximum"] = f.limit == Limit::none ? f.max_int : int64_t(field_max(f, limits));
            break;
        case FieldKind::number:
            p["type"] = "number";
            p["minimum"] = f.min_num;
            if (f.exclusive_min) p["exclusiveMinimum"] = true;
            if (std::isfinite(field_max(f, limits))) p["maximum"] = field_max(f, limits);
            break;
        case FieldKind::text:
            p["type"] = "string";
            p["minLength"] = f.min_int;
            p["maxLength"] = f.max_int;
            break;
        case FieldKind::choice:
            p["type"] = "string";
            p["enum"] = json::array();
            for (std::string_view c : f.choices) p["enum"].push_back(std::string(c));
            break;
        case FieldKind::job_id:
            p["type"] = "string";
            p["pattern"] = "^[0-9a-f]{16}$";
            break;
        case FieldKind::object:
            p["type"] = "object";
            break;
        case FieldKind::boolean:
            p["type"] = "boolean";
            break;
    }
    if (f.nullable) p["nullable"] = true;
    if (!f.default_json.empty()) p["default"] = json::parse(f.default_json);
    return p;
}

template <class Job>
json object_schema(std::span<const Field<Job>> table, const JobLimits& limits) {
    json s = {{"type", "object"}, {"additionalProperties", false}, {"properties", json::object()}, {"required", json::array()}};
    for (const Field<Job>& f : table) {
        s["properties"][std::string(f.name)] = property(f, limits);
        if (f.default_json.empty()) s["required"].push_back(std::string(f.name));
    }
    return s;
}

}  // namespace

json job_schema(const JobLimits& limits) {
    json render = object_schema(render_job_fields(), limits);
    // The one nested object the form needs the fields of; a comparison's configurations are
    // render fields again.
    json adaptive = object_schema(adaptive_fields(), limits);
    adaptive.erase("required");
    for (auto& [k, v] : adaptive.items()) render["properties"]["adaptive"][k] = v;
    // A shot's fields as the form edits them: frames as a range (a list goes through the API),
    // the animation as a name or index typed in.
    json& frames = render["properties"]["frames"];
    frames["additionalProperties"] = false;
    frames["properties"] = {
        {"start", {{"type", "integer"}, {"minimum", -10'000'000}, {"maximum", 10'000'000}, {"default", 1}, {"description", "First frame."}}},
        {"end", {{"type", "integer"}, {"minimum", -10'000'000}, {"maximum", 10'000'000}, {"default", 24}, {"description", "Last frame."}}},
        {"step", {{"type", "integer"}, {"minimum", 1}, {"maximum", 10'000'000}, {"default", 1}, {"description", "Every step-th frame."}}}};
    json& shutter = render["properties"]["shutter"];
    shutter["additionalProperties"] = false;
    shutter["properties"] = {
        {"open", {{"type", "number"}, {"minimum", -1}, {"maximum", 1}, {"default", -0.25}, {"description", "Opens, in frames from the frame."}}},
        {"close", {{"type", "number"}, {"minimum", -1}, {"maximum", 1}, {"default", 0.25}, {"description", "Closes, in frames from the frame."}}}};
    json& animation = render["properties"]["animation"];
    animation["type"] = "string";
    animation["minLength"] = 1;
    animation["maxLength"] = 256;
    json comparison = object_schema(comparison_job_fields(), limits);
    return {{"render_job", render}, {"comparison_job", comparison}};
}

}  // namespace tessera::api
