// Prepared scenes kept between jobs: a second job on the same file and build options is a hit
// (the same scene, not built again); other options, an edited file or a replaced one are
// scenes of their own; the least recently used go when the memory bound is passed, and idle
// ones go after their idle time, while a job still holding one keeps it alive.
#include "build_paths.h"
#include "server/queue/scene_cache.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

namespace tessera::server {
namespace {

namespace fs = std::filesystem;

class SceneCacheTest : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("tessera_scene_cache_" + std::to_string(::getpid()));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
        fs::copy_file(fs::path(TESSERA_PROJECT_SCENES) / "cornell_box.gltf", dir_ / "box.gltf");
        fs::copy_file(fs::path(TESSERA_PROJECT_SCENES) / "cornell_spheres.gltf", dir_ / "spheres.gltf");
    }
    void TearDown() override {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    std::string path(const char* name) const { return (dir_ / name).string(); }
    fs::path dir_;
};

TEST_F(SceneCacheTest, TheSameFileAndOptionsAreOneSceneOtherOptionsAnother) {
    SceneCache cache((dir_ / "cache").string(), int64_t(1) << 30, LoadLimits{}, 60);
    const auto [a, hit_a] = cache.get_local(path("box.gltf"), {}, {});
    const auto [b, hit_b] = cache.get_local(path("box.gltf"), {}, {});
    EXPECT_FALSE(hit_a);
    EXPECT_TRUE(hit_b);
    EXPECT_EQ(a.get(), b.get()) << "a hit is the scene prepared before, not a copy";
    RenderSceneOptions other;
    other.bvh.max_leaf_size = 4;
    const auto [c, hit_c] = cache.get_local(path("box.gltf"), {}, other);
    EXPECT_FALSE(hit_c) << "other build options build another scene";
    EXPECT_NE(c.get(), a.get());
    const auto [d, hit_d] = cache.get_local("builtin:cornell_spheres", {}, {});
    const auto [e, hit_e] = cache.get_local("builtin:cornell_spheres", {}, {});
    EXPECT_FALSE(hit_d);
    EXPECT_TRUE(hit_e);
    EXPECT_EQ(cache.hits(), 2u);
    EXPECT_EQ(cache.misses(), 3u);
}

// A glTF's external buffer (or texture), wherever in its folder, is part of what the scene is:
// one edited is another scene, though the .gltf is the same file. The first preparation that
// reads a file is not kept (the file's identity before it was read is unknown: an edit while
// it was read would be cached); the next, keyed by it, is.
TEST_F(SceneCacheTest, AnEditedFileTheSceneReadsIsAnotherScene) {
    fs::create_directories(dir_ / "data");
    auto write_triangle = [&](float size) {
        const float xyz[9] = {0, 0, 0, size, 0, 0, 0, size, 0};
        std::ofstream(dir_ / "data" / "tri.part", std::ios::binary).write(reinterpret_cast<const char*>(xyz), sizeof xyz);
        fs::rename(dir_ / "data" / "tri.part", dir_ / "data" / "tri.bin");  // a new file, as tools write one
    };
    write_triangle(1);
    std::ofstream(dir_ / "tri.gltf") << R"({"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
        "buffers":[{"byteLength":36,"uri":"data/tri.bin"}],"bufferViews":[{"buffer":0,"byteLength":36}],
        "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[2,2,0]}]})";
    SceneCache cache((dir_ / "cache").string(), int64_t(1) << 30, LoadLimits{}, 60);
    const auto [first, hit_first] = cache.get_local(path("tri.gltf"), {}, {});
    EXPECT_FALSE(hit_first);
    ASSERT_EQ(first->files_read.size(), 1u);
    EXPECT_EQ(fs::path(first->files_read[0]).filename(), "tri.bin");
    const auto [second, hit_second] = cache.get_local(path("tri.gltf"), {}, {});
    EXPECT_FALSE(hit_second) << "the first, read without its buffer's identity, is not kept";
    const auto [same, hit_same] = cache.get_local(path("tri.gltf"), {}, {});
    EXPECT_TRUE(hit_same) << "the second, keyed by its buffer, is";
    EXPECT_EQ(same.get(), second.get());
    write_triangle(2);
    const auto [edited, hit_edited] = cache.get_local(path("tri.gltf"), {}, {});
    EXPECT_FALSE(hit_edited) << "the buffer was edited";
    EXPECT_NE(edited.get(), second.get());
    EXPECT_TRUE(cache.get_local(path("tri.gltf"), {}, {}).second) << "the same files: kept at once";
}

TEST_F(SceneCacheTest, AnEditedOrReplacedFileIsAnotherScene) {
    SceneCache cache((dir_ / "cache").string(), int64_t(1) << 30, LoadLimits{}, 60);
    const auto first = cache.get_local(path("box.gltf"), {}, {}).first;
    // The same bytes written again: a new modification time, so possibly another file now.
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    fs::copy_file(path("box.gltf"), path("box2.gltf"));
    fs::rename(path("box2.gltf"), path("box.gltf"));
    const auto [again, hit] = cache.get_local(path("box.gltf"), {}, {});
    EXPECT_FALSE(hit) << "a replaced file is read again";
    EXPECT_NE(again.get(), first.get());
    fs::copy_file(path("spheres.gltf"), path("box.gltf"), fs::copy_options::overwrite_existing);
    const auto [other, hit2] = cache.get_local(path("box.gltf"), {}, {});
    EXPECT_FALSE(hit2);
    EXPECT_NE(other->scene.triangle_count() + other->scene.spheres.size(),
              again->scene.triangle_count() + again->scene.spheres.size()) << "the new content, not the old";
}

TEST_F(SceneCacheTest, TheLeastRecentlyUsedGoFirstWhenTheBoundIsPassed) {
    size_t box = 0, spheres = 0, furnace = 0;
    {
        SceneCache sizes((dir_ / "sizes").string(), int64_t(1) << 30, LoadLimits{}, 60);
        box = sizes.get_local(path("box.gltf"), {}, {}).first->bytes;
        spheres = sizes.get_local(path("spheres.gltf"), {}, {}).first->bytes;
        furnace = sizes.get_local("builtin:furnace", {}, {}).first->bytes;
    }
    // Room for the box and one of the others.
    SceneCache cache((dir_ / "cache").string(), int64_t(box + std::max(spheres, furnace)), LoadLimits{}, 60);
    cache.get_local(path("box.gltf"), {}, {});
    cache.get_local(path("spheres.gltf"), {}, {});
    EXPECT_TRUE(cache.get_local(path("box.gltf"), {}, {}).second) << "the box is now the most recent";
    cache.get_local("builtin:furnace", {}, {});  // over the bound: the least recently used goes
    EXPECT_TRUE(cache.get_local(path("box.gltf"), {}, {}).second);
    EXPECT_FALSE(cache.get_local(path("spheres.gltf"), {}, {}).second) << "the least recently used went";
    // A scene larger than the whole bound is rendered by whoever holds it, and not kept.
    SceneCache tiny((dir_ / "tiny").string(), 1, LoadLimits{}, 60);
    const auto held = tiny.get_local(path("box.gltf"), {}, {}).first;
    EXPECT_GT(held->scene.triangle_count(), 0u);
    EXPECT_FALSE(tiny.get_local(path("box.gltf"), {}, {}).second);
}

// The objects' and materials' names (Cryptomatte's) count against the bound: the same box with
// every mesh and material named at the loader's longest (200 characters) weighs that much more.
TEST_F(SceneCacheTest, NamesCountAgainstTheBound) {
    nlohmann::json g;
    {
        std::ifstream in(path("box.gltf"));
        in >> g;
    }
    size_t names = 0;
    for (const char* list : {"meshes", "materials"})
        for (size_t i = 0; i < g[list].size(); ++i, ++names) g[list][i]["name"] = std::string(199, 'a') + char('A' + i);
    ASSERT_GT(names, 2u);
    std::ofstream(path("named.gltf")) << g.dump();
    SceneCache cache((dir_ / "cache").string(), int64_t(1) << 30, LoadLimits{}, 60);
    const size_t plain = cache.get_local(path("box.gltf"), {}, {}).first->bytes;
    const size_t named = cache.get_local(path("named.gltf"), {}, {}).first->bytes;
    EXPECT_GE(named, plain + names * 150) << "each name about 180 bytes longer than the loader's own";
}

TEST_F(SceneCacheTest, IdleScenesGoAfterTheirIdleTime) {
    SceneCache cache((dir_ / "cache").string(), int64_t(1) << 30, LoadLimits{}, 0.05);
    cache.get_local(path("box.gltf"), {}, {});
    EXPECT_TRUE(cache.get_local(path("box.gltf"), {}, {}).second);
    std::this_thread::sleep_for(std::chrono::milliseconds(150));
    cache.drop_idle();
    EXPECT_FALSE(cache.get_local(path("box.gltf"), {}, {}).second) << "dropped after 50 ms unused";
}

}  // namespace
}  // namespace tessera::server
