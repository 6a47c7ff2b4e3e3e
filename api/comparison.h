#pragma once
// Sampling configurations compared at equal time against a converged reference: the core of
// `tessera bench convergence` and of POST /v1/comparisons.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/render/renderer.h"
#include "engine/scene/render_scene.h"

namespace tessera::api {

struct ComparisonConfig {
    std::string label;
    RenderSettings settings;   // width/height/depth as the comparison's; seed and time set per run
    RenderSceneOptions scene;  // BVH type etc.
};

struct ComparisonRow {
    std::string label;
    double rel_mse_mean = 0, rel_mse_sd = 0, spp = 0;
    double time_to_target = -1;  // mean over runs that reached it; -1 if any did not
    int reached = 0;
    double efficiency = 0;       // 1/(relMSE·seconds)
    ConvergenceCurve first_curve;
};

struct ComparisonResult {
    double reference_seconds = 0;
    std::vector<ComparisonRow> rows;
};

// Renders the reference (MIS, `reference_spp`), then every configuration `reps` times for
// `seconds` each. `cancel` (optional) is checked between runs.
ComparisonResult run_comparison(const SceneDescription& scene, const std::vector<ComparisonConfig>& configs,
                                const RenderSettings& base, int reference_spp, double seconds, int reps, double target,
                                const std::atomic<bool>* cancel = nullptr);

std::string comparison_markdown(const ComparisonResult& r, double seconds, double target);
nlohmann::json comparison_json(const ComparisonResult& r, double seconds, double target);
std::string comparison_svg(const ComparisonResult& r, const std::string& title);

// The standard set of configurations: strategies, light rays, adaptive, BVH types.
std::vector<ComparisonConfig> standard_configs(const RenderSettings& base);

}  // namespace tessera::api
