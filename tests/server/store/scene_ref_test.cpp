#include "server/store/scene_ref.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <unistd.h>

namespace tessera::server {
namespace {

TEST(ContentHash, NamesBytes) {
    EXPECT_EQ(content_hash("abc"), content_hash(std::string("abc")));
    EXPECT_NE(content_hash("abc"), content_hash("abd"));
    EXPECT_NE(content_hash(std::string("a\0", 2)), content_hash("a"));
    EXPECT_EQ(content_hash("").rfind("fnv1a64-", 0), 0u);
    // The size is part of the name: equal FNV values of different lengths stay apart.
    EXPECT_NE(content_hash("abc").substr(content_hash("abc").rfind('-')), content_hash("abcd").substr(content_hash("abcd").rfind('-')));
}

TEST(SceneRef, EncodesAndDecodesEveryField) {
    const SceneRef built_in{"builtin:displaced_sphere?triangles=2000", "", "", "builtin:displaced_sphere?triangles=2000"};
    const SceneRef decoded = SceneRef::decode(built_in.encode());
    EXPECT_EQ(decoded.source, built_in.source);
    EXPECT_EQ(decoded.hash, "");
    EXPECT_EQ(decoded.ext, "");
    EXPECT_EQ(decoded.shown(), built_in.source);
    const SceneRef file{"/scenes/a b.glb", content_hash("x"), ".glb", "sub/a b.glb"};
    const SceneRef f = SceneRef::decode(file.encode());
    EXPECT_EQ(f.source, file.source);
    EXPECT_EQ(f.hash, file.hash);
    EXPECT_EQ(f.ext, ".glb");
    EXPECT_EQ(f.name, "sub/a b.glb");
    EXPECT_EQ(f.shown(), "sub/a b.glb");
}

// A reference an older API node wrote has three lines: its file is named by its file name, never
// by the API node's folders.
TEST(SceneRef, AnOlderReferenceIsNamedByItsFileName) {
    const SceneRef old = SceneRef::decode("/srv/scenes/sky/a.gltf\n" + content_hash("x") + "\n.gltf");
    EXPECT_EQ(old.name, "");
    EXPECT_EQ(old.shown(), "a.gltf");
    EXPECT_EQ(SceneRef::decode("builtin:furnace\n\n").shown(), "builtin:furnace");
}

TEST(SceneRef, ReadsAFileWithItsHashAndLowerCaseExtension) {
    const auto dir = std::filesystem::temp_directory_path() / ("tessera_scene_ref_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const std::string bytes("glTF\0\x02", 6);
    const auto path = dir / "Model.GLB";
    std::ofstream(path, std::ios::binary) << bytes;
    const auto f = read_scene_file(path.string());
    ASSERT_TRUE(f);
    EXPECT_EQ(f->bytes, bytes);
    EXPECT_EQ(f->ref.hash, content_hash(bytes));
    EXPECT_EQ(f->ref.ext, ".glb");  // picks the loader whatever the file's case
    EXPECT_EQ(f->ref.source, path.string());
    EXPECT_FALSE(read_scene_file((dir / "missing.gltf").string()));
    EXPECT_FALSE(read_scene_file(dir.string()));  // a folder is no scene file
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace tessera::server
