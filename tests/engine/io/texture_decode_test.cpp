// Decoding texture images: PNG read back exactly, and broken, hostile or oversized ones refused
// with a reason before anything large is allocated.
#include "engine/io/texture_decode.h"

#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "engine/io/image_io.h"

namespace tessera {
namespace {

Image gradient(int w, int h) {
    Image img;
    img.width = w;
    img.height = h;
    img.rgb.resize(size_t(w) * h * 3);
    img.sample_count.assign(size_t(w) * h, 1.f);
    for (size_t i = 0; i < img.rgb.size(); ++i) img.rgb[i] = float(i % 17) / 16.f;
    return img;
}

std::string error_of(std::span<const uint8_t> bytes, const LoadLimits& limits = {}) {
    uint64_t budget = limits.max_texture_bytes;
    try {
        decode_texture(bytes, limits, budget);
    } catch (const std::runtime_error& e) {
        return e.what();
    }
    return "";
}

// A PNG signature and an IHDR chunk declaring w × h (CRC left zero).
std::vector<uint8_t> png_header(uint32_t w, uint32_t h) {
    std::vector<uint8_t> b = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A, 0, 0, 0, 13, 'I', 'H', 'D', 'R'};
    for (uint32_t v : {w, h})
        for (int s = 24; s >= 0; s -= 8) b.push_back(uint8_t(v >> s));
    b.insert(b.end(), {8, 6, 0, 0, 0, 0, 0, 0, 0});
    return b;
}

TEST(TextureDecode, PngReadsBackItsBytes) {
    const Image img = gradient(5, 3);
    const std::vector<unsigned char> png = png_bytes(img);
    const std::vector<unsigned char> want = encode_srgb8(img, ToneCurve::srgb);
    uint64_t budget = 1000;
    const auto tex = decode_texture(png, LoadLimits{}, budget);
    ASSERT_EQ(tex->width, 5);
    ASSERT_EQ(tex->height, 3);
    EXPECT_EQ(budget, 1000u - 5 * 3 * 4);
    for (size_t i = 0; i < 15; ++i) {
        for (int c = 0; c < 3; ++c) EXPECT_EQ(tex->rgba[4 * i + size_t(c)], want[3 * i + size_t(c)]) << "texel " << i;
        EXPECT_EQ(tex->rgba[4 * i + 3], 255);  // no alpha channel: opaque
    }
}

TEST(TextureDecode, RefusesWhatIsNotAnImage) {
    const std::string text = "GIF89a, or anything else";
    EXPECT_NE(error_of({reinterpret_cast<const uint8_t*>(text.data()), text.size()}).find("not a PNG or JPEG"), std::string::npos);
    EXPECT_NE(error_of({}).find("not a PNG or JPEG"), std::string::npos);
    // A truncated PNG: the header is there, the data is not.
    std::vector<unsigned char> png = png_bytes(gradient(8, 8));
    png.resize(png.size() / 2);
    const std::string e = error_of(png);
    EXPECT_TRUE(e.find("corrupt") != std::string::npos || e.find("unreadable") != std::string::npos) << e;
}

TEST(TextureDecode, OversizedImagesAreRefusedFromTheirHeader) {
    // 60000 × 60000 RGBA would need 14 GB: refused from the header's 33 bytes (by stb_image's
    // own 2^30-byte bound, before ours).
    EXPECT_NE(error_of(png_header(60000, 60000)).find("header"), std::string::npos);
    // Over our side limit.
    LoadLimits side;
    side.max_texture_size = 1000;
    const std::string e = error_of(png_header(2000, 1500), side);
    EXPECT_NE(e.find("2000x1500"), std::string::npos) << e;
    EXPECT_NE(e.find("limit is 1000"), std::string::npos) << e;
    // Within the side limit but over what is left of the byte budget.
    LoadLimits small;
    small.max_texture_bytes = 4 * 4 * 4;
    const std::vector<unsigned char> png = png_bytes(gradient(8, 8));
    EXPECT_NE(error_of(png, small).find("left of the texture budget"), std::string::npos);
}

TEST(TextureDecode, TheBudgetHoldsTheDecodingPeakNotOnlyTheTexels) {
    // 8 × 8 RGBA is 256 bytes of texels; decoding holds up to 2.5 times that. A budget of twice
    // the texels would hold the result but not the decoding: refused before decoding.
    const std::vector<unsigned char> png = png_bytes(gradient(8, 8));
    LoadLimits twice;
    twice.max_texture_bytes = 2 * 256;
    const std::string e = error_of(png, twice);
    EXPECT_NE(e.find("640 while it decodes"), std::string::npos) << e;
    // Exactly the peak: decoded, and the budget lowered by the texels alone.
    LoadLimits peak;
    peak.max_texture_bytes = 640;
    uint64_t budget = peak.max_texture_bytes;
    const auto img = decode_texture({png.data(), png.size()}, peak, budget);
    ASSERT_TRUE(img);
    EXPECT_EQ(img->width, 8);
    EXPECT_EQ(budget, 640u - 256u);
}

}  // namespace
}  // namespace tessera
