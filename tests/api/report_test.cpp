// What a finished job reports (report.cpp): report.json puts every field of a RenderReport in
// its documented place and reads back (the settings as the job, the curve's points as points),
// the status summary is exactly the report's status part, and a convergence point survives the
// text form a render farm keeps in Redis. job_status_test.cpp has the plain point round trip.
#include "build_paths.h"
#include "api/report.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include <set>
#include <string>

#include "api/json_text.h"

namespace tessera::api {
namespace {

using nlohmann::json;

ConvergencePoint point(double seconds, double spp, double est, double rel, double mse, double mae) {
    ConvergencePoint p;
    p.seconds = seconds;
    p.spp_mean = spp;
    p.est_rel_mse = est;
    p.rel_mse = rel;
    p.mse = mse;
    p.mae = mae;
    return p;
}

// Every field away from its default and from every other field's value, in binary fractions so
// that the expected numbers are exact.
RenderReport full_report() {
    RenderReport r;
    r.job = parse_render_job(json{{"scene", "builtin:cornell_box"}, {"width", 4}, {"height", 2}, {"spp", 8}, {"max_depth", 3},
                                  {"bvh", "median"}, {"seed", 11}, {"reference", "0123456789abcdef"}});
    r.timings.load_s = 0.5;
    r.timings.bvh_s = 0.25;
    r.timings.render_s = 1.5;
    r.timings.write_s = 0.125;
    r.timings.total_s = 2.375;
    r.stats.camera_rays = 1000;
    r.stats.shadow_rays = 600;
    r.stats.bounce_rays = 400;
    r.stats.traversal.nodes_visited = 5000;
    r.stats.traversal.prim_tests = 3000;
    r.stats.samples = 40;
    r.stats.nonfinite_samples = 3;
    r.stats.max_sample = 12.5f;
    r.stats.render_seconds = 0.5;
    r.stats.threads = 3;
    r.triangles = 12;
    r.spheres = 2;
    r.bvh.node_count = 7;
    r.bvh.leaf_count = 4;
    r.bvh.depth = 3;
    r.bvh.sah_cost = 4.75;
    r.accel_bytes = 4096;
    r.scene_build.built = {"triangle blocks", "wide BVH"};
    r.scene_build.left_out = {"light tree"};
    r.scene_build.warnings = {"a material read as diffuse"};
    r.scene_build.seconds = 0.375;
    r.scene_build.stages = {{"load", 0.25}, {"bvh", 0.125}};
    r.render_built = {"half buffers"};
    r.render_left_out = {"adaptive sampling"};
    r.curve.points = {point(0.25, 1, -1, 0.5, 0.125, 0.25), point(0.75, 3, 0.0625, 0.375, 0.0625, 0.125)};
    r.curve.stop = StopReason::time_limit;
    r.spp_min = 2.5;
    r.spp_max = 7.5;
    r.mean_radiance = 0.5;
    r.tiles_done = 6;
    r.tiles_total = 8;
    r.nodes = {{"node-a", 3, 1.5}, {"node-b", 1, 0.5}};
    r.scene_cache.used = true;
    r.scene_cache.hit = true;
    r.scene_cache.load_s = 0.75;
    r.scene_cache.build_s = 0.0625;
    return r;
}

TEST(Report, EveryFieldInItsPlace) {
    const RenderReport r = full_report();
    const json j = to_json(r);
    EXPECT_EQ(j["settings"], to_json(r.job));
    EXPECT_EQ(j["timings"], (json{{"load_s", 0.5}, {"bvh_s", 0.25}, {"render_s", 1.5}, {"write_s", 0.125}, {"total_s", 2.375}}));

    const json& st = j["stats"];
    EXPECT_EQ(st["rays_camera"].get<uint64_t>(), 1000u);
    EXPECT_EQ(st["rays_shadow"].get<uint64_t>(), 600u);
    EXPECT_EQ(st["rays_bounce"].get<uint64_t>(), 400u);
    EXPECT_DOUBLE_EQ(st["mrays_per_s"].get<double>(), 2000 / 0.5 * 1e-6);
    EXPECT_EQ(st["bvh_nodes"].get<size_t>(), 7u);
    EXPECT_EQ(st["bvh_depth"].get<int>(), 3);
    EXPECT_DOUBLE_EQ(st["bvh_sah_cost"].get<double>(), 4.75);
    EXPECT_EQ(st["bvh_bytes"].get<size_t>(), 4096u);
    EXPECT_DOUBLE_EQ(st["nodes_per_ray"].get<double>(), 2.5);
    EXPECT_DOUBLE_EQ(st["prim_tests_per_ray"].get<double>(), 1.5);
    EXPECT_DOUBLE_EQ(st["spp_mean"].get<double>(), 5.0) << "40 samples over 4 × 2 pixels";
    EXPECT_DOUBLE_EQ(st["spp_min"].get<double>(), 2.5);
    EXPECT_DOUBLE_EQ(st["spp_max"].get<double>(), 7.5);
    EXPECT_EQ(st["nonfinite_samples"].get<uint64_t>(), 3u);
    EXPECT_DOUBLE_EQ(st["max_sample_luminance"].get<double>(), 12.5);
    EXPECT_EQ(st["threads"].get<int>(), 3);

    const json& sc = j["scene"];
    EXPECT_EQ(sc["name"], "builtin:cornell_box");
    EXPECT_EQ(sc["triangles"].get<size_t>(), 12u);
    EXPECT_EQ(sc["spheres"].get<size_t>(), 2u);
    EXPECT_EQ(sc["built"], json({"triangle blocks", "wide BVH"}));
    EXPECT_EQ(sc["left_out"], json({"light tree"}));
    EXPECT_EQ(sc["warnings"], json({"a material read as diffuse"}));
    EXPECT_DOUBLE_EQ(sc["build_s"].get<double>(), 0.375);
    EXPECT_EQ(sc["build_stages"], json::parse(R"([{"stage":"load","seconds":0.25},{"stage":"bvh","seconds":0.125}])"))
        << "in order, as the stages ran";
    EXPECT_EQ(sc["cache"], (json{{"hit", true}, {"load_s", 0.75}, {"build_s", 0.0625}}));

    const json& conv = j["convergence"];
    EXPECT_EQ(conv["stop_reason"], "time_limit");
    ASSERT_EQ(conv["points"].size(), 2u);
    EXPECT_EQ(conv["points"][0], to_json(r.curve.points[0]));
    EXPECT_EQ(conv["points"][1], to_json(r.curve.points[1]));

    EXPECT_EQ(j["render"], (json{{"built", {"half buffers"}}, {"left_out", {"adaptive sampling"}}}));
    EXPECT_EQ(j["progress"], (json{{"fraction", 1.0}, {"tiles_done", 6}, {"tiles_total", 8}, {"samples_done", 40}}));

    ASSERT_EQ(j["nodes"].size(), 2u);
    EXPECT_EQ(j["nodes"][0], (json{{"node", "node-a"}, {"tiles", 3}, {"share", 0.75}, {"seconds", 1.5}}));
    EXPECT_EQ(j["nodes"][1], (json{{"node", "node-b"}, {"tiles", 1}, {"share", 0.25}, {"seconds", 0.5}}));

    const std::set<std::string> parts = {"settings", "timings", "stats", "scene", "convergence", "render", "progress", "nodes"};
    std::set<std::string> got;
    for (const auto& [k, v] : j.items()) got.insert(k);
    EXPECT_EQ(got, parts);
}

// report.json's settings are the stored job: they read back as the same job.
TEST(Report, SettingsReadBackAsTheJob) {
    const RenderReport r = full_report();
    const json settings = to_json(r)["settings"];
    const Job back = job_from_json(settings);
    ASSERT_TRUE(std::holds_alternative<RenderJob>(back));
    EXPECT_EQ(to_json(std::get<RenderJob>(back)), settings);
    EXPECT_EQ(std::get<RenderJob>(back).render.spp, 8);
    EXPECT_EQ(std::get<RenderJob>(back).reference, "0123456789abcdef");
}

// The report's curve reads back point by point, also through the text report.json is written as.
TEST(Report, ConvergencePointsReadBack) {
    const RenderReport r = full_report();
    const std::optional<json> text = parse_json(json_text(to_json(r), 2), 64);
    ASSERT_TRUE(text.has_value());
    const json& points = (*text)["convergence"]["points"];
    ASSERT_EQ(points.size(), r.curve.points.size());
    for (size_t i = 0; i < points.size(); ++i) {
        const ConvergencePoint want = r.curve.points[i], got = convergence_point_from_json(points[i]);
        EXPECT_EQ(got.seconds, want.seconds) << i;
        EXPECT_EQ(got.spp_mean, want.spp_mean) << i;
        EXPECT_EQ(got.est_rel_mse, want.est_rel_mse) << i;
        EXPECT_EQ(got.rel_mse, want.rel_mse) << i;
        EXPECT_EQ(got.mse, want.mse) << i;
        EXPECT_EQ(got.mae, want.mae) << i;
    }
}

TEST(Report, TheErrorMeasureNamesTheReference) {
    RenderReport r = full_report();
    const std::string with = to_json(r)["convergence"]["error_measure"].get<std::string>();
    EXPECT_NE(with.find("against job 0123456789abcdef"), std::string::npos) << with;
    r.job.reference.clear();
    const std::string without = to_json(r)["convergence"]["error_measure"].get<std::string>();
    EXPECT_EQ(without.rfind("estimated relative MSE", 0), 0u) << without;
    EXPECT_EQ(without.find("against job"), std::string::npos) << without;
}

// One process has no nodes and a runner without a scene cache has no cache: the parts are left
// out, not written empty or as zeros that read as a miss.
TEST(Report, PartsThatDoNotApplyAreLeftOut) {
    RenderReport r = full_report();
    r.nodes.clear();
    r.scene_cache = SceneCacheUse{};
    const json j = to_json(r);
    EXPECT_FALSE(j.contains("nodes"));
    EXPECT_FALSE(j["scene"].contains("cache"));
    EXPECT_FALSE(status_summary(r).contains("nodes"));
    r.scene_cache.used = true;  // a miss is reported as one
    EXPECT_EQ(to_json(r)["scene"]["cache"]["hit"], false);
}

// A farm whose nodes stored no tiles (a job canceled at once) has shares of 0, not NaN (which
// would be written as null, against the schema's number).
TEST(Report, NodeSharesOfNoTilesAreZero) {
    RenderReport r = full_report();
    r.nodes = {{"node-a", 0, 0.0}, {"node-b", 0, 0.0}};
    const json report = to_json(r);
    ASSERT_EQ(report["nodes"].size(), 2u);
    for (const json& n : report["nodes"]) {
        ASSERT_TRUE(n["share"].is_number()) << n;
        EXPECT_EQ(n["share"].get<double>(), 0.0);
    }
}

// A render that traced nothing (canceled before its first tile) still reports numbers: no
// division by zero rays or zero seconds reaches the JSON as null.
TEST(Report, ARenderOfNothingHasNoNulls) {
    RenderReport r;
    r.job = parse_render_job(json{{"scene", "a"}, {"width", 4}, {"height", 2}});
    const json j = to_json(r);
    for (const auto& [k, v] : j["stats"].items()) {
        EXPECT_TRUE(v.is_number()) << k << " = " << v;
        EXPECT_EQ(v.get<double>(), 0.0) << k;
    }
    for (const auto& [k, v] : j["timings"].items()) EXPECT_TRUE(v.is_number()) << k;
    EXPECT_EQ(j["convergence"]["points"], json::array());
    EXPECT_EQ(j["convergence"]["stop_reason"], "spp");
}

// Scene warnings quote the scene file, whose bytes need not be UTF-8: report.json is still
// written, and reads back.
TEST(Report, WritesWhateverBytesTheSceneQuoted) {
    RenderReport r = full_report();
    r.scene_build.warnings = {std::string("material \"\xC3(\" read as diffuse")};
    r.job.scene = std::string("scenes/caf\xE9.dae");  // Latin-1, not UTF-8
    std::string text;
    ASSERT_NO_THROW(text = json_text(to_json(r), 2));
    const std::optional<json> back = parse_json(text, 64);
    ASSERT_TRUE(back.has_value());
    EXPECT_EQ((*back)["scene"]["name"], "scenes/caf\xEF\xBF\xBD.dae");
}

// The status part is the report's own timings, stats, progress (and nodes), nothing more: a
// status poll never carries the scene or the curve.
TEST(StatusSummary, IsTheReportsStatusPart) {
    const RenderReport r = full_report();
    const json report = to_json(r), summary = status_summary(r);
    EXPECT_EQ(summary["timings"], report["timings"]);
    EXPECT_EQ(summary["stats"], report["stats"]);
    EXPECT_EQ(summary["progress"], report["progress"]);
    EXPECT_EQ(summary["nodes"], report["nodes"]);
    std::set<std::string> keys;
    for (const auto& [k, v] : summary.items()) keys.insert(k);
    EXPECT_EQ(keys, (std::set<std::string>{"timings", "stats", "progress", "nodes"}));
}

const YAML::Node& spec() {
    static const YAML::Node root = YAML::LoadFile(TESSERA_OPENAPI_FILE);
    return root;
}

bool has_type(const json& v, const std::string& type) {
    if (type == "integer") return v.is_number_integer();
    if (type == "number") return v.is_number();
    if (type == "string") return v.is_string();
    if (type == "boolean") return v.is_boolean();
    if (type == "array") return v.is_array();
    if (type == "object") return v.is_object();
    return true;
}

// Every property the schema documents is written, with its type; with `only_documented`,
// nothing else is.
void expect_documented(const json& object, const YAML::Node& schema, const std::string& where, bool only_documented) {
    ASSERT_TRUE(schema && schema["properties"]) << where << " has no properties in api/openapi.yaml";
    ASSERT_TRUE(object.is_object()) << where << " = " << object;
    std::set<std::string> documented;
    for (const auto& kv : schema["properties"]) {
        const std::string name = kv.first.as<std::string>();
        documented.insert(name);
        if (!object.contains(name)) {
            ADD_FAILURE() << where << "." << name << " is documented but not written";
            continue;
        }
        const std::string type = kv.second["type"] ? kv.second["type"].as<std::string>() : "";
        EXPECT_TRUE(has_type(object[name], type)) << where << "." << name << " = " << object[name] << ", documented as " << type;
    }
    if (only_documented) {
        for (const auto& [k, v] : object.items()) {
            EXPECT_TRUE(documented.count(k)) << where << "." << k << " is written but not documented";
        }
    }
}

// GET /v1/jobs/{id} shows the summary's parts as api/openapi.yaml describes them.
TEST(StatusSummary, MatchesTheOpenApiJobStatus) {
    const json summary = status_summary(full_report());
    const YAML::Node props = spec()["components"]["schemas"]["JobStatus"]["properties"];
    ASSERT_TRUE(props);
    expect_documented(summary["stats"], props["stats"], "stats", false);
    expect_documented(summary["progress"], props["progress"], "progress", true);
    for (const json& n : summary["nodes"])
        expect_documented(n, spec()["components"]["schemas"]["NodeShare"], "nodes[]", true);
    // The status adds queued_s to the summary's timings; each of these is one it documents.
    const YAML::Node timings = props["timings"]["properties"];
    for (const auto& [k, v] : summary["timings"].items()) {
        EXPECT_TRUE(timings[k]) << "timings." << k << " is written but not documented";
        EXPECT_TRUE(v.is_number()) << k;
    }
}

TEST(ConvergencePointJson, UnmeasuredErrorsAreNullOrAbsent) {
    const json first = to_json(point(0.5, 1, -1, -1, -1, -1));
    EXPECT_TRUE(first.contains("est_rel_mse"));
    EXPECT_TRUE(first["est_rel_mse"].is_null()) << "no estimate after one sample: null, as the schema's Pass";
    EXPECT_FALSE(first.contains("rel_mse")) << "no reference: no errors against it";
    EXPECT_FALSE(first.contains("mse"));
    EXPECT_FALSE(first.contains("mae"));
    const json measured = to_json(point(0.5, 1, -1, 0.25, 0.125, 0.0625));
    EXPECT_TRUE(measured["est_rel_mse"].is_null()) << "each error on its own";
    EXPECT_EQ(measured["rel_mse"], 0.25);
    EXPECT_EQ(measured["mse"], 0.125);
    EXPECT_EQ(measured["mae"], 0.0625);
}

// 0 is a measurement (an image equal to its reference), not "unmeasured".
TEST(ConvergencePointJson, ZeroErrorIsMeasured) {
    const ConvergencePoint q = convergence_point_from_json(to_json(point(1, 4, 0, 0, 0, 0)));
    EXPECT_EQ(q.est_rel_mse, 0.0);
    EXPECT_EQ(q.rel_mse, 0.0);
    EXPECT_EQ(q.mse, 0.0);
    EXPECT_EQ(q.mae, 0.0);
}

// A farm keeps points as text (json_text) and reads them back: every double exactly.
TEST(ConvergencePointJson, RoundTripsThroughTextExactly) {
    const ConvergencePoint p = point(1.0 / 3.0, 2.0 / 7.0 * 1000, 0.1, 1e-9 / 3.0, 0.3, 7.0 / 11.0);
    const std::optional<json> text = parse_json(json_text(to_json(p)), 4);
    ASSERT_TRUE(text.has_value());
    const ConvergencePoint q = convergence_point_from_json(*text);
    EXPECT_EQ(q.seconds, p.seconds);
    EXPECT_EQ(q.spp_mean, p.spp_mean);
    EXPECT_EQ(q.est_rel_mse, p.est_rel_mse);
    EXPECT_EQ(q.rel_mse, p.rel_mse);
    EXPECT_EQ(q.mse, p.mse);
    EXPECT_EQ(q.mae, p.mae);
}

TEST(ConvergencePointJson, ReadsWhatOtherWritersMayWrite) {
    // Whole numbers written as integers, and measured errors simply left out.
    const ConvergencePoint q = convergence_point_from_json(json{{"seconds", 2}, {"spp_mean", 16}});
    EXPECT_EQ(q.seconds, 2.0);
    EXPECT_EQ(q.spp_mean, 16.0);
    EXPECT_EQ(q.est_rel_mse, -1.0);
    EXPECT_EQ(q.rel_mse, -1.0);
    EXPECT_EQ(q.mse, -1.0);
    EXPECT_EQ(q.mae, -1.0);
    const ConvergencePoint n = convergence_point_from_json(
        json{{"seconds", 2}, {"spp_mean", 16}, {"est_rel_mse", nullptr}, {"rel_mse", nullptr}, {"mse", nullptr}, {"mae", nullptr}});
    EXPECT_EQ(n.est_rel_mse, -1.0);
    EXPECT_EQ(n.rel_mse, -1.0);
}

// Time and samples are always there: a point without them is refused, naming the one missing,
// rather than read as a point at 0 s.
TEST(ConvergencePointJson, TimeAndSamplesAreRequired) {
    for (const char* key : {"seconds", "spp_mean"}) {
        json j = to_json(point(1, 4, 0.5, -1, -1, -1));
        j.erase(key);
        try {
            convergence_point_from_json(j);
            ADD_FAILURE() << "a point without " << key << " was read";
        } catch (const json::exception& e) {
            EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
        }
    }
    for (const json& bad : {json("1.5"), json(nullptr), json::array({1.5}), json(true)}) {
        json j = to_json(point(1, 4, 0.5, -1, -1, -1));
        j["seconds"] = bad;
        EXPECT_THROW(convergence_point_from_json(j), json::exception) << "seconds = " << bad;
        j = to_json(point(1, 4, 0.5, -1, -1, -1));
        j["spp_mean"] = bad;
        EXPECT_THROW(convergence_point_from_json(j), json::exception) << "spp_mean = " << bad;
    }
    EXPECT_THROW(convergence_point_from_json(json::array({1, 4})), json::exception);
    EXPECT_THROW(convergence_point_from_json(json(nullptr)), json::exception);
}

}  // namespace
}  // namespace tessera::api
