// The job schema a form is built from says what the parser takes: the same fields, defaults,
// bounds and choices, with the server's limits as maxima.
#include "api/job_schema.h"

#include <gtest/gtest.h>

#include "api/job_fields.h"

namespace tessera::api {
namespace {

using json = nlohmann::ordered_json;

bool accepted(const json& body, const JobLimits& limits) {
    try {
        parse_render_job(nlohmann::json::parse(body.dump()), limits);
        return true;
    } catch (const InvalidJob&) {
        return false;
    }
}

TEST(JobSchema, SaysWhatTheParserTakes) {
    JobLimits limits;
    limits.max_spp = 123;
    limits.max_dimension = 900;
    const json schema = job_schema(limits)["render_job"];
    EXPECT_EQ(schema["required"], json::array({"scene"}));
    EXPECT_EQ(schema["additionalProperties"], false);
    const json& props = schema["properties"];
    ASSERT_EQ(props.size(), render_job_fields().size());
    size_t i = 0;
    for (const auto& [name, p] : props.items()) EXPECT_EQ(name, render_job_fields()[i++].name) << "in the table's order";
    EXPECT_EQ(props["spp"]["maximum"], 123) << "the server's limit, not the field's own";
    EXPECT_EQ(props["width"]["maximum"], 900);

    // Every default together is a valid job.
    json defaults = {{"scene", "cornell_box"}};
    for (const auto& [name, p] : props.items())
        if (p.contains("default")) defaults[name] = p["default"];
    EXPECT_TRUE(accepted(defaults, limits)) << defaults.dump();

    for (const auto& [name, p] : props.items()) {
        if (name == "scene") continue;
        json job = {{"scene", "cornell_box"}};
        if (p["type"] == "integer") {
            // Bounds are inclusive: the ends are taken, one past them is refused.
            for (const char* end : {"minimum", "maximum"}) {
                job[name] = p[end];
                EXPECT_TRUE(accepted(job, limits)) << name << " = " << p[end];
            }
            if (p["maximum"].get<int64_t>() < INT64_MAX) {
                job[name] = p["maximum"].get<int64_t>() + 1;
                EXPECT_FALSE(accepted(job, limits)) << name;
            }
            job[name] = p["minimum"].get<int64_t>() - 1;
            EXPECT_FALSE(accepted(job, limits)) << name;
        } else if (p["type"] == "number") {
            if (p.contains("maximum")) {  // none: unbounded above
                job[name] = p["maximum"];
                EXPECT_TRUE(accepted(job, limits)) << name;
                job[name] = p["maximum"].get<double>() * 1.01 + 1;
                EXPECT_FALSE(accepted(job, limits)) << name;
            }
            job[name] = p["minimum"];
            EXPECT_EQ(accepted(job, limits), !p.value("exclusiveMinimum", false)) << name;
        } else if (p.contains("enum")) {
            for (const json& choice : p["enum"]) {
                job[name] = choice;
                EXPECT_TRUE(accepted(job, limits)) << name << " = " << choice;
            }
            job[name] = "no-such-choice";
            EXPECT_FALSE(accepted(job, limits)) << name;
        }
        if (p.value("nullable", false)) {
            job[name] = nullptr;
            EXPECT_TRUE(accepted(job, limits)) << name << " = null";
        }
    }
}

TEST(JobSchema, DescribesTheAdaptiveObject) {
    const json adaptive = job_schema(JobLimits{})["render_job"]["properties"]["adaptive"];
    EXPECT_EQ(adaptive["type"], "object");
    EXPECT_EQ(adaptive["nullable"], true);
    EXPECT_TRUE(adaptive["default"].is_null());
    ASSERT_EQ(adaptive["properties"].size(), adaptive_fields().size());
    json job = {{"scene", "cornell_box"}, {"adaptive", json::object()}};
    for (const auto& [name, p] : adaptive["properties"].items()) job["adaptive"][name] = p["default"];
    EXPECT_TRUE(accepted(job, JobLimits{})) << job.dump();
    job["adaptive"]["batch"] = adaptive["properties"]["batch"]["maximum"].get<int64_t>() + 1;
    EXPECT_FALSE(accepted(job, JobLimits{}));
}

TEST(JobSchema, DescribesComparisons) {
    const json c = job_schema(JobLimits{})["comparison_job"];
    EXPECT_EQ(c["properties"].size(), comparison_job_fields().size());
    EXPECT_EQ(c["required"], json::array({"scene"}));
}

}  // namespace
}  // namespace tessera::api
