#include "build_paths.h"
#include "engine/io/collada_loader.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <string>

#include <set>

#include <gtest/gtest.h>

#include "tests/test_paths.h"

namespace tessera {
namespace {

namespace fs = std::filesystem;

// ---- helpers ---------------------------------------------------------------------------------

// A minimal scene: `up` axis, library contents, and the visual scene's nodes.
std::string doc(const std::string& libraries, const std::string& nodes, const std::string& up = "Y_UP") {
    std::string asset = up.empty() ? "" : "<asset><up_axis>" + up + "</up_axis></asset>\n";
    return "<?xml version=\"1.0\"?>\n<COLLADA version=\"1.4.1\">\n" + asset + libraries +
           "\n<library_visual_scenes><visual_scene id=\"S\">\n" + nodes +
           "\n</visual_scene></library_visual_scenes>\n<scene><instance_visual_scene url=\"#S\"/></scene>\n</COLLADA>\n";
}

// A geometry "g" with the given positions and one primitive element (e.g. a <polylist>).
std::string geometry(const std::string& positions, int count, const std::string& primitive) {
    return "<library_geometries><geometry id=\"g\" name=\"g\"><mesh>\n"
           "<source id=\"pos\"><float_array id=\"pos-a\" count=\"" + std::to_string(count * 3) + "\">" + positions +
           "</float_array>\n<technique_common><accessor source=\"#pos-a\" count=\"" + std::to_string(count) +
           "\" stride=\"3\"/></technique_common></source>\n"
           "<source id=\"nrm\"><float_array id=\"nrm-a\" count=\"3\">0 0 1</float_array>"
           "<technique_common><accessor source=\"#nrm-a\" count=\"1\" stride=\"3\"/></technique_common></source>\n"
           "<vertices id=\"v\"><input semantic=\"POSITION\" source=\"#pos\"/></vertices>\n" + primitive +
           "\n</mesh></geometry></library_geometries>\n";
}

const std::string kTriangle = "1 2 3  4 5 6  7 8 9";
const std::string kTrianglePolylist =
    "<polylist count=\"1\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/><vcount>3</vcount><p>0 1 2</p></polylist>";

std::string node(const std::string& transforms, const std::string& body = "<instance_geometry url=\"#g\"/>") {
    return "<node id=\"n\" name=\"n\">" + transforms + body + "</node>";
}

void expect_vec(const glm::vec3& v, float x, float y, float z, float eps = 1e-4f) {
    EXPECT_NEAR(v.x, x, eps);
    EXPECT_NEAR(v.y, y, eps);
    EXPECT_NEAR(v.z, z, eps);
}

bool any_warning(const SceneDescription& s, const std::string& needle) {
    return std::any_of(s.warnings.begin(), s.warnings.end(),
                       [&](const std::string& w) { return w.find(needle) != std::string::npos; });
}

// The error message of parsing `xml`, which must fail with a SceneError.
std::string error_of(const std::string& xml, const LoadLimits& limits = {}) {
    try {
        parse_collada(xml, "inline.dae", limits);
    } catch (const SceneError& e) {
        return e.what();
    }
    ADD_FAILURE() << "parse_collada accepted the input";
    return {};
}

// ---- axes and transforms ---------------------------------------------------------------------

TEST(ColladaLoader, YUpIsIdentity) {
    auto s = parse_collada(doc(geometry(kTriangle, 3, kTrianglePolylist), node("")), "t.dae");
    ASSERT_EQ(s.meshes.size(), 1u);
    expect_vec(s.meshes[0].positions[0], 1, 2, 3);
    EXPECT_TRUE(s.warnings.empty());
}

TEST(ColladaLoader, ZUpMapsToYUp) {
    auto s = parse_collada(doc(geometry(kTriangle, 3, kTrianglePolylist), node(""), "Z_UP"), "t.dae");
    expect_vec(s.meshes[0].positions[0], -1, 3, 2);  // (x, y, z) -> (-x, z, y)
    expect_vec(s.meshes[0].positions[2], -7, 9, 8);
}

TEST(ColladaLoader, XUpMapsToYUp) {
    auto s = parse_collada(doc(geometry(kTriangle, 3, kTrianglePolylist), node(""), "X_UP"), "t.dae");
    expect_vec(s.meshes[0].positions[0], 2, 1, -3);  // swap x and y, negate z
}

TEST(ColladaLoader, MissingUpAxisAssumesYUpWithWarning) {
    auto s = parse_collada(doc(geometry(kTriangle, 3, kTrianglePolylist), node(""), ""), "t.dae");
    expect_vec(s.meshes[0].positions[0], 1, 2, 3);
    EXPECT_TRUE(any_warning(s, "up_axis"));
}

TEST(ColladaLoader, MatrixIsRowMajor) {
    auto s = parse_collada(
        doc(geometry(kTriangle, 3, kTrianglePolylist), node("<matrix>1 0 0 10 0 1 0 20 0 0 1 30 0 0 0 1</matrix>")), "t.dae");
    expect_vec(s.meshes[0].positions[0], 11, 22, 33);
}

TEST(ColladaLoader, TranslateRotateScaleApplyInDocumentOrder) {
    // p' = T * R * S * p: (1,0,0) -> scale 2 -> (2,0,0) -> 90 deg about z -> (0,2,0) -> +(1,0,0).
    auto s = parse_collada(doc(geometry("1 0 0  0 1 0  0 0 1", 3, kTrianglePolylist),
                               node("<translate>1 0 0</translate><rotate>0 0 1 90</rotate><scale>2 2 2</scale>")),
                           "t.dae");
    expect_vec(s.meshes[0].positions[0], 1, 2, 0);
    expect_vec(s.meshes[0].positions[1], -1, 0, 0);
    expect_vec(s.meshes[0].positions[2], 1, 0, 2);
}

TEST(ColladaLoader, NestedNodeTransformsMultiply) {
    std::string nodes = "<node><translate>0 10 0</translate><node><scale>3 3 3</scale>"
                        "<instance_geometry url=\"#g\"/></node></node>";
    auto s = parse_collada(doc(geometry(kTriangle, 3, kTrianglePolylist), nodes), "t.dae");
    expect_vec(s.meshes[0].positions[0], 3, 16, 9);
}

TEST(ColladaLoader, NodeDepthIsLimited) {
    auto nested = [](int depth) {
        std::string open, close;
        for (int i = 0; i < depth; ++i) open += "<node>", close += "</node>";
        return open + "<instance_geometry url=\"#g\"/>" + close;
    };
    LoadLimits limits;
    limits.max_node_depth = 10;
    const std::string lib = geometry(kTriangle, 3, kTrianglePolylist);
    EXPECT_EQ(parse_collada(doc(lib, nested(10)), "t.dae", limits).meshes.size(), 1u);
    EXPECT_NE(error_of(doc(lib, nested(11)), limits).find("deeper than 10"), std::string::npos);
}

TEST(ColladaLoader, HostileNestingIsRejectedWithoutCrashing) {
    std::string open, close;
    for (int i = 0; i < 100000; ++i) open += "<node>", close += "</node>";
    std::string msg = error_of(doc("", open + close));
    EXPECT_NE(msg.find("inline.dae:"), std::string::npos) << msg;
    EXPECT_NE(msg.find("deeper than"), std::string::npos) << msg;
}

// ---- primitives ------------------------------------------------------------------------------

TEST(ColladaLoader, TrianglesWithSeveralInputs) {
    std::string tris = "<triangles count=\"2\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/>"
                       "<input semantic=\"NORMAL\" source=\"#nrm\" offset=\"1\"/><p>0 0 1 0 2 0  2 0 3 0 0 0</p></triangles>";
    auto s = parse_collada(doc(geometry("0 0 0 1 0 0 1 1 0 0 1 0", 4, tris), node("")), "t.dae");
    ASSERT_EQ(s.meshes.size(), 1u);
    EXPECT_EQ(s.meshes[0].indices, (std::vector<uint32_t>{0, 1, 2, 2, 3, 0}));
    EXPECT_TRUE(s.meshes[0].normals.empty());  // the renderer recomputes them, as CS184 does
}

TEST(ColladaLoader, PolylistPolygonsAreFanTriangulated) {
    std::string poly = "<polylist count=\"2\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/>"
                       "<vcount>5 3</vcount><p>0 1 2 3 4  4 3 2</p></polylist>";
    auto s = parse_collada(doc(geometry("0 0 0 1 0 0 2 1 0 1 2 0 0 1 0", 5, poly), node("")), "t.dae");
    EXPECT_EQ(s.meshes[0].indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 0, 3, 4, 4, 3, 2}));
    EXPECT_EQ(s.triangle_count(), 4u);
}

TEST(ColladaLoader, PolygonsElementIsFanTriangulated) {
    std::string poly = "<polygons count=\"2\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/>"
                       "<p>0 1 2 3</p><p>1 2 3</p></polygons>";
    auto s = parse_collada(doc(geometry("0 0 0 1 0 0 1 1 0 0 1 0", 4, poly), node("")), "t.dae");
    EXPECT_EQ(s.meshes[0].indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 1, 2, 3}));
}

TEST(ColladaLoader, AccessorOffsetAndStrideAreHonoured) {
    std::string lib =
        "<library_geometries><geometry id=\"g\"><mesh><source id=\"pos\">"
        "<float_array id=\"a\" count=\"13\">99 1 2 3 -1 4 5 6 -1 7 8 9 -1</float_array>"
        "<technique_common><accessor source=\"#a\" count=\"3\" offset=\"1\" stride=\"4\"/></technique_common></source>"
        "<vertices id=\"v\"><input semantic=\"POSITION\" source=\"#pos\"/></vertices>" + kTrianglePolylist +
        "</mesh></geometry></library_geometries>";
    auto s = parse_collada(doc(lib, node("")), "t.dae");
    expect_vec(s.meshes[0].positions[1], 4, 5, 6);
}

TEST(ColladaLoader, SharedGeometryIsInstancedPerNode) {
    std::string nodes = node("<translate>0 0 0</translate>") + node("<translate>100 0 0</translate>");
    auto s = parse_collada(doc(geometry(kTriangle, 3, kTrianglePolylist), nodes), "t.dae");
    ASSERT_EQ(s.meshes.size(), 2u);
    expect_vec(s.meshes[1].positions[0], 101, 2, 3);
}

TEST(ColladaLoader, TriangleLimitIsCheckedBeforeBuilding) {
    LoadLimits limits;
    limits.max_triangles = 1;
    std::string poly = "<polylist count=\"2\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/>"
                       "<vcount>3 3</vcount><p>0 1 2 0 1 2</p></polylist>";
    EXPECT_NE(error_of(doc(geometry(kTriangle, 3, poly), node("")), limits).find("triangle limit"), std::string::npos);
}

TEST(ColladaLoader, BadTokenNamesItsOwnLine) {
    std::string lib = geometry("1 2 3\n4 5 6\n7 nan 9", 3, kTrianglePolylist);
    std::string xml = doc(lib, node(""));
    int line = 1 + static_cast<int>(std::count(xml.begin(), xml.begin() + xml.find("7 nan"), '\n'));
    EXPECT_NE(error_of(xml).find("inline.dae:" + std::to_string(line) + ":"), std::string::npos);
}

// ---- materials -------------------------------------------------------------------------------

std::string material_lib(const std::string& effect_body) {
    return "<library_effects><effect id=\"e\">" + effect_body + "</effect></library_effects>"
           "<library_materials><material id=\"m\" name=\"shiny\"><instance_effect url=\"#e\"/></material></library_materials>";
}

std::string bound_node() {
    return node("", "<instance_geometry url=\"#g\"><bind_material><technique_common>"
                    "<instance_material symbol=\"x\" target=\"#m\"/></technique_common></bind_material></instance_geometry>");
}

SceneDescription with_effect(const std::string& effect_body) {
    return parse_collada(doc(material_lib(effect_body) + geometry(kTriangle, 3, kTrianglePolylist), bound_node()), "t.dae");
}

TEST(ColladaLoader, LambertianColourFromProfileCommon) {
    auto s = with_effect("<profile_COMMON><technique sid=\"c\"><lambert><diffuse><color>0.1 0.2 0.3 1</color></diffuse>"
                         "</lambert></technique></profile_COMMON>");
    ASSERT_EQ(s.materials.size(), 1u);
    EXPECT_EQ(s.meshes[0].material, 0);
    EXPECT_EQ(s.materials[0].kind, MaterialKind::diffuse);
    EXPECT_EQ(s.materials[0].name, "shiny");
    expect_vec(s.materials[0].albedo, 0.1f, 0.2f, 0.3f);
    EXPECT_GT(s.materials[0].origin.line, 0);
}

TEST(ColladaLoader, MissingColourIsGreyAndUnboundGeometryIsDefault) {
    auto s = with_effect("<profile_COMMON><technique sid=\"c\"><phong/></technique></profile_COMMON>");
    expect_vec(s.materials[0].albedo, 0.5f, 0.5f, 0.5f);
    auto u = parse_collada(doc(geometry(kTriangle, 3, kTrianglePolylist), node("")), "t.dae");
    EXPECT_EQ(u.meshes[0].material, -1);
}

TEST(ColladaLoader, CglEmission) {
    auto s = with_effect("<extra><technique profile=\"CGL\"><emission><radiance>10 9 8</radiance></emission></technique></extra>");
    EXPECT_EQ(s.materials[0].kind, MaterialKind::emission);
    expect_vec(s.materials[0].emission, 10, 9, 8);
    expect_vec(s.materials[0].albedo, 0, 0, 0);
    EXPECT_TRUE(s.warnings.empty());
}

TEST(ColladaLoader, LastRecognisedCglChildDecides) {
    auto s = with_effect("<extra><technique profile=\"CGL\"><mirror><reflectance>1 1 1</reflectance></mirror>"
                         "<glass><reflectance>0.9 0.9 0.9</reflectance><transmittance>0.8 0.7 0.6</transmittance>"
                         "<roughness>0.1</roughness><ior>1.45</ior></glass><sparkle/></technique></extra>");
    const MaterialDesc& m = s.materials[0];
    EXPECT_EQ(m.kind, MaterialKind::glass);
    expect_vec(m.albedo, 0.9f, 0.9f, 0.9f);
    expect_vec(m.transmittance, 0.8f, 0.7f, 0.6f);
    EXPECT_FLOAT_EQ(m.roughness, 0.1f);
    EXPECT_FLOAT_EQ(m.ior, 1.45f);
    EXPECT_FALSE(any_warning(s, "rendered as diffuse"));
    EXPECT_TRUE(any_warning(s, "<sparkle>"));
}

TEST(ColladaLoader, CglMicrofacetAndGlossyAndRefraction) {
    auto s = with_effect("<extra><technique profile=\"CGL\"><microfacet><alpha>0.25</alpha><eta>0.1 0.2 0.3</eta>"
                         "<k>4 3 2</k></microfacet></technique></extra>");
    EXPECT_EQ(s.materials[0].kind, MaterialKind::microfacet);
    EXPECT_FLOAT_EQ(s.materials[0].roughness, 0.25f);
    expect_vec(s.materials[0].eta, 0.1f, 0.2f, 0.3f);
    expect_vec(s.materials[0].k, 4, 3, 2);
    auto g = with_effect("<extra><technique profile=\"CGL\"><glossy><reflectance>0.5 0.5 0.5</reflectance>"
                         "<shininess>50</shininess></glossy></technique></extra>");
    EXPECT_EQ(g.materials[0].kind, MaterialKind::glossy);
    EXPECT_FLOAT_EQ(g.materials[0].shininess, 50.0f);
    auto r = with_effect("<extra><technique profile=\"CGL\"><refraction><transmittance>1 1 1</transmittance>"
                         "<roughness>0</roughness><ior>1.33</ior></refraction></technique></extra>");
    EXPECT_EQ(r.materials[0].kind, MaterialKind::glass);
    EXPECT_FLOAT_EQ(r.materials[0].ior, 1.33f);
}

// ---- lights, spheres, camera -----------------------------------------------------------------

std::string light_lib(const std::string& body) {
    return "<library_lights><light id=\"l\" name=\"lamp\">" + body + "</light></library_lights>";
}

TEST(ColladaLoader, CglLightTechniqueWinsAndAreaFrameFollowsTransform) {
    std::string lib = light_lib("<technique_common><point><color>1 1 1</color></point></technique_common>"
                                "<extra><technique profile=\"CGL\"><area><color>10 10 10</color></area></technique></extra>");
    auto s = parse_collada(
        doc(lib, node("<matrix>0.6 0 0 0 0 0.8 0 0 0 0 1 1.49 0 0 0 1</matrix>", "<instance_light url=\"#l\"/>"), "Z_UP"),
        "t.dae");
    ASSERT_EQ(s.lights.size(), 1u);
    const LightDesc& l = s.lights[0];
    EXPECT_EQ(l.kind, LightKind::area);
    expect_vec(l.radiance, 10, 10, 10);
    expect_vec(l.position, 0, 1.49f, 0);
    expect_vec(l.direction, 0, -1, 0);
    expect_vec(l.dim_x, 0.6f, 0, 0);
    expect_vec(l.dim_y, 0, 0, 0.8f);
}

TEST(ColladaLoader, DirectionalPointAndAmbientLights) {
    std::string lib = "<library_lights>"
                      "<light id=\"d\"><technique_common><directional><color>1 2 3</color></directional></technique_common></light>"
                      "<light id=\"p\"><technique_common><point><color>4 4 4</color><quadratic_attenuation>0.1"
                      "</quadratic_attenuation></point></technique_common></light>"
                      "<light id=\"a\"><technique_common><ambient><color>0.5 0.5 0.5</color></ambient></technique_common></light>"
                      "</library_lights>";
    std::string nodes = node("<rotate>1 0 0 -90</rotate>", "<instance_light url=\"#d\"/>") +
                        node("<translate>1 2 3</translate>", "<instance_light url=\"#p\"/>") +
                        node("", "<instance_light url=\"#a\"/>");
    auto s = parse_collada(doc(lib, nodes), "t.dae");
    ASSERT_EQ(s.lights.size(), 3u);
    EXPECT_EQ(s.lights[0].kind, LightKind::directional);
    expect_vec(s.lights[0].direction, 0, -1, 0);  // -z rotated -90 deg about x points down
    EXPECT_EQ(s.lights[1].kind, LightKind::point);
    expect_vec(s.lights[1].position, 1, 2, 3);
    expect_vec(s.lights[1].radiance, 4, 4, 4);
    EXPECT_EQ(s.lights[2].kind, LightKind::ambient);
}

TEST(ColladaLoader, SphereCentreAndRadiusFollowTransform) {
    std::string lib = "<library_geometries><geometry id=\"s\"><extra><technique profile=\"CGL\"><sphere><radius>.3</radius>"
                      "</sphere></technique></extra></geometry></library_geometries>";
    auto s = parse_collada(doc(lib, node("<translate>1 2 3</translate><scale>2 2 2</scale>", "<instance_geometry url=\"#s\"/>")),
                           "t.dae");
    ASSERT_EQ(s.spheres.size(), 1u);
    expect_vec(s.spheres[0].center, 1, 2, 3);
    EXPECT_NEAR(s.spheres[0].radius, 0.6f, 1e-6f);
    EXPECT_EQ(s.spheres[0].material, -1);
}

TEST(ColladaLoader, CameraFitsTo800x600) {
    std::string lib = "<library_cameras><camera id=\"c\"><optics><technique_common><perspective><xfov>60</xfov>"
                      "<yfov>30</yfov><znear>0.5</znear><zfar>50</zfar></perspective></technique_common></optics></camera>"
                      "</library_cameras>";
    auto s = parse_collada(doc(lib, node("<translate>0 0 5</translate>", "<instance_camera url=\"#c\"/>")), "t.dae");
    ASSERT_TRUE(s.camera.has_value());
    const CameraDesc& c = *s.camera;
    // tan(30)/tan(15) = 2.15 > 4/3, so the vertical fov widens to fit 800 px across 60 degrees.
    const double v = 2 * std::atan(std::tan(glm::radians(30.0)) / (4.0 / 3.0));
    EXPECT_NEAR(c.hfov_deg, 60.0, 1e-4);
    EXPECT_NEAR(c.vfov_deg, glm::degrees(v), 1e-4);
    EXPECT_NEAR(c.focal_px, 300.0 / std::tan(v / 2), 1e-2);
    EXPECT_FLOAT_EQ(c.znear, 0.5f);
    EXPECT_FLOAT_EQ(c.zfar, 50.0f);
    expect_vec(c.position, 0, 0, 5);
    expect_vec(c.look_at, 0, 0, 4);
    ASSERT_TRUE(c.cs184_orbit_dir.has_value());
    expect_vec(*c.cs184_orbit_dir, 0, 0, 1);  // the point (0,0,4), normalised
}

TEST(ColladaLoader, NoCameraLeavesItEmpty) {
    auto s = parse_collada(doc(geometry(kTriangle, 3, kTrianglePolylist), node("")), "t.dae");
    EXPECT_FALSE(s.camera.has_value());
}

TEST(ColladaLoader, MissingFileIsASceneError) {
    EXPECT_THROW(load_collada("/nonexistent/scene.dae"), SceneError);
}

// ---- the broken corpus -----------------------------------------------------------------------

// True when `msg` holds ":<digits>: ", the file:line prefix of a SceneError.
bool has_line_number(const std::string& msg) {
    for (size_t i = msg.find(':'); i != std::string::npos; i = msg.find(':', i + 1)) {
        size_t j = i + 1;
        while (j < msg.size() && std::isdigit(static_cast<unsigned char>(msg[j]))) ++j;
        if (j > i + 1 && msg.compare(j, 2, ": ") == 0) return true;
    }
    return false;
}

TEST(ColladaLoader, EveryCorpusFileFailsWithFileAndLine) {
    const fs::path dir = fs::path(TESSERA_CORPUS_DIR) / "collada";
    ASSERT_TRUE(fs::is_directory(dir)) << dir;
    int files = 0;
    for (const auto& entry : fs::directory_iterator(dir)) {
        if (entry.path().extension() != ".dae") continue;
        ++files;
        const std::string name = entry.path().filename().string();
        try {
            load_collada(entry.path().string());
            ADD_FAILURE() << name << " loaded without an error";
        } catch (const SceneError& e) {
            const std::string msg = e.what();
            EXPECT_NE(msg.find(name), std::string::npos) << msg;
            EXPECT_TRUE(has_line_number(msg)) << name << ": " << msg;
            EXPECT_GT(e.where().line, 0) << msg;
        } catch (const std::exception& e) {
            ADD_FAILURE() << name << " threw a non-SceneError: " << e.what();
        }
    }
    EXPECT_GE(files, 15);
}

// ---- the shared CS184 scenes -----------------------------------------------------------------

float min_coord(const SceneDescription& s, int axis) {
    float v = INFINITY;
    for (const auto& m : s.meshes)
        for (const auto& p : m.positions) v = std::min(v, p[axis]);
    return v;
}
float max_coord(const SceneDescription& s, int axis) {
    float v = -INFINITY;
    for (const auto& m : s.meshes)
        for (const auto& p : m.positions) v = std::max(v, p[axis]);
    return v;
}

TEST(ColladaLoaderCS184, CBspheresLambertian) {
    TESSERA_REQUIRE_CS184(dir);
    auto s = load_collada(dir + "/sky/CBspheres_lambertian.dae");
    EXPECT_EQ(s.triangle_count(), 12u);
    ASSERT_EQ(s.spheres.size(), 2u);
    for (const auto& sp : s.spheres) {
        EXPECT_NEAR(sp.radius, 0.3f, 1e-5f);
        EXPECT_NEAR(sp.center.y, 0.3f, 1e-5f);  // resting on the floor
        EXPECT_GT(sp.origin.line, 0);
    }
    // The box: x in [-1, 1], floor y = 0, ceiling y = 1.5, back wall z = -1.
    EXPECT_NEAR(min_coord(s, 0), -1.0f, 1e-3f);
    EXPECT_NEAR(max_coord(s, 0), 1.0f, 1e-3f);
    EXPECT_NEAR(min_coord(s, 1), 0.0f, 1e-3f);
    EXPECT_NEAR(max_coord(s, 1), 1.5f, 1e-3f);
    EXPECT_NEAR(min_coord(s, 2), -1.0f, 1e-2f);
    // The area light: 0.6 x 0.8 at y = 1.49, emitting downwards.
    ASSERT_EQ(s.lights.size(), 1u);
    const LightDesc& l = s.lights[0];
    EXPECT_EQ(l.kind, LightKind::area);
    EXPECT_NEAR(l.position.y, 1.49f, 1e-3f);
    EXPECT_NEAR(l.direction.y, -1.0f, 1e-4f);
    EXPECT_NEAR(glm::length(l.dim_x) * glm::length(l.dim_y), 0.48f, 1e-4f);
    EXPECT_NEAR(std::min(glm::length(l.dim_x), glm::length(l.dim_y)), 0.6f, 1e-4f);
    expect_vec(l.radiance, 10, 10, 10);
    // The emissive quad.
    auto emissive = std::find_if(s.materials.begin(), s.materials.end(),
                                 [](const MaterialDesc& m) { return m.kind == MaterialKind::emission; });
    ASSERT_NE(emissive, s.materials.end());
    expect_vec(emissive->emission, 10, 10, 10);
    // Camera: xfov 49.13434 at aspect 4:3 fits 800x600 exactly; focal = 300 / tan(vfov / 2).
    ASSERT_TRUE(s.camera.has_value());
    const double v = 2 * std::atan(std::tan(glm::radians(49.13434 / 2)) / 1.333333);
    const double focal = 300.0 / std::tan(v / 2);
    EXPECT_NEAR(focal, 875.0, 1.0);
    EXPECT_NEAR(s.camera->focal_px, focal, focal * 0.01);
    ASSERT_TRUE(s.camera->cs184_orbit_dir.has_value());
    expect_vec(*s.camera->cs184_orbit_dir, 0, 0, 1);
    EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
}

// Its spheres are a mirror and glass, rendered as such: no warning.
TEST(ColladaLoaderCS184, CBspheresReadsGlassAndMirror) {
    TESSERA_REQUIRE_CS184(dir);
    auto s = load_collada(dir + "/sky/CBspheres.dae");
    ASSERT_EQ(s.spheres.size(), 2u);
    std::set<MaterialKind> kinds;
    for (const SphereDesc& sp : s.spheres) kinds.insert(s.materials[size_t(sp.material)].kind);
    EXPECT_EQ(kinds, (std::set<MaterialKind>{MaterialKind::mirror, MaterialKind::glass}));
    EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
}

TEST(ColladaLoaderCS184, CowHasDirectionalLight) {
    TESSERA_REQUIRE_CS184(dir);
    auto s = load_collada(dir + "/meshedit/cow.dae");
    EXPECT_EQ(s.triangle_count(), 5856u);
    ASSERT_EQ(s.lights.size(), 1u);
    EXPECT_EQ(s.lights[0].kind, LightKind::directional);
    EXPECT_NEAR(glm::length(s.lights[0].direction), 1.0f, 1e-5f);
}

TEST(ColladaLoaderCS184, LargeMeshes) {
    TESSERA_REQUIRE_CS184(dir);
    EXPECT_EQ(load_collada(dir + "/sky/CBbunny.dae").triangle_count(), 28588u);
    EXPECT_EQ(load_collada(dir + "/meshedit/maxplanck.dae").triangle_count(), 50801u);
}

TEST(ColladaLoaderCS184, CBgemsShortCameraMatrixIsReadAsCS184Does) {
    TESSERA_REQUIRE_CS184(dir);
    // Its camera <matrix> has 15 numbers; CS184 reads the missing one as 0 and renders the file.
    auto s = load_collada(dir + "/sky/CBgems.dae");
    EXPECT_EQ(s.triangle_count(), 252u);
    EXPECT_TRUE(any_warning(s, "15 numbers"));
    ASSERT_TRUE(s.camera.has_value());
    expect_vec(*s.camera->cs184_orbit_dir, 0, 0, 1);
}

TEST(ColladaLoaderCS184, BasicScenesReadTheCMU462Profile) {
    TESSERA_REQUIRE_CS184(dir);
    auto s = load_collada(dir + "/basic/sphere7_mirror.dae");
    EXPECT_EQ(s.spheres.size(), 7u);
    EXPECT_TRUE(any_warning(s, "CMU462"));
    EXPECT_FALSE(any_warning(s, "rendered as diffuse"));
    EXPECT_EQ(s.materials[size_t(s.spheres[0].material)].kind, MaterialKind::mirror);
}

TEST(ColladaLoaderCS184, EverySharedFileLoads) {
    TESSERA_REQUIRE_CS184(dir);
    // Every file of the shared folder, basic/ included, is supported: none may throw.
    int files = 0;
    for (const auto& entry : fs::recursive_directory_iterator(dir)) {
        if (entry.path().extension() != ".dae") continue;
        ++files;
        SCOPED_TRACE(entry.path().string());
        SceneDescription s;
        EXPECT_NO_THROW(s = load_collada(entry.path().string()));
        EXPECT_GT(s.triangle_count() + s.spheres.size(), 0u);
        EXPECT_FALSE(s.lights.empty());
        EXPECT_TRUE(s.camera.has_value());
        for (const auto& m : s.meshes) EXPECT_GT(m.origin.line, 0);
    }
    EXPECT_GE(files, 40);
}

}  // namespace
}  // namespace tessera
