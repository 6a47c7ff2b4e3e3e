// Holds engine/scene/lights.cpp to lights.h: a CS184 parallelogram lamp becomes a two-triangle
// emissive mesh with its own emitter material, its corners at position ± half of each edge and
// its emitting side toward the lamp's direction, unless an emissive mesh already stands where it
// is (then it is left out, and the report says so); point, spot, directional and ambient lights
// become delta lights and the sky; an emissive mesh's area light keeps its non-degenerate
// triangles with their areas, unit normals and a cumulative area table ending at 1; and the power
// table gives each light its share of luminance × area (twice for two-sided emitters). Also the
// same promises through build_render_scene, where the lamps must be found by rays as well.
#include "engine/scene/lights.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "engine/material/material.h"
#include "engine/scene/intersect.h"
#include "engine/scene/procedural.h"
#include "engine/scene/render_scene.h"

namespace tessera {
namespace {

bool mentions(const std::vector<std::string>& lines, const std::string& what) {
    for (const std::string& l : lines)
        if (l.find(what) != std::string::npos) return true;
    return false;
}

LightDesc lamp(glm::vec3 position, glm::vec3 dim_x, glm::vec3 dim_y, glm::vec3 direction, glm::vec3 radiance, int line) {
    LightDesc l;
    l.kind = LightKind::area;
    l.position = position;
    l.dim_x = dim_x;
    l.dim_y = dim_y;
    l.direction = direction;
    l.radiance = radiance;
    l.origin = SourceLocation{"lamps.dae", line, ""};
    return l;
}

// A quad mesh (two triangles) spanning [lo, hi] in x and z at height y.
MeshDesc quad(float y, glm::vec2 lo, glm::vec2 hi, int material) {
    MeshDesc m;
    m.name = "quad";
    m.positions = {{lo.x, y, lo.y}, {hi.x, y, lo.y}, {hi.x, y, hi.y}, {lo.x, y, hi.y}};
    m.indices = {0, 1, 2, 0, 2, 3};
    m.material = material;
    return m;
}

std::vector<Material> runtime_materials(const SceneDescription& d) {
    std::vector<Material> out;
    for (const MaterialDesc& m : d.materials) out.push_back(make_material(m));
    return out;
}

glm::vec3 face_normal(const MeshDesc& m, size_t tri) {
    const glm::vec3 &a = m.positions[m.indices[3 * tri]], &b = m.positions[m.indices[3 * tri + 1]],
                    &c = m.positions[m.indices[3 * tri + 2]];
    return glm::cross(b - a, c - a);
}

// The lamp's quad: corners at position ± dim_x/2 ± dim_y/2, two triangles covering its area,
// both facing the lamp's direction (whichever way round its edges are given), an emitter material
// of its radiance appended for it, and its origin kept. Other light kinds make no mesh.
TEST(Lights, Cs184LampBecomesAnEmissiveQuadFacingItsDirection) {
    const glm::vec3 pos(1.f, 2.f, 3.f), dx(0.5f, 0.f, 0.f), dz(0.f, 0.f, 0.25f);
    for (glm::vec3 dir : {glm::vec3(0.f, -1.f, 0.f), glm::vec3(0.f, 1.f, 0.f), glm::normalize(glm::vec3(0.2f, -1.f, 0.1f))})
        for (bool swapped : {false, true}) {
            SceneDescription d;
            d.materials.push_back(MaterialDesc{});
            d.meshes.push_back(quad(-5.f, {-1.f, -1.f}, {1.f, 1.f}, 0));  // elsewhere, and not emissive
            d.lights.push_back(lamp(pos, swapped ? dz : dx, swapped ? dx : dz, dir, {3.f, 2.f, 1.f}, 7));
            LightDesc point;
            point.kind = LightKind::point;
            d.lights.push_back(point);
            LightDesc sky;
            sky.kind = LightKind::ambient;
            d.lights.push_back(sky);
            std::vector<Material> materials = runtime_materials(d);
            BuildReport report;
            const std::vector<MeshDesc> lamps = cs184_lamps_as_meshes(d, materials, report);
            const std::string where = "direction (" + std::to_string(dir.x) + ", " + std::to_string(dir.y) + ", " +
                                      std::to_string(dir.z) + ")" + (swapped ? ", edges swapped" : "");
            ASSERT_EQ(lamps.size(), 1u) << where;
            EXPECT_TRUE(report.left_out.empty()) << where;
            const MeshDesc& m = lamps[0];
            ASSERT_EQ(m.positions.size(), 4u);
            ASSERT_EQ(m.indices.size(), 6u);
            for (const glm::vec3& corner : {pos - 0.5f * dx - 0.5f * dz, pos + 0.5f * dx - 0.5f * dz, pos + 0.5f * dx + 0.5f * dz,
                                            pos - 0.5f * dx + 0.5f * dz})
                EXPECT_TRUE(std::any_of(m.positions.begin(), m.positions.end(),
                                        [&](const glm::vec3& p) { return glm::length(p - corner) < 1e-6f; }))
                    << where << ": a corner is missing";
            float area = 0.f;
            for (size_t t = 0; t < 2; ++t) {
                const glm::vec3 n = face_normal(m, t);
                area += 0.5f * glm::length(n);
                EXPECT_GT(glm::dot(n, dir), 0.f) << where << ": triangle " << t << " emits away from the lamp's direction";
            }
            EXPECT_NEAR(area, glm::length(glm::cross(dx, dz)), 1e-6f) << where << ": the triangles must cover the lamp once";
            ASSERT_EQ(m.material, 1) << where << ": the lamp's material is appended after the scene's";
            ASSERT_EQ(materials.size(), 2u);
            EXPECT_EQ(materials[1].emission, glm::vec3(3.f, 2.f, 1.f));
            EXPECT_TRUE(bsdf_is_black(materials[1].bsdf)) << "a lamp reflects nothing";
            EXPECT_FALSE(materials[1].double_sided);
            EXPECT_EQ(m.origin.file, "lamps.dae");
            EXPECT_EQ(m.origin.line, 7);
        }
}

// The Cornell boxes carry their lamp twice, as a lamp and as emissive geometry: where an emissive
// mesh stands at the lamp (its bounds padded by 5% of their diagonal), the lamp is left out and
// the report names it. Non-emissive meshes, meshes without a material, and emissive meshes
// elsewhere do not count.
TEST(Lights, LampWhereAnEmissiveMeshStandsIsLeftOut) {
    SceneDescription d;
    MaterialDesc glow;
    glow.kind = MaterialKind::emission;
    glow.emission = glm::vec3(10.f);
    d.materials.push_back(glow);         // 0
    d.materials.push_back(MaterialDesc{});  // 1: grey
    d.meshes.push_back(quad(1.49f, {-0.4f, -0.3f}, {0.4f, 0.3f}, 0));  // the lamp's geometry
    d.meshes.push_back(quad(0.f, {-1.f, -1.f}, {1.f, 1.f}, 1));        // a grey floor
    d.meshes.push_back(quad(-1.f, {-1.f, -1.f}, {1.f, 1.f}, -1));      // a floor with no material
    const glm::vec3 dx(0.8f, 0.f, 0.f), dz(0.f, 0.f, 0.6f), down(0.f, -1.f, 0.f);
    d.lights.push_back(lamp({0.f, 1.49f, 0.f}, dx, dz, down, glm::vec3(10.f), 1));    // on the geometry
    d.lights.push_back(lamp({0.1f, 1.45f, 0.f}, dx, dz, down, glm::vec3(10.f), 2));   // 4 cm below it: the same lamp
    d.lights.push_back(lamp({0.f, 0.f, 0.f}, dx, dz, down, glm::vec3(10.f), 3));      // on the grey floor
    d.lights.push_back(lamp({0.f, -1.f, 0.f}, dx, dz, down, glm::vec3(10.f), 4));     // on the floor without material
    d.lights.push_back(lamp({0.f, 1.1f, 0.f}, dx, dz, down, glm::vec3(10.f), 5));     // 39 cm below: another lamp
    std::vector<Material> materials = runtime_materials(d);
    BuildReport report;
    const std::vector<MeshDesc> lamps = cs184_lamps_as_meshes(d, materials, report);
    ASSERT_EQ(lamps.size(), 3u);
    EXPECT_EQ(lamps[0].origin.line, 3);
    EXPECT_EQ(lamps[1].origin.line, 4);
    EXPECT_EQ(lamps[2].origin.line, 5);
    EXPECT_EQ(materials.size(), d.materials.size() + 3) << "one material per lamp kept, none for those left out";
    ASSERT_EQ(report.left_out.size(), 2u);
    EXPECT_TRUE(mentions(report.left_out, "lamps.dae:1")) << report.left_out[0];
    EXPECT_TRUE(mentions(report.left_out, "lamps.dae:2")) << report.left_out[1];
    EXPECT_TRUE(mentions(report.left_out, "duplicates an emissive mesh"));
}

// Through build_render_scene: the Cornell box with its lamp given twice has one area light; the
// box with the lamp only as a CS184 lamp has it as a mesh that rays find, emitting downward,
// each of its triangles tied to its entry in light_triangles.
TEST(Lights, Cs184LampIsCountedOnceAndFoundByRays) {
    const LightDesc ceiling = lamp({0.f, 1.49f, 0.f}, {0.8f, 0.f, 0.f}, {0.f, 0.f, 0.6f}, {0.f, -1.f, 0.f}, glm::vec3(10.f), 9);
    SceneDescription twice = cornell_box();
    twice.lights.push_back(ceiling);
    const RenderScene t = build_render_scene(twice, {});
    EXPECT_EQ(t.area_lights.size(), 1u);
    EXPECT_EQ(t.light_triangles.size(), 2u);
    EXPECT_EQ(t.triangle_count(), twice.triangle_count());
    EXPECT_TRUE(mentions(t.report.left_out, "lamps.dae:9"));

    SceneDescription lamp_only = cornell_box();
    lamp_only.meshes.pop_back();  // the lamp's geometry (procedural.cpp adds it last)
    lamp_only.lights.push_back(ceiling);
    const RenderScene s = build_render_scene(lamp_only, {});
    ASSERT_EQ(s.area_lights.size(), 1u);
    const AreaLight& al = s.area_lights[0];
    EXPECT_NEAR(al.area, 0.48f, 1e-6f);
    EXPECT_EQ(al.radiance, glm::vec3(10.f));
    EXPECT_FALSE(al.double_sided);
    EXPECT_EQ(al.power_pmf, 1.f);
    EXPECT_EQ(al.power_cdf, 1.f);
    EXPECT_EQ(s.triangle_count(), lamp_only.triangle_count() + 2);
    EXPECT_EQ(s.materials.size(), lamp_only.materials.size() + 2) << "the lamp's material and the default grey";
    ASSERT_EQ(s.light_triangles.size(), 2u);
    for (uint32_t k = 0; k < 2; ++k) {
        const LightTriangle& lt = s.light_triangles[k];
        EXPECT_EQ(lt.light, 0u);
        EXPECT_GT(-lt.n.y, 0.999f) << "the lamp emits down, into the box";
        ASSERT_LT(lt.prim, s.triangle_count());
        EXPECT_EQ(s.tri_shading[lt.prim].light, k);
    }
    // Hemisphere sampling finds lamps by hitting them: rays up from the floor meet the lamp's
    // triangles, whose material emits the lamp's radiance.
    for (glm::vec2 xz : {glm::vec2(0.f, 0.f), glm::vec2(0.3f, 0.2f), glm::vec2(-0.35f, -0.25f)}) {
        Ray r;
        r.o = glm::vec3(xz.x, 0.5f, xz.y);
        r.d = glm::vec3(0.f, 1.f, 0.f);
        Hit h;
        TraversalCounters tc;
        ASSERT_TRUE(intersect(s, r, h, tc));
        EXPECT_NEAR(h.t, 0.99f, 1e-5f);
        ASSERT_FALSE(h.sphere);
        EXPECT_NE(s.tri_shading[h.prim].light, kNoLight);
        const SurfaceInteraction si = surface_at(s, r, h);
        EXPECT_EQ(s.materials[si.material].emission, glm::vec3(10.f));
        EXPECT_LT(glm::dot(si.ng, r.d), 0.f) << "the ray from the room meets the lamp's emitting side";
    }
}

// Point and spot lights (spots as points) keep position and intensity; directional lights are
// normalised, and one without a direction is dropped; ambient lights add up into the sky; area
// lights are not delta lights.
TEST(Lights, DeltaLightsAndTheSky) {
    SceneDescription d;
    LightDesc p;
    p.kind = LightKind::point;
    p.position = {1.f, 2.f, 3.f};
    p.radiance = {5.f, 6.f, 7.f};
    d.lights.push_back(p);
    LightDesc spot = p;
    spot.kind = LightKind::spot;
    spot.position = {-1.f, 0.f, 0.f};
    d.lights.push_back(spot);
    LightDesc sun;
    sun.kind = LightKind::directional;
    sun.direction = {0.f, -3.f, 4.f};
    sun.radiance = glm::vec3(2.f);
    d.lights.push_back(sun);
    LightDesc nowhere = sun;
    nowhere.direction = glm::vec3(0.f);
    d.lights.push_back(nowhere);
    LightDesc a1, a2;
    a1.kind = a2.kind = LightKind::ambient;
    a1.radiance = {0.1f, 0.2f, 0.3f};
    a2.radiance = {1.f, 1.f, 1.f};
    d.lights.push_back(a1);
    d.lights.push_back(a2);
    d.lights.push_back(lamp(glm::vec3(0.f), glm::vec3(1.f, 0.f, 0.f), glm::vec3(0.f, 0.f, 1.f), glm::vec3(0.f, -1.f, 0.f),
                            glm::vec3(1.f), 1));
    RenderScene s;
    add_delta_lights(d, s);
    ASSERT_EQ(s.delta_lights.size(), 3u);
    EXPECT_EQ(s.delta_lights[0].kind, DeltaKind::point);
    EXPECT_EQ(s.delta_lights[0].position, p.position);
    EXPECT_EQ(s.delta_lights[0].intensity, p.radiance);
    EXPECT_EQ(s.delta_lights[1].kind, DeltaKind::point);
    EXPECT_EQ(s.delta_lights[1].position, spot.position);
    EXPECT_EQ(s.delta_lights[2].kind, DeltaKind::directional);
    EXPECT_LT(glm::length(s.delta_lights[2].direction - glm::vec3(0.f, -0.6f, 0.8f)), 1e-6f);
    EXPECT_EQ(s.delta_lights[2].intensity, glm::vec3(2.f));
    EXPECT_TRUE(s.has_sky);
    EXPECT_LT(glm::length(s.sky - glm::vec3(1.1f, 1.2f, 1.3f)), 1e-6f);
    EXPECT_TRUE(s.area_lights.empty());
    EXPECT_TRUE(s.has_lights());

    RenderScene none;
    add_delta_lights(SceneDescription{}, none);
    EXPECT_FALSE(none.has_sky);
    EXPECT_FALSE(none.has_lights());
}

// An emissive mesh's area light: degenerate triangles are skipped, the others keep their vertex,
// edges, area and unit normal, the cumulative table rises by each one's share of the area and ends
// at exactly 1, and the light carries the material's radiance, sidedness and index. A mesh with
// no area makes no light and leaves the tables as they were.
TEST(Lights, AreaLightTablesItsTrianglesByArea) {
    MeshDesc m;
    m.positions = {{0.f, 0.f, 0.f}, {2.f, 0.f, 0.f}, {0.f, 0.f, 1.f}, {2.f, 0.f, 1.f}, {4.f, 0.f, 0.f}, {0.f, 3.f, 0.f}};
    // Areas 1, 0 (a line), 1, and 3 (in the xy plane).
    m.indices = {0, 2, 1, 0, 1, 4, 1, 2, 3, 0, 1, 5};
    MaterialDesc glow;
    glow.kind = MaterialKind::emission;
    glow.emission = {2.f, 4.f, 6.f};
    glow.double_sided = true;
    const Material mat = make_material(glow);
    RenderScene s;
    const uint32_t index = add_area_light(m, mat, 5, s);
    ASSERT_EQ(index, 0u);
    ASSERT_EQ(s.area_lights.size(), 1u);
    const AreaLight& al = s.area_lights[0];
    EXPECT_EQ(al.first, 0u);
    ASSERT_EQ(al.count, 3u);
    EXPECT_FLOAT_EQ(al.area, 5.f);
    EXPECT_EQ(al.radiance, glow.emission);
    EXPECT_TRUE(al.double_sided);
    EXPECT_EQ(al.material, 5u);
    const float areas[] = {1.f, 1.f, 3.f};
    const size_t tri_of[] = {0, 2, 3};
    float running = 0.f;
    for (uint32_t k = 0; k < 3; ++k) {
        const LightTriangle& lt = s.light_triangles[k];
        const glm::vec3 &p0 = m.positions[m.indices[3 * tri_of[k]]], &p1 = m.positions[m.indices[3 * tri_of[k] + 1]],
                        &p2 = m.positions[m.indices[3 * tri_of[k] + 2]];
        EXPECT_EQ(lt.p0, p0) << k;
        EXPECT_EQ(lt.e1, p1 - p0) << k;
        EXPECT_EQ(lt.e2, p2 - p0) << k;
        EXPECT_FLOAT_EQ(lt.area, areas[k]) << k;
        EXPECT_NEAR(glm::length(lt.n), 1.f, 1e-6f) << k;
        EXPECT_GT(glm::dot(lt.n, glm::cross(lt.e1, lt.e2)), 0.f) << k << ": the normal is cross(e1, e2)'s";
        EXPECT_EQ(lt.light, 0u);
        running += areas[k];
        EXPECT_NEAR(lt.cdf, running / 5.f, 1e-6f) << k;
    }
    EXPECT_EQ(s.light_triangles.back().cdf, 1.f);

    MeshDesc flat;
    flat.positions = {{0.f, 0.f, 0.f}, {1.f, 1.f, 1.f}, {2.f, 2.f, 2.f}};
    flat.indices = {0, 1, 2, 0, 0, 1};
    EXPECT_EQ(add_area_light(flat, mat, 6, s), kNoLight);
    EXPECT_EQ(s.area_lights.size(), 1u);
    EXPECT_EQ(s.light_triangles.size(), 3u);

    // A second light starts where the first one's triangles end.
    MeshDesc one;
    one.positions = {{0.f, 0.f, 0.f}, {1.f, 0.f, 0.f}, {0.f, 1.f, 0.f}};
    one.indices = {0, 1, 2};
    ASSERT_EQ(add_area_light(one, mat, 7, s), 1u);
    EXPECT_EQ(s.area_lights[1].first, 3u);
    EXPECT_EQ(s.area_lights[1].count, 1u);
    EXPECT_EQ(s.light_triangles[3].light, 1u);
    EXPECT_EQ(s.light_triangles[3].cdf, 1.f);
}

AreaLight light(glm::vec3 radiance, float area, bool two_sided) {
    AreaLight l{};
    l.radiance = radiance;
    l.area = area;
    l.double_sided = two_sided;
    return l;
}

// Each light's share is its luminance × area (doubled when two-sided) over the total; the
// cumulative table sums the shares and ends at exactly 1.
TEST(Lights, PowerTableIsProportionalToEmittedPower) {
    std::vector<AreaLight> lights = {light({1.f, 0.f, 0.f}, 1.f, false), light({0.f, 1.f, 0.f}, 1.f, false),
                                     light({0.f, 0.f, 1.f}, 2.f, true), light({3.f, 3.f, 3.f}, 0.5f, false)};
    const double power[] = {0.2126, 0.7152, 0.0722 * 2 * 2, 1.5};
    const double total = power[0] + power[1] + power[2] + power[3];
    build_power_table(lights);
    double running = 0;
    for (size_t i = 0; i < lights.size(); ++i) {
        running += power[i] / total;
        EXPECT_NEAR(lights[i].power_pmf, power[i] / total, 1e-6) << i;
        EXPECT_NEAR(lights[i].power_cdf, running, 1e-6) << i;
        if (i > 0) {
            EXPECT_GE(lights[i].power_cdf, lights[i - 1].power_cdf) << i;
        }
    }
    EXPECT_EQ(lights.back().power_cdf, 1.f);

    // No power at all: every light alike (rather than a division by zero).
    std::vector<AreaLight> dark = {light(glm::vec3(0.f), 1.f, false), light(glm::vec3(0.f), 3.f, true)};
    build_power_table(dark);
    EXPECT_FLOAT_EQ(dark[0].power_pmf, 0.5f);
    EXPECT_FLOAT_EQ(dark[1].power_pmf, 0.5f);
    EXPECT_FLOAT_EQ(dark[0].power_cdf, 0.5f);
    EXPECT_EQ(dark[1].power_cdf, 1.f);

    std::vector<AreaLight> empty;
    build_power_table(empty);
    EXPECT_TRUE(empty.empty());
}

// The same through a scene of lamps whose radiance spans two orders of magnitude, and one with
// two-sided lamps: each light's share is its power, its area measured from its own triangles.
TEST(Lights, ScenePowerTableFollowsEachLampsPower) {
    for (const SceneDescription& d : {many_lights(16), scattered_lights(16)}) {
        const RenderScene s = build_render_scene(d, {});
        ASSERT_EQ(s.area_lights.size(), 16u) << d.source;
        std::vector<double> power;
        double total = 0;
        for (const AreaLight& al : s.area_lights) {
            double area = 0;
            for (uint32_t k = al.first; k < al.first + al.count; ++k) area += s.light_triangles[k].area;
            EXPECT_NEAR(area, al.area, 1e-6 * area) << d.source;
            EXPECT_EQ(al.double_sided, d.source == "builtin:scattered_lights") << d.source;
            power.push_back(luminance(al.radiance) * area * (al.double_sided ? 2.0 : 1.0));
            total += power.back();
        }
        double pmf_sum = 0;
        for (size_t i = 0; i < power.size(); ++i) {
            EXPECT_NEAR(s.area_lights[i].power_pmf, power[i] / total, 1e-5 * power[i] / total + 1e-9) << d.source << ", light " << i;
            pmf_sum += s.area_lights[i].power_pmf;
        }
        EXPECT_NEAR(pmf_sum, 1.0, 1e-5) << d.source;
        EXPECT_EQ(s.area_lights.back().power_cdf, 1.f) << d.source;
    }
}

// The report's line on lights, the warning and left-out line of a scene without any, and the
// warning for an emissive sphere (not a light yet).
TEST(Lights, ReportSaysWhatLightsThereAre) {
    SceneDescription d;
    MaterialDesc glow;
    glow.kind = MaterialKind::emission;
    glow.emission = glm::vec3(1.f);
    d.materials.push_back(glow);
    d.spheres.push_back({glm::vec3(0.f), 1.f, 0, SourceLocation{"balls.gltf", 0, "/nodes/3"}});
    RenderScene s;
    s.materials = runtime_materials(d);
    BuildReport dark;
    report_lights(d, s, dark);
    EXPECT_TRUE(mentions(dark.warnings, "balls.gltf#/nodes/3")) << "the emissive sphere is named";
    EXPECT_TRUE(mentions(dark.warnings, "no lights or emitters"));
    EXPECT_TRUE(mentions(dark.left_out, "light sampling and shadow rays"));

    s.area_lights.push_back(light(glm::vec3(1.f), 1.f, false));
    s.delta_lights.push_back({DeltaKind::point, glm::vec3(0.f), glm::vec3(0.f), glm::vec3(1.f)});
    s.delta_lights.push_back({DeltaKind::point, glm::vec3(1.f), glm::vec3(0.f), glm::vec3(1.f)});
    s.has_sky = true;
    BuildReport lit;
    report_lights(d, s, lit);
    EXPECT_TRUE(mentions(lit.built, "lights: 1 area, 2 delta, sky"));
    EXPECT_FALSE(mentions(lit.warnings, "no lights or emitters"));
    EXPECT_TRUE(lit.left_out.empty());
}

}  // namespace
}  // namespace tessera
