// Texture lookups: known texels read back through coordinates, wrap modes, filters and
// KHR_texture_transform.
#include "engine/material/texture.h"

#include <cmath>

#include <gtest/gtest.h>

namespace tessera {
namespace {

// 4 × 2 texels: texel (x, y) has red 10·x + 60·y + 5, green 200 − 20·x, blue 7·y, alpha 255 − x.
TextureImage test_image() {
    TextureImage img;
    img.width = 4;
    img.height = 2;
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 4; ++x)
            img.rgba.insert(img.rgba.end(), {uint8_t(10 * x + 60 * y + 5), uint8_t(200 - 20 * x), uint8_t(7 * y), uint8_t(255 - x)});
    return img;
}

glm::vec4 raw(int x, int y) {
    return glm::vec4(10 * x + 60 * y + 5, 200 - 20 * x, 7 * y, 255 - x) / 255.f;
}

// The coordinates of texel (x, y)'s centre.
glm::vec2 centre(int x, int y) { return {(x + 0.5f) / 4.f, (y + 0.5f) / 2.f}; }

void expect_near(const glm::vec4& a, const glm::vec4& b, float eps = 1e-5f) {
    for (int c = 0; c < 4; ++c) EXPECT_NEAR(a[c], b[c], eps) << "channel " << c;
}

TEST(Texture, SrgbTableFollowsTheCurve) {
    EXPECT_EQ(kSrgbToLinear[0], 0.f);
    EXPECT_FLOAT_EQ(kSrgbToLinear[255], 1.f);
    EXPECT_NEAR(kSrgbToLinear[10], 10 / 255.0 / 12.92, 1e-7);           // linear segment
    EXPECT_NEAR(kSrgbToLinear[128], std::pow((128 / 255.0 + 0.055) / 1.055, 2.4), 1e-6);  // 0.2159
}

TEST(Texture, TexelCentresReadBackExactlyWithEitherFilter) {
    const TextureImage img = test_image();
    for (bool nearest : {false, true}) {
        const Texture t{0, Wrap::repeat, Wrap::repeat, nearest};
        for (int y = 0; y < 2; ++y)
            for (int x = 0; x < 4; ++x) {
                expect_near(texture_lookup(img, t, centre(x, y), false), raw(x, y));
                // sRGB decodes the colour channels only; alpha stays linear.
                const glm::vec4 s = texture_lookup(img, t, centre(x, y), true);
                EXPECT_NEAR(s.x, kSrgbToLinear[size_t(10 * x + 60 * y + 5)], 1e-6);
                EXPECT_NEAR(s.w, raw(x, y).w, 1e-6);
            }
    }
    // Row 0 is the top of the image: v near 0 reads y = 0.
    const Texture t{0, Wrap::clamp, Wrap::clamp, true};
    expect_near(texture_lookup(img, t, {0.1f, 0.01f}, false), raw(0, 0));
    expect_near(texture_lookup(img, t, {0.9f, 0.99f}, false), raw(3, 1));
}

TEST(Texture, BilinearBlendsDecodedNeighbours) {
    const TextureImage img = test_image();
    const Texture t{0, Wrap::clamp, Wrap::clamp, false};
    // Halfway between texels (1, 0) and (2, 0), and a quarter of the way down to row 1.
    const glm::vec2 at = {0.5f, (0.5f + 0.25f) / 2.f};
    const glm::vec4 top = 0.5f * (raw(1, 0) + raw(2, 0)), bottom = 0.5f * (raw(1, 1) + raw(2, 1));
    expect_near(texture_lookup(img, t, at, false), 0.75f * top + 0.25f * bottom);
    const float srgb_mid = 0.5f * (kSrgbToLinear[15] + kSrgbToLinear[25]);  // decoded, then blended
    EXPECT_NEAR(texture_lookup(img, t, {0.5f, 0.25f}, true).x, srgb_mid, 1e-6);
}

TEST(Texture, WrapModes) {
    const TextureImage img = test_image();
    const Texture repeat{0, Wrap::repeat, Wrap::repeat, true}, clamp{0, Wrap::clamp, Wrap::clamp, true},
        mirror{0, Wrap::mirror, Wrap::mirror, true};
    for (int x = 0; x < 4; ++x) {
        const glm::vec2 c = centre(x, 0);
        // Repeat: whole periods away, also negative ones, read the same texel.
        expect_near(texture_lookup(img, repeat, c + glm::vec2(3.f, 0.f), false), raw(x, 0));
        expect_near(texture_lookup(img, repeat, c - glm::vec2(2.f, 0.f), false), raw(x, 0));
        expect_near(texture_lookup(img, repeat, c + glm::vec2(0.f, 1.f), false), raw(x, 0));
        // Mirrored repeat: u in [1, 2) runs backwards.
        expect_near(texture_lookup(img, mirror, glm::vec2(2.f - c.x, c.y), false), raw(x, 0));
        expect_near(texture_lookup(img, mirror, glm::vec2(c.x - 2.f, c.y), false), raw(x, 0));
    }
    // Clamp: beyond the edge reads the edge texel, with bilinear filtering too.
    expect_near(texture_lookup(img, clamp, {7.f, -3.f}, false), raw(3, 0));
    const Texture clamp_linear{0, Wrap::clamp, Wrap::clamp, false};
    expect_near(texture_lookup(img, clamp_linear, {-0.5f, 5.f}, false), raw(0, 1));
    // Repeat with bilinear filtering blends across the seam: u = 0 is halfway between the last
    // and the first texel of a row.
    const Texture repeat_linear{0, Wrap::repeat, Wrap::clamp, false};
    expect_near(texture_lookup(img, repeat_linear, {0.f, 0.25f}, false), 0.5f * (raw(3, 0) + raw(0, 0)));
    // Any finite coordinate, however large, and non-finite ones read some texel.
    for (float u : {1e30f, -1e30f, INFINITY, NAN})
        for (const Texture* t : {&repeat, &clamp, &mirror, &repeat_linear}) {
            const glm::vec4 v = texture_lookup(img, *t, {u, u}, false);
            EXPECT_TRUE(std::isfinite(v.x) && v.x >= 0.f && v.x <= 1.f);
        }
}

TEST(Texture, TransformScalesRotatesThenOffsets) {
    TextureSlot slot;
    EXPECT_EQ(slot.map({0.3f, 0.7f}), glm::vec2(0.3f, 0.7f));  // identity without the extension
    set_texture_transform(slot, {0.5f, 0.25f}, 0.f, {1.f, 1.f});
    EXPECT_EQ(slot.map({0.f, 0.f}), glm::vec2(0.5f, 0.25f));
    set_texture_transform(slot, {0.f, 0.f}, 0.f, {2.f, 3.f});
    EXPECT_EQ(slot.map({1.f, 1.f}), glm::vec2(2.f, 3.f));
    // A quarter turn: KHR_texture_transform's rotation matrix (cos, sin; −sin, cos) by rows
    // takes u = 1 to v = −1 (counter-clockwise as the image is seen, v pointing down).
    set_texture_transform(slot, {0.f, 0.f}, float(M_PI / 2), {1.f, 1.f});
    const glm::vec2 r = slot.map({1.f, 0.f});
    EXPECT_NEAR(r.x, 0.f, 1e-6);
    EXPECT_NEAR(r.y, -1.f, 1e-6);
    // The order is T · R · S: scale first, offset last.
    set_texture_transform(slot, {10.f, 20.f}, float(M_PI / 2), {2.f, 1.f});
    const glm::vec2 q = slot.map({1.f, 0.f});  // S: (2, 0); R: (0, −2); T: (10, 18)
    EXPECT_NEAR(q.x, 10.f, 1e-5);
    EXPECT_NEAR(q.y, 18.f, 1e-5);
}

TEST(Texture, MeanOfAnImage) {
    const TextureImage img = test_image();
    double r = 0;
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 4; ++x) r += raw(x, y).x;
    EXPECT_NEAR(texture_mean(img, false).x, r / 8, 1e-6);
}

}  // namespace
}  // namespace tessera
