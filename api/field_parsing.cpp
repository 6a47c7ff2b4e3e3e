// How a field table reads JSON: each value checked against its field's kind and bounds (the
// server's limits replacing a maximum where the table says so), errors naming the JSON pointer.
#include "api/json_text.h"
#include "api/job_fields.h"

#include <cmath>
#include <cstdio>
#include <limits>

namespace tessera::api {
namespace {

using nlohmann::json;

constexpr int64_t kInt64Max = std::numeric_limits<int64_t>::max();

std::string describe_type(const json& v) { return v.type_name(); }

std::string bounds_text(double lo, double hi) {
    auto num = [](double x) {
        if (std::isinf(x)) return std::string(x > 0 ? "inf" : "-inf");
        return std::to_string(x);
    };
    return "[" + num(lo) + ", " + num(hi) + "]";
}

}  // namespace

template <class Job>
json check_value(const Field<Job>& f, const json& v, const ParseContext& ctx) {
    const std::string& ptr = ctx.pointer;
    if (f.nullable && v.is_null()) return v;
    switch (f.kind) {
        case FieldKind::integer: {
            const int64_t hi = f.limit == Limit::none ? f.max_int : int64_t(field_max(f, ctx.limits));
            auto out_of_range = [&] {
                return InvalidJob(ptr, ptr + " must lie in [" + std::to_string(f.min_int) + ", " + std::to_string(hi) +
                                           "], got " + json_text(v));
            };
            int64_t n = 0;
            if (v.is_number_unsigned() && v.get<uint64_t>() > uint64_t(kInt64Max)) {
                throw out_of_range();  // above every bound a field can have
            } else if (v.is_number_integer()) {
                n = v.get<int64_t>();
            } else if (v.is_number_float() && std::trunc(v.get<double>()) == v.get<double>()) {
                // 2^63 and beyond do not fit: out of range rather than converted.
                if (std::abs(v.get<double>()) >= 9223372036854775808.0) throw out_of_range();
                n = int64_t(v.get<double>());
            } else {
                throw InvalidJob(ptr, ptr + " must be an integer, not " + describe_type(v));
            }
            if (n < f.min_int || n > hi) throw out_of_range();
            return n;
        }
        case FieldKind::number: {
            if (!v.is_number()) throw InvalidJob(ptr, ptr + " must be a number, not " + describe_type(v));
            const double d = v.get<double>(), hi = field_max(f, ctx.limits);
            const bool low = f.exclusive_min ? !(d > f.min_num) : !(d >= f.min_num);
            if (!std::isfinite(d) || low || d > hi) {
                if (f.exclusive_min)
                    throw InvalidJob(ptr, ptr + " must lie in (" + bounds_text(f.min_num, hi).substr(1) + ", got " + json_text(v));
                throw InvalidJob(ptr, ptr + " must lie in " + bounds_text(f.min_num, hi) + ", got " + json_text(v));
            }
            return d;
        }
        case FieldKind::text: {
            if (!v.is_string()) throw InvalidJob(ptr, ptr + " must be a string, not " + describe_type(v));
            const std::string& t = v.get_ref<const std::string&>();
            if (int64_t(t.size()) < f.min_int) throw InvalidJob(ptr, ptr + " must not be empty");
            if (int64_t(t.size()) > f.max_int)
                throw InvalidJob(ptr, ptr + " is " + std::to_string(t.size()) + " characters long; at most " +
                                          std::to_string(f.max_int) + " are allowed");
            // A name with a NUL or a line break would cut or forge whatever later prints it.
            for (size_t i = 0; i < t.size(); ++i) {
                const unsigned char c = static_cast<unsigned char>(t[i]);
                if (c < 0x20 || c == 0x7f) {
                    char code[8];
                    std::snprintf(code, sizeof code, "0x%02x", c);
                    throw InvalidJob(ptr, ptr + " must not contain control characters (" + code + " at offset " +
                                              std::to_string(i) + ")");
                }
            }
            return v;
        }
        case FieldKind::choice: {
            if (!v.is_string()) throw InvalidJob(ptr, ptr + " must be a string, not " + describe_type(v));
            std::string list;
            for (std::string_view c : f.choices) {
                if (v.get_ref<const std::string&>() == c) return v;
                list += (list.empty() ? "" : "|") + std::string(c);
            }
            throw InvalidJob(ptr, ptr + " must be one of " + list + ", got " + json_excerpt(v));
        }
        case FieldKind::job_id: {
            if (!v.is_string() || v.get_ref<const std::string&>().size() != 16 ||
                v.get_ref<const std::string&>().find_first_not_of("0123456789abcdef") != std::string::npos)
                throw InvalidJob(ptr, ptr + " must be the id of a finished job (16 hex digits) or null");
            return v;
        }
        case FieldKind::boolean: {
            if (!v.is_boolean()) throw InvalidJob(ptr, ptr + " must be true or false, not " + describe_type(v));
            return v;
        }
        case FieldKind::object: return v;
    }
    return v;
}

template <class Job>
void parse_fields(const json& body, std::span<const Field<Job>> table, Job& out, const std::string& prefix,
                  const JobLimits& limits, bool per_config_only) {
    if (!body.is_object())
        throw InvalidJob(prefix, (prefix.empty() ? std::string("the job") : prefix) + " must be a JSON object, not " +
                                     describe_type(body));
    for (const auto& [key, v] : body.items()) {
        // A JSON pointer (RFC 6901): '~' and '/' in a client's key are escaped, so the pointer names it.
        std::string escaped;
        for (char c : key) escaped += c == '~' ? std::string("~0") : c == '/' ? std::string("~1") : std::string(1, c);
        const std::string ptr = prefix + "/" + escaped;
        const Field<Job>* field = nullptr;
        for (const Field<Job>& f : table)
            if (f.name == key) field = &f;
        if (!field) {
            std::string known;
            for (const Field<Job>& f : table)
                if (!per_config_only || f.per_config) known += (known.empty() ? "" : ", ") + std::string(f.name);
            throw InvalidJob(ptr, "unknown field " + ptr + " (expected " + known + ")");
        }
        if (per_config_only && !field->per_config)
            throw InvalidJob(ptr, ptr + " is set by the comparison, not per configuration");
        const ParseContext ctx{ptr, limits};
        field->set(out, check_value(*field, v, ctx), ctx);
    }
    for (const Field<Job>& f : table)
        if (f.default_json.empty() && !body.contains(std::string(f.name)) && !per_config_only)
            throw InvalidJob(prefix + "/" + std::string(f.name), prefix + "/" + std::string(f.name) + " is required");
}

template <class Job>
void apply_defaults(std::span<const Field<Job>> table, Job& out) {
    const JobLimits none = JobLimits::none();
    for (const Field<Job>& f : table) {
        if (f.default_json.empty()) continue;
        const ParseContext ctx{"/" + std::string(f.name), none};
        f.set(out, check_value(f, json::parse(f.default_json), ctx), ctx);
    }
}

template json check_value(const Field<RenderJob>&, const json&, const ParseContext&);
template json check_value(const Field<ComparisonJob>&, const json&, const ParseContext&);
template json check_value(const Field<AdaptiveSettings>&, const json&, const ParseContext&);
template void parse_fields(const json&, std::span<const Field<RenderJob>>, RenderJob&, const std::string&, const JobLimits&, bool);
template void parse_fields(const json&, std::span<const Field<ComparisonJob>>, ComparisonJob&, const std::string&,
                           const JobLimits&, bool);
template void apply_defaults(std::span<const Field<RenderJob>>, RenderJob&);
template void apply_defaults(std::span<const Field<ComparisonJob>>, ComparisonJob&);
template void apply_defaults(std::span<const Field<AdaptiveSettings>>, AdaptiveSettings&);
template void parse_fields(const json&, std::span<const Field<AdaptiveSettings>>, AdaptiveSettings&, const std::string&,
                           const JobLimits&, bool);

}  // namespace tessera::api
