#include "api/scene_summary.h"

#include "engine/geometry/aabb.h"
#include "engine/scene/instancing.h"

namespace tessera::api {

nlohmann::json describe_scene(const SceneDescription& s) {
    const Aabb b = scene_bounds(s);
    nlohmann::json j = {{"triangles", s.triangle_count()}, {"placed_triangles", s.placed_triangle_count()},
                        {"instances", s.instances.size()}, {"prototypes", s.prototypes.size()},
                        {"spheres", s.spheres.size()}, {"lights", s.lights.size()}, {"warnings", s.warnings}};
    size_t emissive = 0;
    for (const auto& m : s.meshes)
        if (m.material >= 0 && s.materials[size_t(m.material)].emits()) ++emissive;
    j["emissive_meshes"] = emissive;
    size_t textured = 0, texel_bytes = 0;
    for (const auto& m : s.materials) textured += m.textured();
    for (const auto& img : s.images) texel_bytes += img->rgba.size();
    j["materials"] = s.materials.size();
    j["textured_materials"] = textured;
    j["images"] = s.images.size();
    j["texel_bytes"] = texel_bytes;
    nlohmann::json animations = nlohmann::json::array();
    for (const AnimationSummary& a : s.animations)
        animations.push_back({{"name", a.name}, {"start_s", a.start_s}, {"end_s", a.end_s}, {"channels", a.channels}});
    j["animations"] = animations;
    if (!b.empty()) j["bounds"] = {{"min", {b.lo.x, b.lo.y, b.lo.z}}, {"max", {b.hi.x, b.hi.y, b.hi.z}}};
    else j["bounds"] = nullptr;
    return j;
}

}  // namespace tessera::api
