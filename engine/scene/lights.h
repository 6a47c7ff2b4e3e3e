#pragma once
// The scene's emitters as light sampling reads them: area lights (emissive meshes, CS184 lamps
// turned into meshes), delta lights and the CS184 sky, with the power table for selection by
// power. Built by build_render_scene through the functions below.
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "engine/scene/scene_description.h"

namespace tessera {

struct Material;
struct RenderScene;
struct BuildReport;

inline constexpr uint32_t kNoLight = ~0u;

// An area light: the triangles of one emissive mesh, one of which is picked by area per sample.
// A CS184 parallelogram light becomes such a mesh too, so that every strategy sees the same
// emitters (hemisphere sampling finds them by hitting geometry).
struct LightTriangle {
    glm::vec3 p0, e1, e2;
    glm::vec3 n;  // unit normal, cross(e1, e2) direction
    float cdf;    // cumulative area fraction within its light, ending at 1
    uint32_t light;  // its AreaLight
    float area;
    uint32_t prim = ~0u;  // the triangle (index of RenderScene::tri_shading), for textured emission
};
struct AreaLight {
    uint32_t first, count;  // into RenderScene::light_triangles
    float area;
    glm::vec3 radiance;
    bool double_sided;
    float power_cdf;        // cumulative share of the total emitted power, ending at 1
    float power_pmf;        // this light's share
    uint32_t material = 0;  // its Material (textured emission reads it)
};
enum class DeltaKind { point, directional };
struct DeltaLight {
    DeltaKind kind;
    glm::vec3 position;   // point
    glm::vec3 direction;  // directional: the direction light travels (unit)
    glm::vec3 intensity;  // point: W/sr; directional: irradiance
};

// CS184 parallelogram lamps as emissive meshes (one material appended to `materials` each),
// except where an emissive mesh already stands: the Cornell boxes carry the lamp twice, once
// as a lamp and once as its geometry, and it must be counted once.
std::vector<MeshDesc> cs184_lamps_as_meshes(const SceneDescription& desc, std::vector<Material>& materials,
                                            BuildReport& report);
// Point, spot (as point), directional and ambient lights of the description.
void add_delta_lights(const SceneDescription& desc, RenderScene& scene);
// The area light of one emissive mesh (its non-degenerate triangles, picked by area); returns
// its index, or kNoLight when the mesh has no area to sample.
uint32_t add_area_light(const MeshDesc& mesh, const Material& material, uint32_t material_index, RenderScene& scene);
// Each area light's share of the emitted power (luminance × area × π, doubled for two-sided
// emitters), for selection by power.
void build_power_table(std::vector<AreaLight>& lights);
// Warnings and the report's line on what lights the scene has.
void report_lights(const SceneDescription& desc, const RenderScene& scene, BuildReport& report);

}  // namespace tessera
