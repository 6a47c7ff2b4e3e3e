#pragma once
// The one declaration of every job field: its JSON name, type, default, bounds, help text and
// command-line names. Parsing (field_parsing.cpp) and to_json (job.cpp), the CLI's flags and --help
// (cli/job_flags.cpp) and the test that holds api/openapi.yaml to the same values
// (tests/api/job_fields_test.cpp) are all derived from these tables.
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "api/job.h"

namespace tessera::api {

enum class FieldKind {
    integer,  // a JSON integer (or a number with no fraction, 4.0)
    number,   // a finite JSON number
    text,     // a string of min..max characters
    choice,   // one of `choices`
    job_id,   // 16 lowercase hex digits, or null
    object,   // a nested object or list, parsed by the field itself
    boolean,  // true or false
};

// The maxima that the server's limits set (JobLimits); `none` keeps the field's own.
enum class Limit { none, dimension, spp, depth, light_rays, time_limit };

struct ParseContext {
    std::string pointer;  // JSON pointer of the value being parsed
    const JobLimits& limits;
};

template <class Job>
struct Field {
    std::string_view name;  // JSON key; "/name" is its pointer
    FieldKind kind = FieldKind::integer;
    std::string_view help;
    std::string_view default_json;  // the default, as JSON text ("" for a required field)
    // integer: [min_int, max_int]; number: [min_num, max_num], min exclusive when
    // `exclusive_min`; text: length in [min_int, max_int].
    int64_t min_int = 0, max_int = 0;
    double min_num = 0, max_num = 0;
    bool exclusive_min = false;
    Limit limit = Limit::none;                // replaces the maximum when not none
    std::span<const std::string_view> choices;
    bool nullable = false;
    // Receives a value already checked against kind and bounds (integers as int64, numbers as
    // double); an `object` field gets the raw value and checks it itself.
    void (*set)(Job&, const nlohmann::json&, const ParseContext&) = nullptr;
    nlohmann::json (*get)(const Job&) = nullptr;
    std::string_view cli;        // CLI11 option names ("-s,--spp"); empty: not a flag of its own
    bool per_config = true;      // render fields: settable per comparison configuration
};

std::span<const Field<RenderJob>> render_job_fields();
std::span<const Field<AdaptiveSettings>> adaptive_fields();
std::span<const Field<ComparisonJob>> comparison_job_fields();

// The effective maximum of an integer or number field under `limits`.
template <class Job>
double field_max(const Field<Job>& f, const JobLimits& limits) {
    switch (f.limit) {
        case Limit::dimension: return limits.max_dimension;
        case Limit::spp: return limits.max_spp;
        case Limit::depth: return limits.max_depth;
        case Limit::light_rays: return limits.max_light_rays;
        case Limit::time_limit: return limits.max_time_limit_s;
        case Limit::none: break;
    }
    return f.kind == FieldKind::number ? f.max_num : double(f.max_int);
}

// The value of one field checked against its kind and bounds: an int64 for integers, a double
// for numbers, the string otherwise (null where nullable). Throws InvalidJob naming ctx.pointer.
template <class Job>
nlohmann::json check_value(const Field<Job>& f, const nlohmann::json& v, const ParseContext& ctx);

// Sets every field of `table` that has a default to it.
template <class Job>
void apply_defaults(std::span<const Field<Job>> table, Job& out);

// The fields of `body` over `out`; throws InvalidJob for an unknown field, a missing required
// one, or a bad value. With `per_config_only`, fields that a comparison sets for all its
// configurations are refused; `prefix` is the body's own JSON pointer.
template <class Job>
void parse_fields(const nlohmann::json& body, std::span<const Field<Job>> table, Job& out, const std::string& prefix,
                  const JobLimits& limits, bool per_config_only = false);

// Every field of `table` by name, in table order.
template <class Job>
nlohmann::json fields_to_json(std::span<const Field<Job>> table, const Job& job) {
    nlohmann::json j = nlohmann::json::object();
    for (const Field<Job>& f : table) j[std::string(f.name)] = f.get(job);
    return j;
}

}  // namespace tessera::api
