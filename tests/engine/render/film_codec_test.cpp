#include "engine/render/film_codec.h"

#include <gtest/gtest.h>

#include <cstring>
#include <stdexcept>

#include "tests/engine/render/sample_film.h"

namespace tessera {
namespace {

using test::sample_film;

TEST(FilmCodec, RoundTripsBitForBit) {
    for (bool half : {false, true})
        for (bool adaptive : {false, true}) {
            const Film f = sample_film(half, adaptive);
            const Film g = decode_film(encode_film(f));
            EXPECT_EQ(g.x0, 32);
            EXPECT_EQ(g.y0, 16);
            EXPECT_EQ(g.width, 5);
            EXPECT_EQ(g.height, 3);
            EXPECT_EQ(0, std::memcmp(f.sum.data(), g.sum.data(), f.sum.size() * sizeof(f.sum[0])));
            ASSERT_EQ(f.sum_half.size(), g.sum_half.size());
            ASSERT_EQ(f.sum_quarter.size(), g.sum_quarter.size());
            if (half) {
                EXPECT_EQ(0, std::memcmp(f.sum_half.data(), g.sum_half.data(), f.sum_half.size() * sizeof(glm::dvec3)));
                EXPECT_EQ(0, std::memcmp(f.sum_quarter.data(), g.sum_quarter.data(), f.sum_quarter.size() * sizeof(glm::dvec3)));
                EXPECT_EQ(0, std::memcmp(f.sum_eighth.data(), g.sum_eighth.data(), f.sum_eighth.size() * sizeof(glm::dvec3)));
            }
            EXPECT_EQ(f.count, g.count);
            EXPECT_EQ(f.done, g.done);
            ASSERT_EQ(f.stats.size(), g.stats.size());
            for (size_t i = 0; i < f.stats.size(); ++i) EXPECT_EQ(f.stats[i].m2, g.stats[i].m2);
            EXPECT_EQ(encode_film(g), encode_film(f));
        }
}

// A denoising film's odd halves and the light its samples saw directly travel too.
TEST(FilmCodec, ADenoisingFilmsHalvesRoundTrip) {
    Film f = Film::tile(8, 4, 3, 2, false, false, kDenoiseAovs);
    ASSERT_FALSE(f.seen.empty());
    for (size_t i = 0; i < f.sum.size(); ++i) {
        f.sum[i] = glm::dvec3(double(i), 2.0, 3.0);
        f.sum_odd[i] = glm::dvec3(0.5 * double(i), 1.0, 1.5);
        f.seen[i] = glm::dvec3(1e-3 * double(i), 0.0, 7.0);
        f.seen_odd[i] = glm::dvec3(0.0, double(i) / 3.0, 3.5);
        f.count[i] = 4;
    }
    const Film g = decode_film(encode_film(f));
    ASSERT_EQ(g.seen.size(), f.seen.size());
    EXPECT_EQ(0, std::memcmp(f.sum_odd.data(), g.sum_odd.data(), f.sum_odd.size() * sizeof(glm::dvec3)));
    EXPECT_EQ(0, std::memcmp(f.seen.data(), g.seen.data(), f.seen.size() * sizeof(glm::dvec3)));
    EXPECT_EQ(0, std::memcmp(f.seen_odd.data(), g.seen_odd.data(), f.seen_odd.size() * sizeof(glm::dvec3)));
    std::string bytes = encode_film(f);
    bytes.pop_back();
    EXPECT_THROW(decode_film(bytes), std::runtime_error);
}

// Guided sampling's per-pixel targets and the rays each pixel's samples traced travel with the
// film (a farm's tiles, checkpoints); a film without targets reads back without them.
TEST(FilmCodec, GuidedTargetsAndRaysRoundTrip) {
    Film f = Film::tile(8, 4, 3, 2, false, false, kDenoiseAovs);
    ASSERT_EQ(f.rays.size(), f.sum.size());
    EXPECT_TRUE(decode_film(encode_film(f)).goal.empty());
    f.goal.assign(f.sum.size(), 0);
    for (size_t i = 0; i < f.sum.size(); ++i) {
        f.count[i] = 8;
        f.goal[i] = uint32_t(8 + 2 * i);
        f.rays[i] = 8.f * float(i + 1) + 0.25f;
    }
    const Film g = decode_film(encode_film(f));
    EXPECT_EQ(g.goal, f.goal);
    EXPECT_EQ(g.rays, f.rays);
    EXPECT_EQ(g.count, f.count);
}

TEST(FilmCodec, RefusesWhatItDidNotWrite) {
    const std::string good = encode_film(sample_film(true, true));
    EXPECT_THROW(decode_film(""), std::runtime_error);
    EXPECT_THROW(decode_film(good.substr(0, good.size() - 1)), std::runtime_error);
    EXPECT_THROW(decode_film(good + "x"), std::runtime_error);
    std::string bad = good;
    bad[0] = 'X';
    EXPECT_THROW(decode_film(bad), std::runtime_error);
    std::string huge = good;
    const int32_t w = 1 << 30;
    std::memcpy(&huge[4], &w, 4);
    EXPECT_THROW(decode_film(huge), std::runtime_error);
}

}  // namespace
}  // namespace tessera
