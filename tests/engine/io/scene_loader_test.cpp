// load_scene: dispatch by extension in any case (not by content), built-in names before the
// file system, a missing file or an unknown extension refused with a SceneError that names the
// path and says why, the file-size bound of LoadLimits taken exactly at the limit and refused one
// byte over, and the caller's limits handed on to the loader it picks.
#include "build_paths.h"
#include "engine/io/scene_loader.h"

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "engine/scene/procedural.h"

namespace tessera {
namespace {

namespace fs = std::filesystem;

// One triangle, as the CS184 files write geometry.
const std::string kCollada = R"(<?xml version="1.0"?>
<COLLADA version="1.4.1">
<asset><up_axis>Y_UP</up_axis></asset>
<library_geometries><geometry id="g" name="g"><mesh>
<source id="pos"><float_array id="pos-a" count="9">0 0 0 1 0 0 0 1 0</float_array>
<technique_common><accessor source="#pos-a" count="3" stride="3"/></technique_common></source>
<vertices id="v"><input semantic="POSITION" source="#pos"/></vertices>
<polylist count="1"><input semantic="VERTEX" source="#v" offset="0"/><vcount>3</vcount><p>0 1 2</p></polylist>
</mesh></geometry></library_geometries>
<library_visual_scenes><visual_scene id="S"><node id="n" name="n"><instance_geometry url="#g"/></node>
</visual_scene></library_visual_scenes>
<scene><instance_visual_scene url="#S"/></scene>
</COLLADA>
)";

// A glTF with no geometry: it loads, with the loader's own warning about that.
const std::string kGltf = R"({"asset":{"version":"2.0"},"extras":[[[1]]]})";

std::string glb_of(std::string json) {
    json.resize((json.size() + 3) / 4 * 4, ' ');
    auto u32 = [](uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
    return "glTF" + u32(2) + u32(uint32_t(12 + 8 + json.size())) + u32(uint32_t(json.size())) + u32(0x4E4F534A) + json;
}

bool has_warning(const SceneDescription& s, const std::string& text) {
    for (const std::string& w : s.warnings)
        if (w.find(text) != std::string::npos) return true;
    return false;
}

class SceneLoader : public ::testing::Test {
protected:
    void SetUp() override {
        std::string tmpl = (fs::temp_directory_path() / "tessera_scene_loader_XXXXXX").string();
        ASSERT_NE(::mkdtemp(tmpl.data()), nullptr);
        dir_ = tmpl;
    }
    void TearDown() override {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    std::string write(const std::string& name, const std::string& bytes) const {
        const fs::path p = dir_ / name;
        std::ofstream(p, std::ios::binary) << bytes;
        return p.string();
    }
    // The SceneError of loading `path`, which must fail.
    SceneError error_of(const std::string& path, const LoadLimits& limits = {}) const {
        try {
            load_scene(path, limits);
        } catch (const SceneError& e) {
            return e;
        }
        ADD_FAILURE() << path << " loaded";
        return SceneError(SourceLocation{}, "loaded");
    }
    fs::path dir_;
};

TEST_F(SceneLoader, ColladaByItsExtensionInAnyCase) {
    for (const char* name : {"box.dae", "BOX.DAE", "box.Dae"}) {
        const std::string path = write(name, kCollada);
        const SceneDescription s = load_scene(path);
        EXPECT_EQ(s.source, path);
        ASSERT_EQ(s.meshes.size(), 1u) << name;
        EXPECT_EQ(s.triangle_count(), 1u);
    }
}

TEST_F(SceneLoader, GltfAndGlbByTheirExtensionsInAnyCase) {
    for (const char* name : {"a.gltf", "B.GLTF", "c.glTF"}) {
        const SceneDescription s = load_scene(write(name, kGltf));
        EXPECT_TRUE(has_warning(s, "no triangle geometry")) << name;
    }
    for (const char* name : {"d.glb", "E.GLB"}) {
        const SceneDescription s = load_scene(write(name, glb_of(kGltf)));
        EXPECT_TRUE(has_warning(s, "no triangle geometry")) << name;
    }
}

// The extension decides which reader runs: a glTF under .dae is read as COLLADA and refused as
// such, and the reverse.
TEST_F(SceneLoader, TheExtensionNotTheContentPicksTheReader) {
    const std::string gltf_as_dae = write("really_gltf.dae", kGltf);
    const SceneError e = error_of(gltf_as_dae);
    EXPECT_EQ(e.where().file, gltf_as_dae);
    const std::string said = e.detail();
    EXPECT_TRUE(said.find("XML") != std::string::npos || said.find("COLLADA") != std::string::npos) << said;
    const std::string dae_as_gltf = write("really_dae.gltf", kCollada);
    const SceneError g = error_of(dae_as_gltf);
    EXPECT_EQ(g.where().file, dae_as_gltf);
    EXPECT_NE(g.detail().find("glTF"), std::string::npos) << g.what();
}

TEST_F(SceneLoader, UnknownExtensionsAreRefusedNamingThem) {
    struct Case {
        const char* name;
        const char* shown;  // the extension as the message quotes it, lower case
    };
    const Case cases[] = {{"mesh.obj", "'.obj'"},
                          {"MESH.OBJ", "'.obj'"},
                          {"scene.gltf.bak", "'.bak'"},
                          {"no_extension", "''"},
                          {"scene.json", "'.json'"}};
    for (const Case& c : cases) {
        const std::string path = write(c.name, kCollada);
        const SceneError e = error_of(path);
        EXPECT_EQ(e.where().file, path);
        EXPECT_NE(e.detail().find(std::string("unknown scene format ") + c.shown), std::string::npos) << e.what();
        EXPECT_NE(e.detail().find("expected .dae, .gltf or .glb"), std::string::npos) << e.what();
    }
}

TEST_F(SceneLoader, AMissingFileIsASceneErrorNamingThePath) {
    for (const std::string& path : {(dir_ / "absent.dae").string(), (dir_ / "absent.glb").string(),
                                    (dir_ / "no" / "such" / "dir" / "x.gltf").string()}) {
        const SceneError e = error_of(path);
        EXPECT_EQ(e.where().file, path);
        EXPECT_EQ(e.detail(), "no such scene file");
        EXPECT_EQ(std::string(e.what()), path + ": no such scene file");
    }
    // A folder is not a scene file, whatever its name.
    fs::create_directories(dir_ / "folder.gltf");
    EXPECT_EQ(error_of((dir_ / "folder.gltf").string()).detail(), "no such scene file");
}

// The size is checked before any reader opens the file; the bound itself is allowed.
TEST_F(SceneLoader, FileSizeLimitIsInclusive) {
    const std::string path = write("box.dae", kCollada);
    const uint64_t size = fs::file_size(path);
    LoadLimits limits;
    limits.max_file_bytes = size;
    EXPECT_EQ(load_scene(path, limits).triangle_count(), 1u);
    limits.max_file_bytes = size - 1;
    const SceneError e = error_of(path, limits);
    EXPECT_EQ(e.where().file, path);
    EXPECT_EQ(e.detail(), "file is " + std::to_string(size) + " bytes, over the limit of " + std::to_string(size - 1));
    // glTF too: the bound is load_scene's own, checked before the reader is chosen.
    const std::string gltf = write("big.gltf", kGltf);
    limits.max_file_bytes = kGltf.size() - 1;
    EXPECT_NE(error_of(gltf, limits).detail().find("over the limit"), std::string::npos);
    limits.max_file_bytes = kGltf.size();
    EXPECT_NO_THROW(load_scene(gltf, limits));
}

// Limits other than the file size reach the reader: a loader called without them would take
// the defaults and let a hostile file through.
TEST_F(SceneLoader, LimitsAreHandedToTheReader) {
    LoadLimits no_triangles;
    no_triangles.max_triangles = 0;
    const SceneError c = error_of(write("box.dae", kCollada), no_triangles);
    EXPECT_NE(c.detail().find("triangle limit"), std::string::npos) << c.what();
    LoadLimits shallow;
    shallow.max_json_depth = 3;
    const SceneError g = error_of(write("deep.gltf", kGltf), shallow);
    EXPECT_NE(g.detail().find("deeper than 3"), std::string::npos) << g.what();
    EXPECT_NO_THROW(load_scene(write("deep.gltf", kGltf), LoadLimits{}));
}

// A reader's own error keeps its position: line for COLLADA, JSON pointer for glTF.
TEST_F(SceneLoader, ReaderErrorsKeepTheirPosition) {
    const std::string corpus = TESSERA_CORPUS_DIR;
    const std::string dae = corpus + "/collada/nan_in_positions.dae";
    const SceneError c = error_of(dae);
    EXPECT_EQ(c.where().file, dae);
    EXPECT_GT(c.where().line, 0);
    const std::string gltf = corpus + "/gltf/nan_position.gltf";
    const SceneError g = error_of(gltf);
    EXPECT_EQ(g.where().file, gltf);
    EXPECT_EQ(g.where().pointer, "/accessors/0");
}

TEST_F(SceneLoader, BuiltInNamesAreNotFiles) {
    const SceneDescription s = load_scene("builtin:cornell_spheres");
    EXPECT_EQ(s.source, "builtin:cornell_spheres");
    EXPECT_EQ(s.meshes.size(), cornell_spheres().meshes.size());
    EXPECT_EQ(s.spheres.size(), 2u);
    EXPECT_EQ(load_scene("builtin:displaced_sphere?triangles=32").triangle_count(), 32u);
    // A built-in name's error is the built-in check's, not "no such scene file".
    const SceneError e = error_of("builtin:cornell_box.dae");
    EXPECT_EQ(e.where().file, "builtin:cornell_box.dae");
    EXPECT_NE(e.detail().find("unknown built-in scene"), std::string::npos) << e.what();
    EXPECT_NE(error_of("builtin:displaced_sphere?triangles=3").detail().find("[8, 20000000]"), std::string::npos);
}

}  // namespace
}  // namespace tessera
