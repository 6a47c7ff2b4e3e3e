// The built-in scenes: the names and parameters check_builtin_name takes and refuses (each
// refusal naming the name), the promised geometry of each scene (the Cornell box's bounds and
// lamp, lamp counts, lamp sizes that never overlap, emitters facing into the room, closed and
// outward-wound geodesic spheres, the smallest triangle count at or above the one asked for),
// and that every scene is the same on every call.
#include "engine/scene/procedural.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "engine/io/scene_loader.h"
#include "engine/scene/environment.h"

namespace tessera {
namespace {

const char* const kPlainNames[] = {"builtin:cornell_box",  "builtin:cornell_spheres", "builtin:cornell_glossy",
                                   "builtin:lamp_room",    "builtin:furnace",         "builtin:many_lights",
                                   "builtin:scattered_lights", "builtin:lamp_field"};

SceneError refusal_of(const std::string& name) {
    try {
        check_builtin_name(name);
    } catch (const SceneError& e) {
        return e;
    }
    ADD_FAILURE() << "'" << name << "' was taken";
    return SceneError(SourceLocation{}, "taken");
}

TEST(Procedural, InstancesTakeACountAndATriangleCountWithinBounds) {
    const SceneDescription d = builtin_scene("builtin:instances?count=7&triangles=200");
    EXPECT_EQ(d.instances.size(), 7u);
    ASSERT_EQ(d.prototypes.size(), 1u);
    EXPECT_GE(d.prototypes[0].indices.size() / 3, 200u);
    EXPECT_NO_THROW(validate(d));
    EXPECT_EQ(builtin_scene("builtin:instances").instances.size(), 100u);
    for (const char* bad : {"builtin:instances?count=0", "builtin:instances?count=1000001", "builtin:instances?triangles=7",
                            "builtin:instances?count=5&count=6", "builtin:instances?colour=3", "builtin:instances?count=",
                            "builtin:instances&count=3", "builtin:instances?count=-1"})
        refusal_of(bad);
    // The triangle bound counts the mesh once, however often it is placed.
    EXPECT_NO_THROW(check_builtin_name("builtin:instances?count=1000&triangles=800", 1000));
    EXPECT_THROW(check_builtin_name("builtin:instances?count=1&triangles=100000", 1000), SceneError);
}

glm::vec3 face_normal(const MeshDesc& m, size_t tri) {
    const glm::vec3 a = m.positions[m.indices[3 * tri]], b = m.positions[m.indices[3 * tri + 1]],
                    c = m.positions[m.indices[3 * tri + 2]];
    return glm::cross(b - a, c - a);
}

glm::vec3 centroid(const MeshDesc& m) {
    glm::vec3 sum(0.f);
    for (const glm::vec3& p : m.positions) sum += p;
    return sum / float(m.positions.size());
}

// The enclosed volume by the divergence theorem: positive when the faces are wound outward.
double signed_volume(const MeshDesc& m) {
    double v = 0;
    for (size_t t = 0; t < m.indices.size() / 3; ++t) {
        const glm::dvec3 a(m.positions[m.indices[3 * t]]), b(m.positions[m.indices[3 * t + 1]]),
            c(m.positions[m.indices[3 * t + 2]]);
        v += glm::dot(a, glm::cross(b, c));
    }
    return v / 6.0;
}

// Closed and consistently wound: each directed edge once, and its reverse once.
void expect_closed_and_consistent(const MeshDesc& m) {
    std::map<std::pair<uint32_t, uint32_t>, int> edges;
    for (size_t t = 0; t < m.indices.size() / 3; ++t)
        for (int k = 0; k < 3; ++k) ++edges[{m.indices[3 * t + k], m.indices[3 * t + (k + 1) % 3]}];
    int bad = 0;
    for (const auto& [e, n] : edges) {
        const auto back = edges.find({e.second, e.first});
        if (n != 1 || back == edges.end() || back->second != 1) ++bad;
    }
    EXPECT_EQ(bad, 0) << m.name << ": edges that are open, repeated or wound against their neighbour";
}

bool same_bits(const glm::vec3& a, const glm::vec3& b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Bit for bit: a built-in scene is an input like a file, and jobs on it must agree across runs
// and across the nodes of a farm.
void expect_same_scene(const SceneDescription& a, const SceneDescription& b) {
    EXPECT_EQ(a.source, b.source);
    ASSERT_EQ(a.materials.size(), b.materials.size());
    for (size_t i = 0; i < a.materials.size(); ++i) {
        EXPECT_TRUE(same_bits(a.materials[i].albedo, b.materials[i].albedo)) << i;
        EXPECT_TRUE(same_bits(a.materials[i].emission, b.materials[i].emission)) << i;
    }
    ASSERT_EQ(a.meshes.size(), b.meshes.size());
    for (size_t i = 0; i < a.meshes.size(); ++i) {
        EXPECT_EQ(a.meshes[i].indices, b.meshes[i].indices) << i;
        ASSERT_EQ(a.meshes[i].positions.size(), b.meshes[i].positions.size()) << i;
        EXPECT_EQ(std::memcmp(a.meshes[i].positions.data(), b.meshes[i].positions.data(),
                              a.meshes[i].positions.size() * sizeof(glm::vec3)),
                  0)
            << "mesh " << i;
        EXPECT_EQ(a.meshes[i].material, b.meshes[i].material) << i;
    }
    ASSERT_EQ(a.spheres.size(), b.spheres.size());
    for (size_t i = 0; i < a.spheres.size(); ++i) EXPECT_TRUE(same_bits(a.spheres[i].center, b.spheres[i].center));
    EXPECT_EQ(a.lights.size(), b.lights.size());
}

// The emitting meshes of a scene.
std::vector<const MeshDesc*> emitters(const SceneDescription& s) {
    std::vector<const MeshDesc*> out;
    for (const MeshDesc& m : s.meshes)
        if (m.material >= 0 && s.materials[size_t(m.material)].emits()) out.push_back(&m);
    return out;
}

// --- names -----------------------------------------------------------------------------------

TEST(BuiltinNames, EveryNameIsTakenAndBuildsItsScene) {
    for (const char* name : kPlainNames) {
        EXPECT_NO_THROW(check_builtin_name(name)) << name;
        const SceneDescription s = builtin_scene(name);
        EXPECT_EQ(s.source, name);
        EXPECT_FALSE(s.meshes.empty()) << name;
        EXPECT_FALSE(s.materials.empty()) << name;
    }
    for (const char* name : {"builtin:displaced_sphere", "builtin:displaced_sphere?triangles=8",
                             "builtin:displaced_sphere?triangles=20000000", "builtin:displaced_sphere?triangles=00000100"})
        EXPECT_NO_THROW(check_builtin_name(name)) << name;
}

TEST(BuiltinNames, UnknownNamesAreRefusedNamingThemAndListingTheKnownOnes) {
    for (const char* name : {"builtin:cornell", "builtin:Cornell_box", "builtin:cornell_box ", " builtin:cornell_box",
                             "builtin:cornell_box?spp=4", "builtin:", "cornell_box", "", "builtin:furnace_sphere",
                             "builtin:cornell_box/../lamp_room"}) {
        const SceneError e = refusal_of(name);
        EXPECT_EQ(e.where().file, name);
        EXPECT_EQ(e.where().line, 0);
        EXPECT_NE(e.detail().find("unknown built-in scene"), std::string::npos) << e.what();
        EXPECT_THROW(builtin_scene(name), SceneError) << name;
    }
    // The list in the message is the list that is taken.
    const std::string listed = refusal_of("builtin:nope").detail();
    for (const char* name : kPlainNames) EXPECT_NE(listed.find(std::string(name) + ","), std::string::npos) << name;
    EXPECT_NE(listed.find("builtin:displaced_sphere?triangles=N"), std::string::npos);
}

TEST(BuiltinNames, DisplacedSphereParametersAreChecked) {
    struct Case {
        const char* name;
        const char* says;
    };
    const Case cases[] = {
        {"builtin:displaced_sphere?triangles=7", "lie in [8, 20000000]"},
        {"builtin:displaced_sphere?triangles=0", "lie in [8, 20000000]"},
        {"builtin:displaced_sphere?triangles=20000001", "lie in [8, 20000000]"},
        {"builtin:displaced_sphere?triangles=999999999", "lie in [8, 20000000]"},
        {"builtin:displaced_sphere?triangles=1000000000", "whole number"},
        {"builtin:displaced_sphere?triangles=99999999999999999999999", "whole number"},
        {"builtin:displaced_sphere?triangles=", "whole number"},
        {"builtin:displaced_sphere?triangles=-8", "whole number"},
        {"builtin:displaced_sphere?triangles=+8", "whole number"},
        {"builtin:displaced_sphere?triangles=1e6", "whole number"},
        {"builtin:displaced_sphere?triangles=0x100", "whole number"},
        {"builtin:displaced_sphere?triangles= 100", "whole number"},
        {"builtin:displaced_sphere?triangles=100&seed=2", "whole number"},
        {"builtin:displaced_sphere?triangles=abc", "whole number"},
        {"builtin:displaced_sphere?tris=100", "expected '?triangles=N'"},
        {"builtin:displaced_sphere?", "expected '?triangles=N'"},
        {"builtin:displaced_sphere?Triangles=100", "expected '?triangles=N'"},
        {"builtin:displaced_spheres", "expected '?triangles=N'"},
    };
    for (const Case& c : cases) {
        const SceneError e = refusal_of(c.name);
        EXPECT_EQ(e.where().file, c.name);
        EXPECT_NE(e.detail().find(c.says), std::string::npos) << c.name << ": " << e.detail();
        EXPECT_THROW(builtin_scene(c.name), SceneError) << c.name;
    }
}

// --- displaced_sphere ------------------------------------------------------------------------

// A geodesic octahedron has 8·k² faces: the count is the smallest of those at or above the one
// asked for, so "?triangles=N" is never short and never more than one step over.
TEST(DisplacedSphere, TriangleCountIsTheSmallestGeodesicCountAtOrAboveN) {
    for (uint64_t n : {8ull, 9ull, 32ull, 33ull, 200ull, 2000ull, 2048ull, 2049ull}) {
        const SceneDescription s = builtin_scene("builtin:displaced_sphere?triangles=" + std::to_string(n));
        ASSERT_EQ(s.meshes.size(), 1u);
        const uint64_t tris = s.triangle_count();
        const uint64_t k = uint64_t(std::llround(std::sqrt(double(tris) / 8.0)));
        EXPECT_EQ(8 * k * k, tris) << n;
        EXPECT_GE(tris, n);
        EXPECT_LT(8 * (k - 1) * (k - 1), n) << n << " -> " << tris;
        // Closed: V − E + F = 2 with E = 3F/2, so shared lattice points are single vertices.
        EXPECT_EQ(s.meshes[0].positions.size(), 4 * k * k + 2) << n;
    }
    EXPECT_EQ(builtin_scene("builtin:displaced_sphere?triangles=8").triangle_count(), 8u);
    EXPECT_EQ(builtin_scene("builtin:displaced_sphere?triangles=2000").triangle_count(), 2048u);
}

TEST(DisplacedSphere, IsClosedOutwardAndDisplacedWithinItsBound) {
    const SceneDescription s = displaced_sphere(800, 5);
    const MeshDesc& m = s.meshes[0];
    expect_closed_and_consistent(m);
    EXPECT_GT(signed_volume(m), 0.0);
    // h is a sum of sines weighted 1/2 … 1/9 and moves a vertex by 15 % of it.
    double weights = 0;
    for (int i = 0; i < 8; ++i) weights += 1.0 / (2 + i);
    float lo = INFINITY, hi = 0;
    for (const glm::vec3& p : m.positions) lo = std::min(lo, glm::length(p)), hi = std::max(hi, glm::length(p));
    EXPECT_GE(lo, float(1 - 0.15 * weights) - 1e-4f);
    EXPECT_LE(hi, float(1 + 0.15 * weights) + 1e-4f);
    EXPECT_GT(hi - lo, 0.05f) << "not displaced";
    ASSERT_EQ(s.lights.size(), 1u);
    EXPECT_EQ(s.lights[0].kind, LightKind::directional);
    EXPECT_NEAR(glm::length(s.lights[0].direction), 1.f, 1e-5f);
    EXPECT_EQ(m.material, 0);
}

TEST(DisplacedSphere, TheSeedChangesTheSurfaceOnly) {
    const SceneDescription a = displaced_sphere(500, 1), b = displaced_sphere(500, 2);
    expect_same_scene(a, displaced_sphere(500));
    expect_same_scene(a, builtin_scene("builtin:displaced_sphere?triangles=500"));
    EXPECT_EQ(a.meshes[0].indices, b.meshes[0].indices);
    ASSERT_EQ(a.meshes[0].positions.size(), b.meshes[0].positions.size());
    size_t moved = 0;
    for (size_t i = 0; i < a.meshes[0].positions.size(); ++i) moved += !same_bits(a.meshes[0].positions[i], b.meshes[0].positions[i]);
    EXPECT_GT(moved, a.meshes[0].positions.size() / 2);
}

// --- the Cornell family ----------------------------------------------------------------------

TEST(CornellBox, WallsLampAndCameraAreWhereTheHeaderSays) {
    const SceneDescription s = cornell_box();
    glm::vec3 lo(INFINITY), hi(-INFINITY);
    for (const MeshDesc& m : s.meshes)
        for (const glm::vec3& p : m.positions) lo = glm::min(lo, p), hi = glm::max(hi, p);
    EXPECT_EQ(lo, glm::vec3(-1.f, 0.f, -1.f));
    EXPECT_EQ(hi, glm::vec3(1.f, 1.5f, 1.f));
    const auto lamps = emitters(s);
    ASSERT_EQ(lamps.size(), 1u);
    const MeshDesc& lamp = *lamps[0];
    float area = 0;
    for (size_t t = 0; t < lamp.indices.size() / 3; ++t) area += 0.5f * glm::length(face_normal(lamp, t));
    EXPECT_NEAR(area, 0.8f * 0.6f, 1e-5f);
    EXPECT_EQ(s.materials[size_t(lamp.material)].emission, glm::vec3(10.f));
    for (const glm::vec3& p : lamp.positions) EXPECT_LT(p.y, 1.5f);
    ASSERT_TRUE(s.camera.has_value());
    EXPECT_GT(s.camera->position.z, 1.f) << "the camera looks in through the open front";
}

// Emitters are one-sided: a lamp wound the wrong way lights the ceiling and leaves the room
// dark. Every face of the box, lamp included, faces the room's middle.
TEST(CornellBox, EveryFaceFacesIntoTheRoom) {
    const SceneDescription s = cornell_box();
    const glm::vec3 middle(0.f, 0.75f, 0.f);
    for (const MeshDesc& m : s.meshes)
        for (size_t t = 0; t < m.indices.size() / 3; ++t)
            EXPECT_GT(glm::dot(face_normal(m, t), middle - centroid(m)), 0.f) << m.name << " triangle " << t;
}

TEST(CornellBox, SpheresRestOnTheFloorAndGlossyMaterialsAreAsStated) {
    const SceneDescription s = cornell_spheres();
    ASSERT_EQ(s.spheres.size(), 2u);
    EXPECT_FLOAT_EQ(s.spheres[0].radius, 0.3f);
    EXPECT_FLOAT_EQ(s.spheres[1].radius, 0.25f);
    for (const SphereDesc& sp : s.spheres) {
        EXPECT_FLOAT_EQ(sp.center.y, sp.radius);
        EXPECT_LE(std::abs(sp.center.x) + sp.radius, 1.f);
        EXPECT_LE(std::abs(sp.center.z) + sp.radius, 1.f);
    }
    const SceneDescription g = cornell_glossy();
    ASSERT_EQ(g.spheres.size(), 2u);
    const MaterialDesc& gold = g.materials[size_t(g.spheres[0].material)];
    const MaterialDesc& plastic = g.materials[size_t(g.spheres[1].material)];
    EXPECT_EQ(gold.kind, MaterialKind::metallic_roughness);
    EXPECT_EQ(gold.metallic, 1.f);
    EXPECT_EQ(gold.roughness, 0.3f);
    EXPECT_EQ(plastic.kind, MaterialKind::metallic_roughness);
    EXPECT_EQ(plastic.metallic, 0.f);
    EXPECT_EQ(plastic.roughness, 0.15f);
}

// --- many lamps ------------------------------------------------------------------------------

// Lamps are squares at y = 1.49 in the x–z plane: two overlap when both extents overlap.
bool overlap(const MeshDesc& a, const MeshDesc& b) {
    auto extent = [](const MeshDesc& m, int axis) {
        float lo = INFINITY, hi = -INFINITY;
        for (const glm::vec3& p : m.positions) lo = std::min(lo, p[axis]), hi = std::max(hi, p[axis]);
        return std::pair(lo, hi);
    };
    const auto [ax0, ax1] = extent(a, 0);
    const auto [bx0, bx1] = extent(b, 0);
    const auto [az0, az1] = extent(a, 2);
    const auto [bz0, bz1] = extent(b, 2);
    return ax0 < bx1 && bx0 < ax1 && az0 < bz1 && bz0 < az1;
}

TEST(ManyLights, CountsReplaceTheBigLampAndFaceDown) {
    for (int n : {1, 2, 5, 16, 17, 100}) {
        const SceneDescription s = many_lights(n);
        const SceneDescription room = cornell_spheres();
        EXPECT_EQ(s.meshes.size(), room.meshes.size() - 1 + size_t(n)) << n;
        EXPECT_EQ(s.spheres.size(), 2u);
        const auto lamps = emitters(s);
        ASSERT_EQ(lamps.size(), size_t(n)) << "the big lamp is gone and every small one emits";
        float lo = INFINITY, hi = 0;
        for (const MeshDesc* m : lamps) {
            const glm::vec3 e = s.materials[size_t(m->material)].emission;
            EXPECT_EQ(e.x, e.y);
            EXPECT_EQ(e.y, e.z);
            lo = std::min(lo, e.x), hi = std::max(hi, e.x);
            for (const glm::vec3& p : m->positions) {
                EXPECT_FLOAT_EQ(p.y, 1.49f);
                EXPECT_LT(std::abs(p.x), 1.f);
                EXPECT_LT(std::abs(p.z), 1.f);
            }
            for (size_t t = 0; t < m->indices.size() / 3; ++t) EXPECT_LT(face_normal(*m, t).y, 0.f) << m->name;
        }
        EXPECT_GE(lo, 1.f);
        EXPECT_LE(hi, 100.f);
        if (n >= 16) { EXPECT_GT(hi / lo, 10.f) << "radiance should span orders of magnitude"; }
    }
}

TEST(ManyLights, SparseLampsAre8cmAndDenseOnesNeverOverlap) {
    const SceneDescription few = many_lights(4);
    for (const MeshDesc* m : emitters(few)) {
        EXPECT_NEAR(glm::length(m->positions[1] - m->positions[0]), 0.08f, 1e-5f);
        EXPECT_NEAR(glm::length(m->positions[3] - m->positions[0]), 0.08f, 1e-5f);
    }
    for (const SceneDescription& s : {many_lights(100), lamp_room()}) {
        const auto lamps = emitters(s);
        int overlapping = 0;
        for (size_t i = 0; i < lamps.size(); ++i)
            for (size_t j = i + 1; j < lamps.size(); ++j) overlapping += overlap(*lamps[i], *lamps[j]);
        EXPECT_EQ(overlapping, 0) << s.source << " with " << lamps.size() << " lamps";
    }
}

TEST(ManyLights, LampRoomIsAThousandLamps) {
    const SceneDescription s = lamp_room();
    EXPECT_EQ(s.source, "builtin:lamp_room");
    EXPECT_EQ(emitters(s).size(), 1000u);
    EXPECT_EQ(emitters(lamp_room(7)).size(), 7u);
    EXPECT_EQ(emitters(builtin_scene("builtin:many_lights")).size(), 32u);
}

TEST(ScatteredLights, SmallTwoSidedSquaresInsideTheRoom) {
    const SceneDescription s = scattered_lights(200);
    const auto lamps = emitters(s);
    ASSERT_EQ(lamps.size(), 200u);
    EXPECT_EQ(emitters(builtin_scene("builtin:scattered_lights")).size(), 1000u);
    for (const MeshDesc* m : lamps) {
        const MaterialDesc& mat = s.materials[size_t(m->material)];
        EXPECT_TRUE(mat.double_sided) << m->name;
        EXPECT_GE(mat.emission.x, 1.f);
        EXPECT_LE(mat.emission.x, 100.f);
        ASSERT_EQ(m->positions.size(), 4u);
        for (int k = 0; k < 4; ++k)
            EXPECT_NEAR(glm::length(m->positions[size_t((k + 1) % 4)] - m->positions[size_t(k)]), 0.03f, 1e-4f) << m->name;
        const glm::vec3 c = centroid(*m);
        EXPECT_LT(std::abs(c.x), 0.91f);
        EXPECT_LT(std::abs(c.z), 0.91f);
        EXPECT_GT(c.y, 0.04f);
        EXPECT_LT(c.y, 1.46f);
    }
}

// "The same lamps either way": with and without blocks, a light hierarchy is measured against
// the same lamps, so occlusion is the only difference.
TEST(LampField, BlocksChangeNothingButTheBlocks) {
    const int n = 50;
    const SceneDescription with = lamp_field(n, true), without = lamp_field(n, false);
    EXPECT_EQ(with.meshes.size(), 1u + 144u * 5u + size_t(n));
    EXPECT_EQ(without.meshes.size(), 1u + size_t(n));
    EXPECT_EQ(emitters(with).size(), size_t(n));
    for (int i = 0; i < n; ++i) {
        const MeshDesc& a = with.meshes[with.meshes.size() - size_t(n) + size_t(i)];
        const MeshDesc& b = without.meshes[without.meshes.size() - size_t(n) + size_t(i)];
        ASSERT_EQ(a.positions.size(), b.positions.size());
        for (size_t k = 0; k < a.positions.size(); ++k) EXPECT_TRUE(same_bits(a.positions[k], b.positions[k])) << "lamp " << i;
        const glm::vec3 c = centroid(a);
        EXPECT_LE(std::abs(c.x), 20.f);
        EXPECT_LE(std::abs(c.z), 20.f);
        EXPECT_GE(c.y, 0.2f);
        EXPECT_LE(c.y, 3.2f);
    }
}

// --- furnaces --------------------------------------------------------------------------------

TEST(Furnace, BoxIsAClosedCubeAroundItsCamera) {
    const glm::vec3 center(1.f, -2.f, 3.f);
    const SceneDescription s = furnace_box(0.25f, 2.f, 0.5f, center);
    ASSERT_EQ(s.meshes.size(), 1u);
    const MeshDesc& m = s.meshes[0];
    EXPECT_EQ(m.indices.size(), 36u);
    expect_closed_and_consistent(m);
    MeshDesc at_origin = m;
    for (glm::vec3& p : at_origin.positions) p -= center;
    EXPECT_NEAR(std::abs(signed_volume(at_origin)), 1.0, 1e-5);
    const MaterialDesc& mat = s.materials[0];
    EXPECT_EQ(mat.albedo, glm::vec3(0.25f));
    EXPECT_EQ(mat.emission, glm::vec3(2.f));
    EXPECT_TRUE(mat.double_sided) << "seen from inside";
    ASSERT_TRUE(s.camera.has_value());
    EXPECT_EQ(s.camera->position, center);
    // The built-in furnace: albedo 0.5, emission 1.
    const SceneDescription b = builtin_scene("builtin:furnace");
    EXPECT_EQ(b.materials[0].albedo, glm::vec3(0.5f));
    EXPECT_EQ(b.materials[0].emission, glm::vec3(1.f));
    EXPECT_EQ(furnace_box(0.5f, 0.f).materials[0].kind, MaterialKind::diffuse);
}

TEST(Furnace, SphereIsClosedOnItsRadiusAndAlignedWithNoAxis) {
    const glm::vec3 center(0.5f, 1.f, -2.f);
    const float radius = 2.f;
    const SceneDescription s = furnace_sphere(0.5f, 1.f, radius, center, 4);
    const MeshDesc& m = s.meshes[0];
    EXPECT_EQ(m.indices.size() / 3, 8u * 4 * 4);
    EXPECT_EQ(m.positions.size(), 4u * 4 * 4 + 2);
    expect_closed_and_consistent(m);
    for (const glm::vec3& p : m.positions) EXPECT_NEAR(glm::length(p - center), radius, 1e-5f * radius);
    MeshDesc at_origin = m;
    for (glm::vec3& p : at_origin.positions) p -= center;
    const double sphere = 4.0 / 3.0 * std::numbers::pi * radius * radius * radius, v = signed_volume(at_origin);
    EXPECT_GT(v, 0.85 * sphere) << "inscribed and wound outward";
    EXPECT_LT(v, sphere);
    for (size_t t = 0; t < m.indices.size() / 3; ++t) {
        const glm::vec3 n = glm::normalize(face_normal(m, t));
        EXPECT_LT(std::max({std::abs(n.x), std::abs(n.y), std::abs(n.z)}), 1.f - 1e-5f) << "face " << t << " is axis-aligned";
    }
    EXPECT_EQ(s.camera->position, center);
    EXPECT_EQ(furnace_sphere(0.5f, 1.f, 1.f, glm::vec3(0.f), 0).meshes[0].indices.size(), 8u * 3);
}

// --- determinism -----------------------------------------------------------------------------

TEST(Builtins, EveryCallBuildsTheSameScene) {
    for (const char* name : kPlainNames) {
        SCOPED_TRACE(name);
        expect_same_scene(builtin_scene(name), builtin_scene(name));
    }
    expect_same_scene(scattered_lights(50), scattered_lights(50));
    expect_same_scene(lamp_field(30, true), lamp_field(30, true));
}

// --- the sky ---------------------------------------------------------------------------------

TEST(Sky, SunAt35DegreesOverABlueSkyAndGreyGround) {
    const int w = 256, h = 128;
    const std::vector<float> rgb = sky_environment(w, h);
    ASSERT_EQ(rgb.size(), size_t(w) * h * 3);
    int sun = 0;
    float brightest_sky = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const float* px = &rgb[(size_t(y) * w + x) * 3];
            const glm::vec3 d = environment_direction((float(x) + 0.5f) / float(w), (float(y) + 0.5f) / float(h));
            if (px[0] > 1000.f) {
                ++sun;
                // A texel is sun when its centre is within 2 degrees of the sun, so is its elevation.
                const float elevation = glm::degrees(std::asin(std::clamp(d.y, -1.f, 1.f)));
                EXPECT_NEAR(elevation, 35.f, 2.01f) << x << ", " << y;
            } else if (d.y > 0.f) {
                EXPECT_GT(px[2], px[0]) << "sky is blue at " << x << ", " << y;
                brightest_sky = std::max(brightest_sky, px[2]);
            } else {
                EXPECT_EQ(px[0], 0.25f);
                EXPECT_EQ(px[1], 0.23f);
                EXPECT_EQ(px[2], 0.2f);
            }
        }
    EXPECT_GT(sun, 0);
    EXPECT_LT(sun, 40) << "a 2-degree sun covers a few texels";
    EXPECT_GE(10000.f / brightest_sky, 5000.f);
}

TEST(Procedural, ADisplacedSphereIsHeldToATriangleBoundBeforeItIsBuilt) {
    // What it would build (8k² ≥ N), not only what was asked: 100,000 asked builds 100,352.
    EXPECT_NO_THROW(check_builtin_name("builtin:displaced_sphere?triangles=100000", 100'352));
    EXPECT_THROW(check_builtin_name("builtin:displaced_sphere?triangles=100000", 100'351), SceneError);
    EXPECT_NO_THROW(check_builtin_name("builtin:cornell_box", 1));  // fixed scenes are small
    LoadLimits limits;
    limits.max_triangles = 1000;
    try {
        load_scene("builtin:displaced_sphere?triangles=20000000", limits);
        ADD_FAILURE() << "20 million triangles were built past a bound of 1000";
    } catch (const SceneError& e) {
        EXPECT_NE(std::string(e.what()).find("over the limit of 1000"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace tessera
