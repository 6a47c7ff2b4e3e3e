#include "api/job_spec.h"

#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>

namespace tessera::api {
namespace {

using nlohmann::json;

const char* type_name(const json& v) { return v.type_name(); }

int64_t get_int(const json& v, const std::string& ptr, int64_t lo, int64_t hi) {
    if (!v.is_number_integer() && !(v.is_number_float() && std::trunc(v.get<double>()) == v.get<double>()))
        throw InvalidJob(ptr, ptr + " must be an integer, not " + std::string(type_name(v)));
    const double d = v.get<double>();
    if (d < double(lo) || d > double(hi))
        throw InvalidJob(ptr, ptr + " must lie in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + v.dump());
    return v.is_number_float() ? int64_t(d) : v.get<int64_t>();
}

double get_number(const json& v, const std::string& ptr, double lo, double hi) {
    if (!v.is_number()) throw InvalidJob(ptr, ptr + " must be a number, not " + std::string(type_name(v)));
    const double d = v.get<double>();
    if (!std::isfinite(d) || d < lo || d > hi)
        throw InvalidJob(ptr, ptr + " must lie in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + v.dump());
    return d;
}

std::string get_string(const json& v, const std::string& ptr) {
    if (!v.is_string()) throw InvalidJob(ptr, ptr + " must be a string, not " + std::string(type_name(v)));
    return v.get<std::string>();
}

template <class E, size_t N>
E get_enum(const json& v, const std::string& ptr, const std::pair<const char*, E> (&options)[N]) {
    const std::string s = get_string(v, ptr);
    std::string list;
    for (const auto& [name, value] : options) {
        if (s == name) return value;
        list += (list.empty() ? "" : "|") + std::string(name);
    }
    throw InvalidJob(ptr, ptr + " must be one of " + list + ", got \"" + s + "\"");
}

constexpr std::pair<const char*, BvhType> kBvh[] = {
    {"none", BvhType::none}, {"midpoint", BvhType::midpoint}, {"median", BvhType::median}, {"sah", BvhType::sah},
    {"embree", BvhType::embree}};
constexpr std::pair<const char*, DirectLighting> kDirect[] = {
    {"hemisphere", DirectLighting::hemisphere}, {"importance", DirectLighting::importance}, {"mis", DirectLighting::mis}};
constexpr std::pair<const char*, BounceMode> kBounces[] = {{"accumulate", BounceMode::accumulate}, {"nth", BounceMode::nth}};
constexpr std::pair<const char*, LightingOutput> kOutput[] = {
    {"all", LightingOutput::all}, {"direct", LightingOutput::direct}, {"indirect", LightingOutput::indirect}};
constexpr std::pair<const char*, LightSelection> kSelection[] = {{"all", LightSelection::all}, {"power", LightSelection::power}};
constexpr std::pair<const char*, Integrator> kIntegrator[] = {{"path", Integrator::path}, {"normals", Integrator::normals}};
constexpr std::pair<const char*, TriangleTest> kTriangle[] = {
    {"watertight", TriangleTest::watertight}, {"moller_trumbore", TriangleTest::moller_trumbore}};

template <class E, size_t N>
const char* enum_name(E e, const std::pair<const char*, E> (&options)[N]) {
    for (const auto& [name, value] : options) if (value == e) return name;
    return "?";
}

}  // namespace

JobSpec parse_job(const json& body, const JobLimits& limits) {
    if (!body.is_object()) throw InvalidJob("", "the job must be a JSON object, not " + std::string(body.type_name()));
    JobSpec job;
    RenderSettings& r = job.render;
    r.width = 800;
    r.height = 600;
    bool have_scene = false;
    for (const auto& [key, v] : body.items()) {
        const std::string ptr = "/" + key;
        if (key == "scene") {
            job.scene = get_string(v, ptr);
            if (job.scene.empty() || job.scene.size() > 4096) throw InvalidJob(ptr, "/scene must be a non-empty name");
            have_scene = true;
        } else if (key == "width") r.width = int(get_int(v, ptr, 1, limits.max_dimension));
        else if (key == "height") r.height = int(get_int(v, ptr, 1, limits.max_dimension));
        else if (key == "spp") r.spp = int(get_int(v, ptr, 1, limits.max_spp));
        else if (key == "light_rays") r.light_rays = int(get_int(v, ptr, 1, limits.max_light_rays));
        else if (key == "max_depth") r.max_depth = int(get_int(v, ptr, 0, limits.max_depth));
        else if (key == "bvh") {
            job.scene_options.bvh.type = get_enum(v, ptr, kBvh);
            if (job.scene_options.bvh.type == BvhType::embree && !embree_available())
                throw InvalidJob(ptr, "/bvh \"embree\" is not available: this build has no Embree (install libembree-dev and rebuild)");
        }
        else if (key == "max_leaf_size") job.scene_options.bvh.max_leaf_size = int(get_int(v, ptr, 1, 255));
        else if (key == "triangle_test") job.scene_options.triangle_test = get_enum(v, ptr, kTriangle);
        else if (key == "direct") r.direct = get_enum(v, ptr, kDirect);
        else if (key == "integrator") r.integrator = get_enum(v, ptr, kIntegrator);
        else if (key == "russian_roulette") r.russian_roulette = float(get_number(v, ptr, 0.0, 1.0));
        else if (key == "bounces") r.bounces = get_enum(v, ptr, kBounces);
        else if (key == "lighting") r.output = get_enum(v, ptr, kOutput);
        else if (key == "light_selection") r.light_selection = get_enum(v, ptr, kSelection);
        else if (key == "adaptive") {
            if (v.is_null()) { r.adaptive.reset(); continue; }
            if (!v.is_object()) throw InvalidJob(ptr, "/adaptive must be an object {\"batch\", \"tolerance\"} or null");
            AdaptiveSettings a;
            for (const auto& [k2, v2] : v.items()) {
                const std::string p2 = ptr + "/" + k2;
                if (k2 == "batch") a.batch = int(get_int(v2, p2, 1, limits.max_spp));
                else if (k2 == "tolerance") a.tolerance = float(get_number(v2, p2, 0.0, 1e6));
                else throw InvalidJob(p2, "unknown field " + p2 + " (expected batch, tolerance)");
            }
            r.adaptive = a;
        } else if (key == "tile_size") r.tile_size = int(get_int(v, ptr, 1, 4096));
        else if (key == "seed") r.seed = uint64_t(get_int(v, ptr, 0, std::numeric_limits<int64_t>::max()));
        else if (key == "priority") job.priority = int(get_int(v, ptr, -1000, 1000));
        else if (key == "time_limit_s") job.time_limit_s = r.time_limit_s = get_number(v, ptr, 0.0, limits.max_time_limit_s);
        else if (key == "target_error") r.target_error = get_number(v, ptr, 0.0, 1e6);
        else if (key == "reference") {
            if (v.is_null()) { job.reference.clear(); continue; }
            job.reference = get_string(v, ptr);
            if (job.reference.size() != 16 || job.reference.find_first_not_of("0123456789abcdef") != std::string::npos)
                throw InvalidJob(ptr, ptr + " must be the id of a finished job (16 hex digits) or null");
        }
        else throw InvalidJob(ptr, "unknown field " + ptr);
    }
    if (!have_scene) throw InvalidJob("/scene", "/scene is required");
    if (int64_t(r.width) * r.height > limits.max_pixels)
        throw InvalidJob("/width", "width × height = " + std::to_string(int64_t(r.width) * r.height) +
                                       " pixels is over the limit of " + std::to_string(limits.max_pixels));
    return job;
}

json to_json(const JobSpec& job) {
    const RenderSettings& r = job.render;
    json j = {
        {"scene", job.scene},
        {"width", r.width},
        {"height", r.height},
        {"spp", r.spp},
        {"light_rays", r.light_rays},
        {"max_depth", r.max_depth},
        {"bvh", enum_name(job.scene_options.bvh.type, kBvh)},
        {"max_leaf_size", job.scene_options.bvh.max_leaf_size},
        {"triangle_test", enum_name(job.scene_options.triangle_test, kTriangle)},
        {"direct", enum_name(r.direct, kDirect)},
        {"integrator", enum_name(r.integrator, kIntegrator)},
        {"russian_roulette", r.russian_roulette},
        {"bounces", enum_name(r.bounces, kBounces)},
        {"lighting", enum_name(r.output, kOutput)},
        {"light_selection", enum_name(r.light_selection, kSelection)},
        {"adaptive", r.adaptive ? json{{"batch", r.adaptive->batch}, {"tolerance", r.adaptive->tolerance}} : json(nullptr)},
        {"tile_size", r.tile_size},
        {"seed", r.seed},
        {"priority", job.priority},
        {"time_limit_s", job.time_limit_s},
        {"target_error", r.target_error},
        {"reference", job.reference.empty() ? json(nullptr) : json(job.reference)},
    };
    return j;
}

}  // namespace tessera::api
