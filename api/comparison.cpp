#include "api/comparison.h"

#include <cmath>
#include <cstdio>

namespace tessera::api {
namespace {

// Time at which the curve first reaches `target` (log-log interpolation), or -1.
double time_to(const ConvergenceCurve& c, double target) {
    for (size_t i = 0; i < c.points.size(); ++i) {
        const auto& p = c.points[i];
        if (p.rel_mse >= 0 && p.rel_mse <= target) {
            if (i == 0) return p.seconds;
            const auto& q = c.points[i - 1];
            const double t = (std::log(target) - std::log(q.rel_mse)) / (std::log(p.rel_mse) - std::log(q.rel_mse));
            return std::exp(std::log(q.seconds) + t * (std::log(p.seconds) - std::log(q.seconds)));
        }
    }
    return -1;
}

}  // namespace

std::vector<ComparisonConfig> standard_configs(const RenderSettings& base) {
    std::vector<ComparisonConfig> configs;
    for (DirectLighting d : {DirectLighting::hemisphere, DirectLighting::importance, DirectLighting::mis}) {
        ComparisonConfig c{d == DirectLighting::hemisphere ? "hemisphere, 4 light rays"
                           : d == DirectLighting::importance ? "importance, 4 light rays" : "MIS, 4 light rays", base, {}};
        c.settings.direct = d;
        c.settings.light_rays = 4;
        configs.push_back(c);
    }
    for (int l : {1, 16, 64}) {
        ComparisonConfig c{"importance, " + std::to_string(l) + " light ray" + (l > 1 ? "s" : ""), base, {}};
        c.settings.direct = DirectLighting::importance;
        c.settings.light_rays = l;
        configs.push_back(c);
    }
    {
        ComparisonConfig c{"importance, adaptive (batch 16, tol 0.05)", base, {}};
        c.settings.direct = DirectLighting::importance;
        c.settings.light_rays = 4;
        c.settings.adaptive = AdaptiveSettings{16, 0.05f};
        configs.push_back(c);
    }
    for (BvhType t : {BvhType::midpoint, BvhType::median}) {
        ComparisonConfig c{std::string("importance, BVH ") + to_string(t), base, {}};
        c.settings.direct = DirectLighting::importance;
        c.settings.light_rays = 4;
        c.scene.bvh.type = t;
        configs.push_back(c);
    }
    return configs;
}

ComparisonResult run_comparison(const SceneDescription& desc, const std::vector<ComparisonConfig>& configs,
                                const RenderSettings& base, int reference_spp, double seconds, int reps, double target,
                                const std::atomic<bool>* cancel) {
    ComparisonResult out;
    const RenderScene scene = build_render_scene(desc, RenderSceneOptions{});
    RenderSettings rs = base;
    rs.spp = reference_spp;
    rs.direct = DirectLighting::mis;
    rs.light_rays = 4;
    rs.seed = 987654321;
    rs.time_limit_s = 0;
    rs.target_error = 0;
    rs.adaptive.reset();
    RenderCallbacks rcb;
    rcb.cancel = cancel;
    const RenderResult ref = render(scene, rs, rcb);
    out.reference_seconds = ref.stats.render_seconds;
    for (const ComparisonConfig& c : configs) {
        if (cancel && cancel->load()) break;
        const bool own = c.scene.bvh.type != BvhType::sah || c.scene.triangle_test != TriangleTest::watertight;
        const RenderScene other = own ? build_render_scene(desc, c.scene) : RenderScene{};
        const RenderScene& sc = own ? other : scene;
        ComparisonRow row;
        row.label = c.label;
        std::vector<double> errs;
        double t_sum = 0;
        for (int r = 0; r < reps; ++r) {
            RenderSettings st = c.settings;
            st.width = base.width;
            st.height = base.height;
            st.max_depth = base.max_depth;  // the reference's depth: a config measured against a deeper reference is biased
            st.spp = 1 << 20;  // the time budget ends each run
            st.seed = uint64_t(1000 + r);
            st.time_limit_s = seconds;
            RenderCallbacks cb;
            cb.reference = &ref.image;
            cb.cancel = cancel;
            const RenderResult res = render(sc, st, cb);
            errs.push_back(res.curve.points.back().rel_mse);
            row.spp += res.curve.points.back().spp_mean / reps;
            const double t = time_to(res.curve, target);
            if (t > 0) { t_sum += t; ++row.reached; }
            if (r == 0) row.first_curve = res.curve;
        }
        for (double e : errs) row.rel_mse_mean += e / double(errs.size());
        for (double e : errs) row.rel_mse_sd += (e - row.rel_mse_mean) * (e - row.rel_mse_mean) / std::max<double>(1, double(errs.size()) - 1);
        row.rel_mse_sd = std::sqrt(row.rel_mse_sd);
        row.time_to_target = row.reached == reps ? t_sum / reps : -1;
        row.efficiency = row.rel_mse_mean > 0 ? 1.0 / (row.rel_mse_mean * seconds) : 0;
        out.rows.push_back(row);
    }
    return out;
}

std::string comparison_markdown(const ComparisonResult& r, double seconds, double target) {
    std::string s;
    char line[512];
    std::snprintf(line, sizeof line, "| configuration | relMSE at %.1f s (mean ± sd) | spp reached | time to relMSE %.3g (s) | efficiency 1/(relMSE·s) |\n"
                                     "|---|---:|---:|---:|---:|\n", seconds, target);
    s += line;
    for (const auto& row : r.rows) {
        char tt[64];
        if (row.time_to_target > 0) std::snprintf(tt, sizeof tt, "%.3f", row.time_to_target);
        else std::snprintf(tt, sizeof tt, "not reached (%d runs did)", row.reached);
        // The label (a client's text, any length) whole and apart from the numbers: a '|' or a line
        // break in it would start a cell or a row of its own.
        std::string label;
        for (char c : row.label) label += c == '|' ? std::string("\\|") : c == '\n' || c == '\r' ? std::string(" ") : std::string(1, c);
        std::snprintf(line, sizeof line, " | %.4g ± %.2g | %.0f | %s | %.3g |\n", row.rel_mse_mean, row.rel_mse_sd, row.spp, tt,
                      row.efficiency);
        s += "| " + label + line;
    }
    return s;
}

nlohmann::json comparison_json(const ComparisonResult& r, double seconds, double target) {
    nlohmann::json rows = nlohmann::json::array();
    for (const auto& row : r.rows)
        rows.push_back({{"label", row.label}, {"rel_mse_mean", row.rel_mse_mean}, {"rel_mse_sd", row.rel_mse_sd},
                        {"spp_reached", row.spp},
                        {"time_to_target_s", row.time_to_target > 0 ? nlohmann::json(row.time_to_target) : nlohmann::json(nullptr)},
                        {"runs_reaching_target", row.reached}, {"efficiency", row.efficiency}});
    return {{"seconds_per_run", seconds}, {"target_rel_mse", target}, {"reference_seconds", r.reference_seconds}, {"rows", rows}};
}

std::string comparison_svg(const ComparisonResult& r, const std::string& title) {
    std::vector<ConvergenceCurve> curves;
    std::vector<std::string> labels;
    for (const auto& row : r.rows) { curves.push_back(row.first_curve); labels.push_back(row.label); }
    return convergence_svg(curves, labels, title);
}

}  // namespace tessera::api
