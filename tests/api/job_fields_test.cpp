// The field tables are the one declaration of every job field; api/openapi.yaml must describe
// the same fields with the same types, defaults, bounds and choices. This test fails on any
// disagreement, in either direction.
#include "build_paths.h"
#include "api/job_fields.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <set>

namespace tessera::api {
namespace {

using nlohmann::json;

// A YAML scalar as JSON: numbers, booleans and null as such, anything else a string.
json scalar(const YAML::Node& n) {
    if (n.IsNull()) return nullptr;
    const std::string s = n.Scalar();
    if (n.Tag() == "!") return s;  // quoted
    try {
        size_t used = 0;
        const long long i = std::stoll(s, &used);
        if (used == s.size()) return i;
    } catch (...) {
    }
    try {
        size_t used = 0;
        const double d = std::stod(s, &used);
        if (used == s.size()) return d;
    } catch (...) {
    }
    if (s == "true") return true;
    if (s == "false") return false;
    if (s == "null" || s == "~") return nullptr;
    return s;
}

bool same_value(const json& a, const json& b) {
    if (a.is_number() && b.is_number()) return a.get<double>() == b.get<double>();
    return a == b;
}

const YAML::Node& spec() {
    static const YAML::Node root = YAML::LoadFile(TESSERA_OPENAPI_FILE);
    return root;
}

template <class Job>
void expect_schema_matches(const YAML::Node& schema, std::span<const Field<Job>> table, const std::string& where) {
    ASSERT_TRUE(schema && schema["properties"]) << where << " has no properties";
    const YAML::Node props = schema["properties"];
    const JobLimits limits;  // the server's defaults, which the file documents
    std::set<std::string> in_table;
    for (const Field<Job>& f : table) {
        const std::string name(f.name);
        in_table.insert(name);
        SCOPED_TRACE(where + "." + name);
        const YAML::Node p = props[name];
        ASSERT_TRUE(p) << "the table declares " << name << ", the OpenAPI schema does not";
        const std::string type = p["type"] ? p["type"].as<std::string>() : "";
        switch (f.kind) {
            case FieldKind::integer: EXPECT_EQ(type, "integer"); break;
            case FieldKind::number: EXPECT_EQ(type, "number"); break;
            case FieldKind::text:
            case FieldKind::choice:
            case FieldKind::job_id: EXPECT_EQ(type, "string"); break;
            case FieldKind::boolean: EXPECT_EQ(type, "boolean"); break;
            case FieldKind::object: break;  // an object or a oneOf
        }
        if (f.default_json.empty()) {
            EXPECT_FALSE(p["default"]) << "a required field has no default";
        } else {
            ASSERT_TRUE(p["default"]) << "no default in the OpenAPI schema";
            const json want = json::parse(f.default_json);
            // An empty list default (passes: []) is a sequence of nothing.
            const json got = p["default"].IsSequence() && p["default"].size() == 0 ? json::array()
                           : p["default"].IsScalar() || p["default"].IsNull() ? scalar(p["default"]) : json("<not a scalar>");
            EXPECT_TRUE(same_value(want, got)) << "default: table " << want << ", OpenAPI " << got;
        }
        if (f.kind == FieldKind::integer || f.kind == FieldKind::number) {
            const double lo = f.kind == FieldKind::integer ? double(f.min_int) : f.min_num;
            ASSERT_TRUE(p["minimum"]) << "no minimum";
            EXPECT_EQ(p["minimum"].as<double>(), lo);
            const double hi = field_max(f, limits);
            if (std::isinf(hi)) {
                EXPECT_FALSE(p["maximum"]) << "the table has no maximum";
            } else {
                ASSERT_TRUE(p["maximum"]) << "no maximum";
                // int64's maximum is not a double: compare it as text.
                if (f.kind == FieldKind::integer && f.max_int == std::numeric_limits<int64_t>::max())
                    EXPECT_EQ(p["maximum"].as<std::string>(), std::to_string(f.max_int));
                else
                    EXPECT_EQ(p["maximum"].as<double>(), hi);
            }
            EXPECT_EQ(p["exclusiveMinimum"] && p["exclusiveMinimum"].as<bool>(), f.exclusive_min);
            // A field whose maximum is a server limit shows that limit's default in the table
            // too (its help and the CLI read it there), never a number of its own.
            if (f.limit != Limit::none) {
                EXPECT_EQ(f.kind == FieldKind::integer ? double(f.max_int) : f.max_num, hi)
                    << "the table's maximum differs from the server limit's default";
            }
        }
        if (f.kind == FieldKind::text) {
            ASSERT_TRUE(p["minLength"] && p["maxLength"]);
            EXPECT_EQ(p["minLength"].as<int64_t>(), f.min_int);
            EXPECT_EQ(p["maxLength"].as<int64_t>(), f.max_int);
        }
        if (f.kind == FieldKind::choice) {
            ASSERT_TRUE(p["enum"] && p["enum"].IsSequence()) << "no enum";
            std::vector<std::string> got, want(f.choices.begin(), f.choices.end());
            for (const auto& e : p["enum"]) got.push_back(e.as<std::string>());
            EXPECT_EQ(got, want);
        }
        if (f.kind == FieldKind::job_id) {
            EXPECT_EQ(p["pattern"].as<std::string>(""), "^[0-9a-f]{16}$");
        }
        // OpenAPI 3.0 allows `nullable` only beside a `type`: a field of several forms (a oneOf)
        // says it on one of them.
        bool nullable = p["nullable"] && p["nullable"].as<bool>();
        if (p["oneOf"])
            for (const auto& alt : p["oneOf"]) nullable = nullable || (alt["nullable"] && alt["nullable"].as<bool>());
        EXPECT_EQ(nullable, f.nullable);
    }
    for (const auto& kv : props) {
        const std::string name = kv.first.as<std::string>();
        EXPECT_TRUE(in_table.count(name)) << where << "." << name << " is in the OpenAPI schema, not in the table";
    }
    std::set<std::string> required_table, required_spec;
    for (const Field<Job>& f : table)
        if (f.default_json.empty()) required_table.insert(std::string(f.name));
    if (schema["required"])
        for (const auto& r : schema["required"]) required_spec.insert(r.as<std::string>());
    EXPECT_EQ(required_table, required_spec) << where << ": required fields";
    ASSERT_TRUE(schema["additionalProperties"]);
    EXPECT_FALSE(schema["additionalProperties"].as<bool>()) << where << ": unknown fields are errors";
}

TEST(JobFields, RenderJobMatchesOpenApi) {
    const YAML::Node job = spec()["components"]["schemas"]["Job"];
    expect_schema_matches(job, render_job_fields(), "Job");
    expect_schema_matches(job["properties"]["adaptive"], adaptive_fields(), "Job.adaptive");
}

TEST(JobFields, ComparisonJobMatchesOpenApi) {
    expect_schema_matches(spec()["components"]["schemas"]["ComparisonJob"], comparison_job_fields(), "ComparisonJob");
}

// The effective job lists every field: JobSettings requires exactly the table's names.
TEST(JobFields, JobSettingsRequiresEveryField) {
    std::set<std::string> spec_names, table_names;
    const YAML::Node all = spec()["components"]["schemas"]["JobSettings"]["allOf"];
    ASSERT_TRUE(all && all.IsSequence());
    for (const auto& part : all)
        if (part["required"])
            for (const auto& r : part["required"]) spec_names.insert(r.as<std::string>());
    for (const auto& f : render_job_fields()) table_names.insert(std::string(f.name));
    EXPECT_EQ(spec_names, table_names);
}

// A stored comparison: ComparisonSettings requires every comparison field and its kind.
TEST(JobFields, ComparisonSettingsRequiresEveryField) {
    std::set<std::string> spec_names, table_names{"kind"};
    for (const auto& r : spec()["components"]["schemas"]["ComparisonSettings"]["required"]) spec_names.insert(r.as<std::string>());
    for (const auto& f : comparison_job_fields()) table_names.insert(std::string(f.name));
    EXPECT_EQ(spec_names, table_names);
}

// The defaults a job gets are the table's, and the engine's own defaults (what a program using
// the engine directly gets) agree with them.
TEST(JobFields, EngineDefaultsAgreeWithTheTable) {
    const RenderJob defaults = default_render_job();
    const RenderSettings engine;
    const RenderSceneOptions scene_engine;
    RenderJob from_engine;
    from_engine.scene = defaults.scene;
    from_engine.render = engine;
    from_engine.scene_options = scene_engine;
    EXPECT_EQ(to_json(from_engine), to_json(defaults));
    AdaptiveSettings a;
    apply_defaults(adaptive_fields(), a);
    EXPECT_EQ(a.batch, AdaptiveSettings{}.batch);
    EXPECT_EQ(a.tolerance, AdaptiveSettings{}.tolerance);
}

// Every field in each table once; CLI names once across the table.
TEST(JobFields, NamesAreUnique) {
    std::set<std::string> names, flags;
    for (const auto& f : render_job_fields()) {
        EXPECT_TRUE(names.insert(std::string(f.name)).second) << f.name;
        if (!f.cli.empty()) {
            EXPECT_TRUE(flags.insert(std::string(f.cli)).second) << f.cli;
        }
        EXPECT_FALSE(f.help.empty()) << f.name << " has no help text";
    }
}

}  // namespace
}  // namespace tessera::api
