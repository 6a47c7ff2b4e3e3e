#pragma once
// A render job as the API and the CLI's --job take it: JSON mapped to engine settings, with
// every field checked once, here, and errors that name the field (as a JSON pointer).
#include <stdexcept>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "engine/render/render_settings.h"
#include "engine/scene/render_scene.h"

namespace tessera::api {

// Bad input: `pointer` names the offending field ("/spp", "/adaptive/batch"; "" for the body).
class InvalidJob : public std::runtime_error {
public:
    InvalidJob(std::string pointer, const std::string& what) : std::runtime_error(what), pointer_(std::move(pointer)) {}
    const std::string& pointer() const { return pointer_; }

private:
    std::string pointer_;
};

// Limits against absurd or abusive jobs (configurable by the server).
struct JobLimits {
    int64_t max_pixels = 16384ll * 16384;
    int max_dimension = 16384;
    int max_spp = 1 << 16;
    int max_depth = 1000;
    int max_light_rays = 1024;
    double max_time_limit_s = 7 * 24 * 3600.0;
};

struct JobSpec {
    std::string scene;
    RenderSettings render;
    RenderSceneOptions scene_options;
    int priority = 0;
    double time_limit_s = 0.0;  // 0: none (also in render.time_limit_s)
    std::string reference;      // a finished job whose image is the reference for the error curve
};

// Throws InvalidJob. Only "scene" is required; unknown fields are errors.
JobSpec parse_job(const nlohmann::json& body, const JobLimits& limits = {});
// The effective settings, every field present (the report and GET /v1/jobs/{id} show these).
nlohmann::json to_json(const JobSpec& job);

}  // namespace tessera::api
