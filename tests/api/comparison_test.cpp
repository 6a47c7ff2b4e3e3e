// Equal-time comparisons (comparison.cpp): the standard configurations are what their labels
// say, a run of tiny renders (16x12 pixels, hundredths of a second) fills one row per
// configuration consistently, and the table, JSON and plot show every row as it is.
// job_runner_test.cpp runs a comparison job end to end; this holds the parts to their own word.
#include "api/comparison.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <cmath>
#include <set>
#include <sstream>
#include <string>

#include "engine/scene/procedural.h"

namespace tessera::api {
namespace {

using nlohmann::json;

RenderSettings tiny_base() {
    RenderSettings base;
    base.width = 16;
    base.height = 12;
    base.max_depth = 2;
    base.threads = 1;
    return base;
}

std::vector<std::string> lines_of(const std::string& text) {
    std::vector<std::string> lines;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    return lines;
}

// Everything but what a configuration is about comes from the comparison's settings.
TEST(Comparison, StandardConfigsKeepTheBaseSettings) {
    RenderSettings base = tiny_base();
    base.sampler = SamplerKind::independent;
    base.seed = 5;
    base.russian_roulette = 0.5f;
    const std::vector<ComparisonConfig> configs = standard_configs(base);
    ASSERT_EQ(configs.size(), 9u);
    std::set<std::string> labels;
    for (const ComparisonConfig& c : configs) {
        EXPECT_TRUE(labels.insert(c.label).second) << "two configurations labelled " << c.label;
        EXPECT_EQ(c.settings.width, base.width) << c.label;
        EXPECT_EQ(c.settings.height, base.height) << c.label;
        EXPECT_EQ(c.settings.max_depth, base.max_depth) << c.label;
        EXPECT_EQ(c.settings.sampler, base.sampler) << c.label;
        EXPECT_EQ(c.settings.seed, base.seed) << c.label;
        EXPECT_EQ(c.settings.russian_roulette, base.russian_roulette) << c.label;
        EXPECT_EQ(c.scene.triangle_test, TriangleTest::watertight) << c.label;
    }
}

// The light rays, adaptive sampling and BVH a label names are the ones its settings hold.
TEST(Comparison, StandardConfigsSetWhatTheirLabelsName) {
    const std::vector<ComparisonConfig> configs = standard_configs(tiny_base());
    int bvh_configs = 0, adaptive_configs = 0;
    for (const ComparisonConfig& c : configs) {
        SCOPED_TRACE(c.label);
        const size_t rays_at = c.label.find(" light ray");
        if (rays_at != std::string::npos) {
            const size_t number_at = c.label.rfind(' ', rays_at - 1) + 1;
            EXPECT_EQ(std::to_string(c.settings.light_rays), c.label.substr(number_at, rays_at - number_at));
            EXPECT_EQ(c.label.substr(rays_at), c.settings.light_rays == 1 ? " light ray" : " light rays");
        }
        if (c.label.find("adaptive") != std::string::npos) {
            ++adaptive_configs;
            ASSERT_TRUE(c.settings.adaptive.has_value());
            EXPECT_EQ(c.settings.adaptive->batch, 16);
            EXPECT_FLOAT_EQ(c.settings.adaptive->tolerance, 0.05f);
            EXPECT_NE(c.label.find("batch 16, tol 0.05"), std::string::npos);
        } else {
            EXPECT_FALSE(c.settings.adaptive.has_value());
        }
        const size_t bvh_at = c.label.find("BVH ");
        if (bvh_at != std::string::npos) {
            ++bvh_configs;
            EXPECT_EQ(c.label.substr(bvh_at + 4), to_string(c.scene.bvh.type));
            EXPECT_NE(c.scene.bvh.type, BvhType::sah) << "a BVH configuration compares another BVH with the default";
        } else {
            EXPECT_EQ(c.scene.bvh.type, BvhType::sah);
        }
    }
    EXPECT_EQ(bvh_configs, 2);
    EXPECT_EQ(adaptive_configs, 1);
}

// "importance, 16 light rays" must render with light (importance) sampling: the label's
// strategy is the strategy rendered, whatever the base's default (MIS for a job).
TEST(Comparison, StandardConfigsRenderTheStrategyTheirLabelsName) {
    RenderSettings base = tiny_base();
    ASSERT_EQ(base.direct, DirectLighting::mis) << "the premise: a job's default direct lighting";
    for (const ComparisonConfig& c : standard_configs(base)) {
        const std::string strategy = c.label.substr(0, c.label.find(','));
        const DirectLighting want = strategy == "hemisphere"   ? DirectLighting::hemisphere
                                    : strategy == "importance" ? DirectLighting::importance
                                                               : DirectLighting::mis;
        ASSERT_TRUE(strategy == "hemisphere" || strategy == "importance" || strategy == "MIS") << c.label;
        EXPECT_EQ(c.settings.direct, want) << c.label;
    }
}

// One row per configuration, in order, each consistent with itself; a target every run reaches
// at its first pass gives a time for every run.
TEST(Comparison, RunFillsARowPerConfiguration) {
    const SceneDescription scene = cornell_box();
    const RenderSettings base = tiny_base();
    ComparisonConfig mis{"MIS", base, {}};
    mis.settings.direct = DirectLighting::mis;
    ComparisonConfig midpoint{"importance, BVH midpoint", base, {}};
    midpoint.settings.direct = DirectLighting::importance;
    midpoint.scene.bvh.type = BvhType::midpoint;
    const double seconds = 0.02;
    const int reps = 2;
    const ComparisonResult r = run_comparison(scene, {mis, midpoint}, base, 4, seconds, reps, 1e9);
    EXPECT_GT(r.reference_seconds, 0.0);
    ASSERT_EQ(r.rows.size(), 2u);
    EXPECT_EQ(r.rows[0].label, "MIS");
    EXPECT_EQ(r.rows[1].label, "importance, BVH midpoint");
    for (const ComparisonRow& row : r.rows) {
        SCOPED_TRACE(row.label);
        EXPECT_TRUE(std::isfinite(row.rel_mse_mean));
        EXPECT_GT(row.rel_mse_mean, 0.0) << "a few samples are not the reference";
        EXPECT_TRUE(std::isfinite(row.rel_mse_sd));
        EXPECT_GE(row.rel_mse_sd, 0.0);
        EXPECT_GT(row.spp, 0.0);
        EXPECT_EQ(row.reached, reps);
        EXPECT_GT(row.time_to_target, 0.0);
        EXPECT_DOUBLE_EQ(row.efficiency, 1.0 / (row.rel_mse_mean * seconds));
        ASSERT_FALSE(row.first_curve.points.empty());
        EXPECT_EQ(row.first_curve.stop, StopReason::time_limit) << "the time budget ends each run";
        for (const ConvergencePoint& p : row.first_curve.points)
            EXPECT_GE(p.rel_mse, 0.0) << "every pass is measured against the reference";
    }
}

// A target no run reaches: no time, -1, and the table and JSON say so.
TEST(Comparison, AnUnreachedTargetHasNoTime) {
    ComparisonConfig c{"importance", tiny_base(), {}};
    c.settings.direct = DirectLighting::importance;
    const ComparisonResult r = run_comparison(cornell_box(), {c}, tiny_base(), 1, 0.01, 1, 1e-30);
    ASSERT_EQ(r.rows.size(), 1u);
    EXPECT_EQ(r.rows[0].reached, 0);
    EXPECT_EQ(r.rows[0].time_to_target, -1.0);
    EXPECT_TRUE(comparison_json(r, 0.01, 1e-30)["rows"][0]["time_to_target_s"].is_null());
    EXPECT_NE(comparison_markdown(r, 0.01, 1e-30).find("not reached (0 runs did)"), std::string::npos);
}

TEST(Comparison, ACancelBeforeTheStartRunsNoConfiguration) {
    const std::atomic<bool> cancel{true};
    ComparisonConfig c{"MIS", tiny_base(), {}};
    const ComparisonResult r = run_comparison(cornell_box(), {c, c}, tiny_base(), 4, 0.02, 2, 0.01, &cancel);
    EXPECT_TRUE(r.rows.empty());
}

ComparisonResult two_rows() {
    ComparisonResult r;
    r.reference_seconds = 1.5;
    ComparisonRow a;
    a.label = "MIS, 4 light rays";
    a.rel_mse_mean = 0.0123;
    a.rel_mse_sd = 0.0012;
    a.spp = 17.25;
    a.time_to_target = 1.25;
    a.reached = 3;
    a.efficiency = 81.3;
    ComparisonRow b;
    b.label = "hemisphere";
    b.rel_mse_mean = 0.5;
    b.rel_mse_sd = 0;
    b.spp = 3;
    b.time_to_target = -1;
    b.reached = 1;
    b.efficiency = 1;
    r.rows = {a, b};
    return r;
}

TEST(Comparison, MarkdownTableHasARowPerConfiguration) {
    EXPECT_EQ(comparison_markdown(two_rows(), 2.0, 0.01),
              "| configuration | relMSE at 2.0 s (mean ± sd) | spp reached | time to relMSE 0.01 (s) | efficiency 1/(relMSE·s) |\n"
              "|---|---:|---:|---:|---:|\n"
              "| MIS, 4 light rays | 0.0123 ± 0.0012 | 17 | 1.250 | 81.3 |\n"
              "| hemisphere | 0.5 ± 0 | 3 | not reached (1 runs did) | 1 |\n");
}

// Labels are a client's (POST /v1/comparisons): a long one must not cut its row short and run
// the next row into it.
TEST(Comparison, MarkdownKeepsALongLabelWhole) {
    ComparisonResult r = two_rows();
    r.rows[0].label = std::string(600, 'x');
    const std::string table = comparison_markdown(r, 2.0, 0.01);
    const std::vector<std::string> lines = lines_of(table);
    ASSERT_EQ(lines.size(), 2u + r.rows.size()) << table;
    EXPECT_EQ(lines[2], "| " + r.rows[0].label + " | 0.0123 ± 0.0012 | 17 | 1.250 | 81.3 |");
    EXPECT_EQ(lines[3], "| hemisphere | 0.5 ± 0 | 3 | not reached (1 runs did) | 1 |");
}

TEST(Comparison, JsonHasEveryRow) {
    const json j = comparison_json(two_rows(), 2.0, 0.01);
    EXPECT_EQ(j["seconds_per_run"], 2.0);
    EXPECT_EQ(j["target_rel_mse"], 0.01);
    EXPECT_EQ(j["reference_seconds"], 1.5);
    ASSERT_EQ(j["rows"].size(), 2u);
    EXPECT_EQ(j["rows"][0], (json{{"label", "MIS, 4 light rays"}, {"rel_mse_mean", 0.0123}, {"rel_mse_sd", 0.0012},
                                  {"spp_reached", 17.25}, {"time_to_target_s", 1.25}, {"runs_reaching_target", 3},
                                  {"efficiency", 81.3}}));
    EXPECT_TRUE(j["rows"][1]["time_to_target_s"].is_null()) << "not reached: null, not -1";
    EXPECT_EQ(j["rows"][1]["runs_reaching_target"], 1);
    EXPECT_EQ(comparison_json(ComparisonResult{}, 2.0, 0.01)["rows"], json::array());
}

// The plot: a curve per row, labels and title as text (escaped), never as markup.
TEST(Comparison, SvgEscapesLabelsAndTitle) {
    ComparisonResult r = two_rows();
    for (ComparisonRow& row : r.rows) {
        ConvergencePoint p, q;
        p.seconds = 0.1;
        p.rel_mse = 0.5;
        q.seconds = 0.2;
        q.rel_mse = 0.25;
        row.first_curve.points = {p, q};
    }
    r.rows[1].label = "a<b & \"c\"";
    const std::string svg = comparison_svg(r, "scene <x>: relative MSE");
    EXPECT_EQ(svg.rfind("<svg", 0), 0u);
    EXPECT_NE(svg.find(">MIS, 4 light rays<"), std::string::npos);
    EXPECT_NE(svg.find("a&lt;b &amp; &quot;c&quot;"), std::string::npos);
    EXPECT_EQ(svg.find("a<b"), std::string::npos);
    EXPECT_NE(svg.find("scene &lt;x&gt;: relative MSE"), std::string::npos);
    size_t polylines = 0;
    for (size_t at = svg.find("<polyline"); at != std::string::npos; at = svg.find("<polyline", at + 1)) ++polylines;
    EXPECT_EQ(polylines, r.rows.size());
}

}  // namespace
}  // namespace tessera::api
