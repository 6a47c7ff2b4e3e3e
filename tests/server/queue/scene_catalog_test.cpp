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

// What the server tells a client names a file by its place in the catalog (`shown`, which the
// loaders are given), never by the server's folders: a link by where it sits, not where it
// points (a folder outside the catalog), a folder given through ".." or a link alike, an upload
// under upload/<id>/, a built-in by its name.
TEST_F(SceneCatalogTest, EveryFileIsShownByItsPlaceInTheCatalog) {
    write("outside/far.gltf", box_);
    fs::create_symlink(dir_ / "outside" / "far.gltf", dir_ / "project" / "sub" / "near.gltf");
    fs::create_directory_symlink(dir_ / "project", dir_ / "linked");
    auto expect_places = [&](SceneCatalog& c) {
        const std::vector<std::pair<std::string, std::string>> shown = {
            {"box", "box.gltf"}, {"sub/deep", "sub/deep.gltf"}, {"sub/near", "sub/near.gltf"}, {"other", "other.gltf"},
            {"builtin:furnace", "builtin:furnace"}};
        for (const auto& [name, place] : shown) {
            const auto e = c.find(name);
            ASSERT_TRUE(e) << name;
            EXPECT_EQ(e->shown, place) << name;
        }
        EXPECT_FALSE(c.find("../outside/far")) << "a link is named where it sits";
        EXPECT_EQ(c.find_environment("sky")->shown, "sky.exr");
        const CatalogEntry up = c.add_upload("mine.gltf", box_, {});
        EXPECT_EQ(up.shown, up.name.substr(0, up.name.rfind('/')) + "/mine.gltf");
        EXPECT_EQ(up.shown.rfind("upload/", 0), 0u) << up.shown;
        for (const CatalogEntry& e : c.entries()) {
            EXPECT_EQ(e.shown.find(dir_.string()), std::string::npos) << e.shown;
            EXPECT_EQ(e.shown.find(".."), std::string::npos) << e.shown;
        }
    };
    SceneCatalog as_given = catalog();
    expect_places(as_given);
    SceneCatalog through((dir_ / "linked").string(), {(dir_ / "more" / ".." / "more").string()}, (dir_ / "uploads").string());
    expect_places(through);
}

// A broken upload is refused naming the file by its place, what it names quoted as written.
TEST_F(SceneCatalogTest, ABrokenUploadNamesItsFileByItsPlace) {
    SceneCatalog c = catalog();
    // A buffer whose file is the upload itself, longer than it: tinygltf names the file it read.
    const std::string self = R"({"asset": {"version": "2.0"}, "buffers": [{"uri": "self.gltf", "byteLength": 99999}]})";
    try {
        c.add_upload("self.gltf", self, {});
        ADD_FAILURE() << "a buffer longer than its file";
    } catch (const QueueError& e) {
        const std::string text = std::string(e.what()) + " " + e.location;
        EXPECT_EQ(text.find(dir_.string()), std::string::npos) << text;
        EXPECT_NE(text.find("upload/"), std::string::npos) << text;
    }
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
