#include "server/farm/tile_image_codec.h"

#include <gtest/gtest.h>

#include <cstring>
#include <stdexcept>

#include "engine/render/film_codec.h"
#include "tests/engine/render/sample_film.h"

namespace tessera::server {
namespace {

using test::sample_film;

TEST(TileImageCodec, ATileImagePlacedEqualsTheResolvedFilm) {
    // Two tiles of a 5x6 image, resolved on their nodes and placed, against the whole film
    // resolved at once: equal bit for bit.
    Film whole(5, 6, true, false);
    Film top = Film::tile(0, 0, 5, 3, true, false), bottom = Film::tile(0, 3, 5, 3, true, false);
    for (int y = 0; y < 6; ++y)
        for (int x = 0; x < 5; ++x) {
            const size_t i = size_t(y) * 5 + x;
            whole.sum[i] = glm::dvec3(0.1 * double(i), 1.0 / 3.0, 7e-8 * double(i * i));
            whole.count[i] = uint32_t(1 + i % 4);
            Film& t = y < 3 ? top : bottom;
            const size_t j = size_t(y % 3) * 5 + x;
            t.sum[j] = whole.sum[i];
            t.count[j] = whole.count[i];
        }
    Image placed(5, 6);
    for (const Film* t : {&top, &bottom}) place_tile(decode_tile_image(encode_tile_image(*t)), placed);
    const Image want = whole.resolve();
    EXPECT_EQ(placed.rgb, want.rgb);
    EXPECT_EQ(placed.sample_count, want.sample_count);
    EXPECT_EQ(encode_tile_image(top).size(), 20u + 15u * 16u);
}

TEST(TileImageCodec, TileImagesRefuseWhatTheyDidNotWriteOrWhatDoesNotFit) {
    const std::string good = encode_tile_image(sample_film(true, false));
    EXPECT_THROW(decode_tile_image(good.substr(0, good.size() - 1)), std::runtime_error);
    EXPECT_THROW(decode_tile_image(good + "x"), std::runtime_error);
    EXPECT_THROW(decode_tile_image(encode_film(sample_film(true, false))), std::runtime_error);
    Image small(8, 8);
    EXPECT_THROW(place_tile(decode_tile_image(good), small), std::runtime_error);  // x0 = 32
}

}  // namespace
}  // namespace tessera::server
