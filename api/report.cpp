#include "api/report.h"

namespace tessera::api {

using nlohmann::json;

namespace {

json timings_json(const JobTimings& t) {
    return {{"load_s", t.load_s}, {"bvh_s", t.bvh_s}, {"render_s", t.render_s}, {"write_s", t.write_s}, {"total_s", t.total_s}};
}

json stats_json(const RenderReport& r) {
    const RenderStats& st = r.stats;
    const double npx = double(r.job.render.width) * r.job.render.height;
    const double per_ray = st.rays() ? 1.0 / double(st.rays()) : 0.0;
    return {{"rays_camera", st.camera_rays}, {"rays_shadow", st.shadow_rays}, {"rays_bounce", st.bounce_rays},
            {"mrays_per_s", st.render_seconds > 0 ? double(st.rays()) / st.render_seconds * 1e-6 : 0.0},
            {"bvh_nodes", r.bvh.node_count}, {"bvh_depth", r.bvh.depth},
            {"bvh_sah_cost", r.bvh.sah_cost}, {"bvh_bytes", r.accel_bytes},
            {"nodes_per_ray", double(st.traversal.nodes_visited) * per_ray},
            {"prim_tests_per_ray", double(st.traversal.prim_tests) * per_ray},
            {"spp_mean", double(st.samples) / npx}, {"spp_min", float(r.spp_min)}, {"spp_max", float(r.spp_max)},
            {"nonfinite_samples", st.nonfinite_samples}, {"max_sample_luminance", st.max_sample},
            {"threads", st.threads}};
}

json progress_json(const RenderReport& r) {
    return {{"fraction", 1.0}, {"tiles_done", r.tiles_done}, {"tiles_total", r.tiles_total}, {"samples_done", r.stats.samples}};
}

json recovered_json(const RenderReport& r) {
    return {{"samples", r.recovered_samples}, {"render_s", r.recovered_render_s}};
}

json nodes_json(const RenderReport& r) {
    json nodes = json::array();
    size_t all = 0;
    for (const NodeShare& n : r.nodes) all += n.tiles;
    for (const NodeShare& n : r.nodes)
        nodes.push_back({{"node", n.node}, {"tiles", n.tiles}, {"share", all ? double(n.tiles) / double(all) : 0.0},
                         {"seconds", n.seconds}});
    return nodes;
}

}  // namespace

json to_json(const ConvergencePoint& p) {
    json jp = {{"seconds", p.seconds}, {"spp_mean", p.spp_mean}};
    jp["est_rel_mse"] = p.est_rel_mse >= 0 ? json(p.est_rel_mse) : json(nullptr);
    if (p.rel_mse >= 0) {
        jp["rel_mse"] = p.rel_mse;
        jp["mse"] = p.mse;
        jp["mae"] = p.mae;
    }
    // A denoising render's second series: the denoised image's error.
    if (p.denoised_est_rel_mse >= 0) {
        jp["denoised_est_rel_mse"] = p.denoised_est_rel_mse;
        if (p.denoised_rel_mse >= 0) jp["denoised_rel_mse"] = p.denoised_rel_mse;
        jp["denoise_seconds"] = p.denoise_seconds;
    }
    return jp;
}

ConvergencePoint convergence_point_from_json(const json& j) {
    auto measured = [&](const char* k) { return j.contains(k) && j[k].is_number() ? j[k].get<double>() : -1.0; };
    ConvergencePoint p;
    p.seconds = j.at("seconds").get<double>();
    p.spp_mean = j.at("spp_mean").get<double>();
    p.est_rel_mse = measured("est_rel_mse");
    p.rel_mse = measured("rel_mse");
    p.mse = measured("mse");
    p.mae = measured("mae");
    p.denoised_est_rel_mse = measured("denoised_est_rel_mse");
    p.denoised_rel_mse = measured("denoised_rel_mse");
    p.denoise_seconds = std::max(0.0, measured("denoise_seconds"));
    return p;
}

json to_json(const RenderReport& r) {
    json report;
    report["settings"] = to_json(r.job);
    report["timings"] = timings_json(r.timings);
    report["stats"] = stats_json(r);
    report["scene"] = {{"name", r.job.scene}, {"triangles", r.triangles}, {"spheres", r.spheres},
                       {"built", r.scene_build.built}, {"left_out", r.scene_build.left_out},
                       {"warnings", r.scene_build.warnings}, {"build_s", r.scene_build.seconds}};
    json stages = json::array();
    for (const BuildStage& st : r.scene_build.stages) stages.push_back({{"stage", st.name}, {"seconds", st.seconds}});
    report["scene"]["build_stages"] = stages;
    if (r.scene_cache.used)
        report["scene"]["cache"] = {{"hit", r.scene_cache.hit}, {"load_s", r.scene_cache.load_s}, {"build_s", r.scene_cache.build_s}};
    json points = json::array();
    for (const ConvergencePoint& p : r.curve.points) points.push_back(to_json(p));
    const std::string& ref = r.job.reference;
    report["convergence"] = {
        {"stop_reason", to_string(r.curve.stop)},
        {"error_measure", ref.empty()
                              ? "estimated relative MSE from the even- and odd-sample half buffers: mean ((A-B)^2/4)/(x^2+0.01)"
                              : "relative MSE against job " + ref + ": mean (x-r)^2/(r^2+0.01); the half-buffer estimate too"},
        {"points", points}};
    report["render"] = {{"built", r.render_built}, {"left_out", r.render_left_out}};
    report["progress"] = progress_json(r);
    if (!r.nodes.empty()) report["nodes"] = nodes_json(r);
    if (r.recovered_samples > 0) report["recovered"] = recovered_json(r);
    return report;
}

json status_summary(const RenderReport& r) {
    json s = {{"timings", timings_json(r.timings)}, {"stats", stats_json(r)}, {"progress", progress_json(r)}};
    if (!r.nodes.empty()) s["nodes"] = nodes_json(r);
    if (r.recovered_samples > 0) s["recovered"] = recovered_json(r);
    if (r.job.render.denoise) s["denoised"] = r.denoised;  // whether the status links to a denoised image
    return s;
}

}  // namespace tessera::api
