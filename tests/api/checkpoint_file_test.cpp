#include "api/checkpoint_file.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <unistd.h>

namespace tessera::api {
namespace {

// A checkpoint of a film with every buffer a denoising, adaptive render keeps, its values all
// different: its arrays are larger than the writer's buffer and its small fields smaller.
RenderCheckpoint sample_checkpoint() {
    RenderCheckpoint c;
    c.pass = 3;
    c.target = 16;
    c.tiles_done = {1, 0, 1, 1, 0};
    c.points.resize(2);
    c.points[1].spp_mean = 8;
    c.samples = 123456789;
    c.seconds = 4.25;
    c.stats.samples = 99;
    c.film = Film(160, 90, true, true, kDenoiseAovs);
    uint64_t state = 88172645463325252ull;
    auto next = [&] {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        return double(state % 1000003) / 7.0;
    };
    for (auto* v : {&c.film.sum, &c.film.sum_half, &c.film.sum_quarter, &c.film.sum_eighth, &c.film.sum_odd, &c.film.seen, &c.film.seen_odd})
        for (glm::dvec3& x : *v) x = glm::dvec3(next(), next(), next());
    for (uint32_t& n : c.film.count) n = uint32_t(next());
    for (double& a : c.film.aov) a = next();
    return c;
}

std::string file_bytes(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// The file is streamed from the checkpoint's film, not encoded in memory first: its bytes are
// still exactly the encoding's, and it reads back to the same checkpoint.
TEST(CheckpointFile, StreamsTheEncodingsBytesAndReadsBack) {
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("tessera_ck_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    const RenderCheckpoint c = sample_checkpoint();
    const std::string encoded = encode_checkpoint(c);
    ASSERT_GT(encoded.size(), size_t(1) << 20);
    const std::string path = (dir / "frame" / "render.ckpt").string();
    ASSERT_TRUE(write_checkpoint(path, c));
    EXPECT_EQ(file_bytes(path), encoded);
    EXPECT_FALSE(std::filesystem::exists(path + ".part"));
    const std::optional<RenderCheckpoint> back = read_checkpoint(path);
    ASSERT_TRUE(back.has_value());
    EXPECT_EQ(encode_checkpoint(*back), encoded);
    // Written again over it (a later checkpoint of the same render): still whole.
    RenderCheckpoint later = c;
    later.pass = 4;
    ASSERT_TRUE(write_checkpoint(path, later));
    EXPECT_EQ(file_bytes(path), encode_checkpoint(later));
    // A path no file can have (its folder is a device): false, nothing thrown.
    EXPECT_FALSE(write_checkpoint("/dev/null/render.ckpt", c));
    // A disk that fills while the film streams: the file beside it is /dev/full, whose writes
    // fail with ENOSPC. False, the part removed, the checkpoint before left as it was.
    std::filesystem::create_symlink("/dev/full", path + ".part");
    EXPECT_FALSE(write_checkpoint(path, c));
    EXPECT_FALSE(std::filesystem::is_symlink(path + ".part"));
    EXPECT_EQ(file_bytes(path), encode_checkpoint(later)) << "the checkpoint before is left as it was";
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace tessera::api
