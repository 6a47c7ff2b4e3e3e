// The scene catalog: what a job may name. Names come from the folders and never act as paths;
// the project's folder wins a name over --scenes folders; environment maps are apart from
// scenes; a file added later is found; uploads keep only clean names and whole, loadable
// scenes; a scene's description is cached until its file changes.
#include "build_paths.h"
#include "server/queue/scene_catalog.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "engine/core/scene_error.h"
#include "engine/io/scene_loader.h"
#include "server/queue/queue_error.h"

namespace tessera::server {
namespace {

namespace fs = std::filesystem;

std::string read_all(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), {});
}

class SceneCatalogTest : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("tessera_catalog_" + std::to_string(::getpid()));
        fs::remove_all(dir_);
        box_ = read_all(fs::path(TESSERA_PROJECT_SCENES) / "cornell_box.gltf");
        write("project/box.gltf", box_);
        write("project/sub/deep.gltf", box_);
        write("project/sky.exr", "not read until asked for");
        write("project/notes.txt", "not a scene");
        write("more/box.gltf", "the project's box wins this name");
        write("more/other.gltf", box_);
        fs::create_directories(dir_ / "uploads");
    }
    void TearDown() override {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    void write(const std::string& rel, const std::string& bytes) {
        fs::create_directories((dir_ / rel).parent_path());
        std::ofstream(dir_ / rel, std::ios::binary) << bytes;
    }
    SceneCatalog catalog() {
        return SceneCatalog((dir_ / "project").string(), {(dir_ / "more").string()}, (dir_ / "uploads").string());
    }
    fs::path dir_;
    std::string box_;
};

TEST_F(SceneCatalogTest, NamesComeFromTheFoldersAndNeverActAsPaths) {
    SceneCatalog c = catalog();
    ASSERT_TRUE(c.find("box"));
    EXPECT_EQ(c.find("box")->source, "project") << "the project's folder wins a name";
    EXPECT_EQ(fs::path(c.find("box")->path), dir_ / "project" / "box.gltf");
    ASSERT_TRUE(c.find("sub/deep"));
    ASSERT_TRUE(c.find("other"));
    EXPECT_EQ(c.find("other")->source, "directory");
    ASSERT_TRUE(c.find("builtin:furnace"));
    EXPECT_EQ(c.find("builtin:furnace")->source, "builtin");
    for (const std::string& name : std::vector<std::string>{"notes", "sky", "box.gltf", "../project/box", "/etc/passwd", (dir_ / "project" / "box").string(),
                                   "sub/../box", ""})
        EXPECT_FALSE(c.find(name)) << "'" << name << "' names no scene";
    ASSERT_TRUE(c.find_environment("sky")) << "an environment map is named like a scene, apart from them";
    EXPECT_FALSE(c.find_environment("box"));
}

// What the server says about a scene's file names it by its place in the catalog: the folders
// of the server's disk are taken out of every path in the text, in any spelling of them.
TEST_F(SceneCatalogTest, RedactTakesTheServersFoldersOutOfPaths) {
    SceneCatalog c = catalog();
    const std::string project = (dir_ / "project").string(), more = (dir_ / "more").string();
    EXPECT_EQ(c.redact("scene: " + project + "/sub/deep.gltf#/animations: no animation 'x'"),
              "scene: sub/deep.gltf#/animations: no animation 'x'");
    EXPECT_EQ(c.redact(more + "/other.gltf and " + project + "/box.gltf"), "other.gltf and box.gltf");
    EXPECT_EQ(c.redact((dir_ / "uploads").string() + "/up.glb: broken"), "up.glb: broken");
    EXPECT_EQ(c.redact("/etc/passwd stays"), "/etc/passwd stays");
    EXPECT_EQ(c.redact("/bak" + project + "/box.gltf"), "/bak" + project + "/box.gltf") << "inside another path: left";
    EXPECT_EQ(c.redact(""), "");
    // A folder given through ".." or a link is cut in the spelling the file system gives too.
    fs::create_directory_symlink(dir_ / "project", dir_ / "linked");
    SceneCatalog through((dir_ / "linked").string(), {(dir_ / "more" / ".." / "more").string()}, "");
    EXPECT_EQ(through.redact(fs::canonical(dir_ / "project").string() + "/box.gltf"), "box.gltf");
    EXPECT_EQ(through.redact((dir_ / "linked").string() + "/box.gltf"), "box.gltf");
    EXPECT_EQ(through.redact(fs::canonical(dir_ / "more").string() + "/other.gltf"), "other.gltf");
    // A relative folder is cut as its absolute path, never as "./" in the text.
    SceneCatalog relative(".", {}, "");
    EXPECT_EQ(relative.redact("../x and ./y"), "../x and ./y");
}

TEST_F(SceneCatalogTest, AFileAddedLaterIsFound) {
    SceneCatalog c = catalog();
    EXPECT_FALSE(c.find("late"));
    write("more/late.gltf", box_);
    EXPECT_TRUE(c.find("late"));
}

TEST_F(SceneCatalogTest, UploadsKeepOnlyCleanNamesAndWholeScenes) {
    SceneCatalog c = catalog();
    const LoadLimits limits;
    for (const std::string& bad : std::vector<std::string>{"../x.gltf", "a/b.gltf", ".hidden.gltf", "x.obj", "", "sp ace.gltf", std::string(200, 'a') + ".gltf"}) {
        try {
            c.add_upload(bad, box_, limits);
            ADD_FAILURE() << "'" << bad << "' was taken";
        } catch (const QueueError& p) {
            EXPECT_EQ(p.kind, QueueErrorKind::invalid) << bad;
            EXPECT_EQ(p.field.value_or("?"), "name") << bad;
        }
    }
    try {
        std::string broken = box_;
        broken.resize(broken.size() / 2);  // cut off halfway
        c.add_upload("broken.gltf", broken, limits);
        ADD_FAILURE() << "a broken scene was taken";
    } catch (const QueueError& p) {
        EXPECT_EQ(p.kind, QueueErrorKind::broken_file);
        EXPECT_NE(p.location.find("broken.gltf"), std::string::npos) << p.location;
    }
    EXPECT_TRUE(fs::is_empty(dir_ / "uploads")) << "nothing is kept of refused uploads";
    const CatalogEntry up = c.add_upload("mine.gltf", box_, limits);
    EXPECT_EQ(up.source, "upload");
    EXPECT_EQ(up.name.rfind("upload/", 0), 0u) << up.name;
    EXPECT_EQ(up.name.substr(up.name.size() - 5), "/mine");
    ASSERT_TRUE(c.find(up.name));
    EXPECT_EQ(read_all(c.find(up.name)->path), box_);
    EXPECT_NE(c.add_upload("mine.gltf", box_, limits).name, up.name) << "two uploads of one name are two scenes";
}

TEST_F(SceneCatalogTest, ADescriptionHoldsUntilItsFileChanges) {
    SceneCatalog c = catalog();
    const CatalogEntry e = *c.find("other");
    const nlohmann::json first = c.describe(e, LoadLimits{});
    EXPECT_GT(first.at("triangles").get<size_t>(), 0u);
    EXPECT_EQ(c.describe(e, LoadLimits{}), first);
    write("more/other.gltf", "{ broken");
    fs::last_write_time(dir_ / "more" / "other.gltf", fs::file_time_type::clock::now() + std::chrono::seconds(5));
    EXPECT_THROW(c.describe(e, LoadLimits{}), SceneError) << "a changed file is read again";
}

}  // namespace
}  // namespace tessera::server
