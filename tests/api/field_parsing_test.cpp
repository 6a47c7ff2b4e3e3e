// How the field tables read JSON (field_parsing.cpp): each value checked against its field's
// kind and bounds, the server's limits replacing a maximum where the table says so, and every
// refusal naming its JSON pointer with a message a client can act on. job_test.cpp checks which
// pointer each bad job gets; this holds the kinds, the messages, the limits and the defaults.
#include "api/job_fields.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <limits>
#include <string>

namespace tessera::api {
namespace {

using nlohmann::json;

struct Refusal {
    std::string pointer, message;
};

template <class Parse>
Refusal refusal_of(Parse&& parse) {
    try {
        parse();
    } catch (const InvalidJob& e) {
        return {e.pointer(), e.what()};
    }
    return {"<accepted>", ""};
}

Refusal render_refusal(const json& body, const JobLimits& limits = {}) {
    return refusal_of([&] { parse_render_job(body, limits); });
}

Refusal comparison_refusal(const json& body, const JobLimits& limits = {}) {
    return refusal_of([&] { parse_comparison_job(body, limits); });
}

json with_scene(json fields) {
    fields["scene"] = "a";
    return fields;
}

template <class Job>
const Field<Job>& field_named(std::span<const Field<Job>> table, std::string_view name) {
    for (const Field<Job>& f : table)
        if (f.name == name) return f;
    ADD_FAILURE() << "no field " << name;
    return table.front();
}

// The kinds' messages, each with the pointer of the value; the HTTP layer passes both on as the
// problem's detail and field.
TEST(FieldParsing, IntegersSayTheirRangeAndWhatTheyGot) {
    Refusal r = render_refusal(with_scene({{"spp", 0}}));
    EXPECT_EQ(r.pointer, "/spp");
    EXPECT_EQ(r.message, "/spp must lie in [1, 65536], got 0");
    EXPECT_EQ(render_refusal(with_scene({{"priority", 1001}})).message, "/priority must lie in [-1000, 1000], got 1001");
    EXPECT_EQ(render_refusal(with_scene({{"priority", -1001}})).message, "/priority must lie in [-1000, 1000], got -1001");
    EXPECT_EQ(render_refusal(with_scene({{"spp", "4"}})).message, "/spp must be an integer, not string")
        << "the example api/openapi.yaml gives for a problem";
    EXPECT_EQ(render_refusal(with_scene({{"spp", 1.5}})).message, "/spp must be an integer, not number");
    EXPECT_EQ(render_refusal(with_scene({{"spp", true}})).message, "/spp must be an integer, not boolean");
    EXPECT_EQ(render_refusal(with_scene({{"spp", nullptr}})).message, "/spp must be an integer, not null")
        << "null only where a field is nullable";
    EXPECT_EQ(render_refusal(with_scene({{"spp", json::array({4})}})).message, "/spp must be an integer, not array");
}

// 4.0 and 1e2 are integers written as numbers: taken, as the table's kind says.
TEST(FieldParsing, WholeNumbersWrittenAsFloatsAreIntegers) {
    EXPECT_EQ(parse_render_job(json::parse(R"({"scene":"a","spp":4.0})")).render.spp, 4);
    EXPECT_EQ(parse_render_job(json::parse(R"({"scene":"a","spp":1e2})")).render.spp, 100);
    EXPECT_EQ(parse_render_job(json::parse(R"({"scene":"a","priority":-3.0})")).priority, -3);
    const JobLimits limits;
    const ParseContext ctx{"/spp", limits};
    const json checked = check_value(field_named(render_job_fields(), "spp"), json(8.0), ctx);
    EXPECT_TRUE(checked.is_number_integer()) << "setters receive integers as int64: " << checked;
    EXPECT_EQ(checked.get<int64_t>(), 8);
}

// Beyond int64 nothing is converted (a wrapped or saturated value would be taken silently).
TEST(FieldParsing, IntegersBeyondInt64AreOutOfRange) {
    Refusal r = render_refusal(json::parse(R"({"scene":"a","seed":18446744073709551615})"));
    EXPECT_EQ(r.pointer, "/seed");
    EXPECT_EQ(r.message, "/seed must lie in [0, 9223372036854775807], got 18446744073709551615");
    EXPECT_EQ(render_refusal(json::parse(R"({"scene":"a","spp":1e300})")).message, "/spp must lie in [1, 65536], got 1e+300");
    EXPECT_EQ(render_refusal(json::parse(R"({"scene":"a","priority":-1e300})")).pointer, "/priority");
    EXPECT_EQ(render_refusal(json::parse(R"({"scene":"a","seed":9223372036854775808.0})")).pointer, "/seed")
        << "2^63 as a double is one past int64";
}

TEST(FieldParsing, NumbersSayTheirRange) {
    Refusal r = render_refusal(with_scene({{"russian_roulette", 1.5}}));
    EXPECT_EQ(r.pointer, "/russian_roulette");
    EXPECT_EQ(r.message, "/russian_roulette must lie in [0.000000, 1.000000], got 1.5");
    EXPECT_EQ(render_refusal(with_scene({{"russian_roulette", -0.25}})).message,
              "/russian_roulette must lie in [0.000000, 1.000000], got -0.25");
    EXPECT_EQ(render_refusal(with_scene({{"russian_roulette", "0.5"}})).message, "/russian_roulette must be a number, not string");
    EXPECT_EQ(render_refusal(with_scene({{"lens_radius", nullptr}})).message, "/lens_radius must be a number, not null");
    // The ends are inside; an integer is a number.
    EXPECT_EQ(render_refusal(with_scene({{"russian_roulette", 1}})).pointer, "<accepted>");
    EXPECT_EQ(render_refusal(with_scene({{"russian_roulette", 0}})).pointer, "<accepted>");
    const JobLimits limits;
    const ParseContext ctx{"/russian_roulette", limits};
    const json checked = check_value(field_named(render_job_fields(), "russian_roulette"), json(1), ctx);
    EXPECT_TRUE(checked.is_number_float()) << "setters receive numbers as double: " << checked;
}

// An exclusive minimum shows as "(" and refuses the end itself; an unbounded maximum shows as inf.
TEST(FieldParsing, ExclusiveMinimaAndUnboundedMaxima) {
    Refusal r = comparison_refusal(with_scene({{"seconds", 0}}));
    EXPECT_EQ(r.pointer, "/seconds");
    EXPECT_EQ(r.message, "/seconds must lie in (0.000000, 600.000000], got 0");
    EXPECT_EQ(comparison_refusal(with_scene({{"target_error", 0}})).message, "/target_error must lie in (0.000000, inf], got 0");
    EXPECT_EQ(comparison_refusal(with_scene({{"seconds", 1e-9}})).pointer, "<accepted>");
    EXPECT_EQ(comparison_refusal(with_scene({{"seconds", 600}})).pointer, "<accepted>");
    EXPECT_EQ(comparison_refusal(with_scene({{"target_error", 1e300}})).pointer, "<accepted>");
}

// A tree built in code (the CLI's flags, a stored job) can hold what JSON text cannot: NaN and
// infinities are refused even by a field with no maximum.
TEST(FieldParsing, NonFiniteNumbersAreRefused) {
    const JobLimits limits;
    const ParseContext ctx{"/target_error", limits};
    const Field<ComparisonJob>& target = field_named(comparison_job_fields(), "target_error");
    ASSERT_TRUE(std::isinf(field_max(target, limits))) << "the premise: a field unbounded above";
    for (const double bad : {std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
                             std::numeric_limits<double>::quiet_NaN()}) {
        const Refusal r = refusal_of([&] { check_value(target, json(bad), ctx); });
        EXPECT_EQ(r.pointer, "/target_error") << bad;
    }
    EXPECT_EQ(render_refusal(with_scene({{"russian_roulette", std::numeric_limits<double>::quiet_NaN()}})).pointer,
              "/russian_roulette");
    EXPECT_EQ(render_refusal(with_scene({{"time_limit_s", std::numeric_limits<double>::infinity()}})).pointer, "/time_limit_s");
}

TEST(FieldParsing, ChoicesListThemselves) {
    Refusal r = render_refusal(with_scene({{"bvh", "kd"}}));
    EXPECT_EQ(r.pointer, "/bvh");
    EXPECT_EQ(r.message, "/bvh must be one of none|midpoint|median|sah|embree, got \"kd\"");
    EXPECT_EQ(render_refusal(with_scene({{"direct", "MIS"}})).message,
              "/direct must be one of hemisphere|importance|mis, got \"MIS\"")
        << "choices are case-sensitive";
    EXPECT_EQ(render_refusal(with_scene({{"sampler", 1}})).message, "/sampler must be a string, not number");
    EXPECT_EQ(render_refusal(with_scene({{"light_selection", "automatic"}})).pointer, "/light_selection")
        << "the JSON name is auto, not the enum's";
    EXPECT_EQ(parse_render_job(with_scene({{"light_selection", "auto"}})).render.light_selection, LightSelection::automatic);
}

// A message quotes the client's value: bytes that are not UTF-8 must not make the message
// itself unanswerable (the HTTP layer's JSON would throw on it).
TEST(FieldParsing, AQuotedValueIsValidUtf8) {
    const Refusal r = render_refusal(with_scene({{"bvh", std::string("kd\xFF")}}));
    EXPECT_EQ(r.pointer, "/bvh");
    EXPECT_NO_THROW((void)json(r.message).dump()) << "the message is not UTF-8";
    EXPECT_NE(r.message.find("kd\xEF\xBF\xBD"), std::string::npos) << r.message;
}

TEST(FieldParsing, TextIsAStringOfBoundedLength) {
    EXPECT_EQ(render_refusal(json{{"scene", 4}}).message, "/scene must be a string, not number");
    EXPECT_EQ(render_refusal(json{{"scene", nullptr}}).message, "/scene must be a string, not null") << "scene is not nullable";
    EXPECT_EQ(render_refusal(json{{"scene", "a\tb"}}).message, "/scene must not contain control characters (0x09 at offset 1)");
    EXPECT_EQ(render_refusal(json{{"scene", "ab\x7f"}}).message, "/scene must not contain control characters (0x7f at offset 2)");
    EXPECT_EQ(render_refusal(json{{"scene", "caf\xC3\xA9"}}).pointer, "<accepted>") << "UTF-8 is not a control character";
    // A nullable text: null is "none", an empty string is still refused.
    EXPECT_EQ(render_refusal(with_scene({{"environment", nullptr}})).pointer, "<accepted>");
    EXPECT_EQ(render_refusal(with_scene({{"environment", ""}})).message, "/environment must not be empty");
    EXPECT_EQ(render_refusal(with_scene({{"environment", "sky\n"}})).pointer, "/environment");
}

TEST(FieldParsing, JobIdsAreSixteenLowercaseHexDigitsOrNull) {
    const std::string refused = "/reference must be the id of a finished job (16 hex digits) or null";
    for (const json& bad : {json("0123456789ABCDEF"), json("0123456789abcde"), json("0123456789abcdef0"),
                           json("0123456789abcdeg"), json(123), json::array()}) {
        const Refusal r = render_refusal(with_scene({{"reference", bad}}));
        EXPECT_EQ(r.pointer, "/reference") << bad;
        EXPECT_EQ(r.message, refused) << bad;
    }
    EXPECT_EQ(parse_render_job(with_scene({{"reference", "0123456789abcdef"}})).reference, "0123456789abcdef");
    EXPECT_EQ(parse_render_job(with_scene({{"reference", nullptr}})).reference, "");
}

// The unknown field's message lists what would have been taken; inside a comparison's
// configuration, only what a configuration may set.
TEST(FieldParsing, AnUnknownFieldListsTheKnownOnes) {
    std::string all;
    for (const Field<RenderJob>& f : render_job_fields()) all += (all.empty() ? "" : ", ") + std::string(f.name);
    Refusal r = render_refusal(with_scene({{"spps", 4}}));
    EXPECT_EQ(r.pointer, "/spps");
    EXPECT_EQ(r.message, "unknown field /spps (expected " + all + ")");

    std::string per_config;
    for (const Field<RenderJob>& f : render_job_fields())
        if (f.per_config) per_config += (per_config.empty() ? "" : ", ") + std::string(f.name);
    ASSERT_NE(per_config, all) << "the premise: some fields are the comparison's";
    r = comparison_refusal(json::parse(R"({"scene":"a","configs":[{"label":"x"},{"label":"y","nope":1}]})"));
    EXPECT_EQ(r.pointer, "/configs/1/nope");
    EXPECT_EQ(r.message, "unknown field /configs/1/nope (expected " + per_config + ")");

    r = render_refusal(with_scene({{"adaptive", {{"batch", 8}, {"tol", 1}}}}));
    EXPECT_EQ(r.message, "unknown field /adaptive/tol (expected batch, tolerance)");
}

// RFC 6901: a key holding "/" or "~" is escaped in a pointer ("~1", "~0"), or the pointer names
// another place ("/a/b" is key "b" inside key "a").
TEST(FieldParsing, PointersEscapeTheKeysTheyName) {
    EXPECT_EQ(render_refusal(with_scene({{"a/b", 1}})).pointer, "/a~1b");
    EXPECT_EQ(render_refusal(with_scene({{"a~b", 1}})).pointer, "/a~0b");
}

TEST(FieldParsing, AComparisonSetsSomeFieldsForAllItsConfigurations) {
    for (const Field<RenderJob>& f : render_job_fields()) {
        if (f.per_config) continue;
        const std::string name(f.name);
        json config = {{"label", "x"}};
        config[name] = json::parse(f.default_json.empty() ? "\"a\"" : std::string(f.default_json));
        const Refusal r = comparison_refusal(json{{"scene", "a"}, {"configs", json::array({config})}});
        EXPECT_EQ(r.pointer, "/configs/0/" + name);
        EXPECT_EQ(r.message, "/configs/0/" + name + " is set by the comparison, not per configuration");
    }
}

TEST(FieldParsing, TheBodyMustBeAnObject) {
    for (const json& body : {json::array(), json("scene"), json(3), json(nullptr)}) {
        const Refusal r = render_refusal(body);
        EXPECT_EQ(r.pointer, "") << body;
        EXPECT_EQ(r.message, std::string("the job must be a JSON object, not ") + body.type_name());
    }
    // A nested table names its own pointer.
    RenderJob job = default_render_job();
    const Refusal r = refusal_of([&] { parse_fields(json::array(), render_job_fields(), job, "/configs/2", JobLimits{}); });
    EXPECT_EQ(r.pointer, "/configs/2");
    EXPECT_EQ(r.message, "/configs/2 must be a JSON object, not array");
}

TEST(FieldParsing, ARequiredFieldIsNamed) {
    const Refusal r = render_refusal(json::object());
    EXPECT_EQ(r.pointer, "/scene");
    EXPECT_EQ(r.message, "/scene is required");
    EXPECT_EQ(comparison_refusal(json{{"reps", 2}}).message, "/scene is required");
}

// The server's limits replace the table's maximum of the fields that name them, in the message
// too, and reach into nested objects (adaptive) and configurations.
TEST(FieldParsing, ServerLimitsReplaceMaxima) {
    JobLimits tight;
    tight.max_spp = 8;
    tight.max_dimension = 100;
    tight.max_depth = 4;
    tight.max_light_rays = 2;
    tight.max_time_limit_s = 60;
    EXPECT_EQ(render_refusal(with_scene({{"spp", 9}}), tight).message, "/spp must lie in [1, 8], got 9");
    EXPECT_EQ(render_refusal(with_scene({{"spp", 8}}), tight).pointer, "<accepted>");
    EXPECT_EQ(render_refusal(with_scene({{"width", 101}}), tight).message, "/width must lie in [1, 100], got 101");
    EXPECT_EQ(render_refusal(with_scene({{"height", 101}}), tight).pointer, "/height");
    EXPECT_EQ(render_refusal(with_scene({{"max_depth", 5}}), tight).message, "/max_depth must lie in [0, 4], got 5");
    EXPECT_EQ(render_refusal(with_scene({{"light_rays", 3}}), tight).message, "/light_rays must lie in [1, 2], got 3");
    EXPECT_EQ(render_refusal(with_scene({{"time_limit_s", 61}}), tight).message,
              "/time_limit_s must lie in [0.000000, 60.000000], got 61");
    EXPECT_EQ(render_refusal(with_scene({{"adaptive", {{"batch", 9}}}}), tight).message, "/adaptive/batch must lie in [1, 8], got 9");
    EXPECT_EQ(comparison_refusal(json::parse(R"({"scene":"a","configs":[{"label":"x","light_rays":3}]})"), tight).message,
              "/configs/0/light_rays must lie in [1, 2], got 3");
    EXPECT_EQ(comparison_refusal(with_scene({{"reference_spp", 9}}), tight).pointer, "/reference_spp");
    // A field without a limit keeps its own maximum whatever the limits.
    EXPECT_EQ(render_refusal(with_scene({{"tile_size", 4097}}), JobLimits::none()).message,
              "/tile_size must lie in [1, 4096], got 4097");
    // Limits may be wider than the table's own maximum: the server's word wins.
    JobLimits wide;
    wide.max_spp = 1 << 20;
    EXPECT_EQ(parse_render_job(with_scene({{"spp", 1 << 18}}), wide).render.spp, 1 << 18);
}

// Defaults come from each field's default text: every field with one is reset to it, whatever
// the job held before.
TEST(FieldParsing, ApplyDefaultsSetsEveryDefaultedField) {
    RenderJob job = parse_render_job(json::parse(R"({"scene":"x.dae","width":48,"height":36,"spp":64,"light_rays":4,
        "max_depth":5,"bvh":"median","direct":"hemisphere","russian_roulette":0.5,"bounces":"nth","lighting":"indirect",
        "light_selection":"power","adaptive":{"batch":16,"tolerance":0.25},"tile_size":16,"seed":7,"priority":3,
        "time_limit_s":12.5,"target_error":0.125,"reference":"0123456789abcdef","max_leaf_size":4,
        "triangle_test":"moller_trumbore","integrator":"normals","sampler":"independent","environment":"sky",
        "lens_radius":0.25,"focal_distance":3.5})"));
    apply_defaults(render_job_fields(), job);
    const json got = to_json(job);
    for (const Field<RenderJob>& f : render_job_fields()) {
        if (f.default_json.empty()) continue;
        const json want = json::parse(f.default_json);
        EXPECT_EQ(got.at(std::string(f.name)), want) << f.name;
    }
    EXPECT_EQ(job.scene, "x.dae") << "a required field has no default to reset it to";

    ComparisonJob c;
    apply_defaults(comparison_job_fields(), c);
    const json cj = to_json(c);
    for (const Field<ComparisonJob>& f : comparison_job_fields()) {
        if (f.default_json.empty()) continue;
        EXPECT_EQ(cj.at(std::string(f.name)), json::parse(f.default_json)) << f.name;
    }

    AdaptiveSettings a{1, 9.f};
    apply_defaults(adaptive_fields(), a);
    const json aj = fields_to_json(adaptive_fields(), a);
    for (const Field<AdaptiveSettings>& f : adaptive_fields())
        EXPECT_NEAR(aj.at(std::string(f.name)).get<double>(), json::parse(f.default_json).get<double>(), 1e-7) << f.name;
}

// Every default must pass its own field's check (apply_defaults checks them without limits; the
// default limits are what a server starts with).
TEST(FieldParsing, EveryDefaultPassesItsOwnCheckUnderDefaultLimits) {
    const JobLimits limits;
    for (const Field<RenderJob>& f : render_job_fields()) {
        if (f.default_json.empty()) continue;
        const ParseContext ctx{"/" + std::string(f.name), limits};
        EXPECT_NO_THROW(check_value(f, json::parse(f.default_json), ctx)) << f.name;
    }
    for (const Field<ComparisonJob>& f : comparison_job_fields()) {
        if (f.default_json.empty()) continue;
        const ParseContext ctx{"/" + std::string(f.name), limits};
        EXPECT_NO_THROW(check_value(f, json::parse(f.default_json), ctx)) << f.name;
    }
}

}  // namespace
}  // namespace tessera::api
