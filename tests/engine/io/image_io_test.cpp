// image_io: EXR written and read back bit for bit, the sample counts in a channel of their own
// (never taken for alpha, so colour is not premultiplied by them), from a file or from memory;
// 8-bit encodings that round to nearest on the sRGB and CS184 curves, clamp, and apply exposure
// before the curve; the rate heatmap's colours and its scale stated in the file; metadata kept in
// the files; the format chosen by extension in any case; and unwritable or unreadable paths
// refused naming the path. Files go to a temporary folder of each test's own.
#include "engine/io/image_io.h"

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/io/texture_decode.h"
#include "engine/material/texture.h"

namespace tessera {
namespace {

namespace fs = std::filesystem;

class ImageIo : public ::testing::Test {
protected:
    void SetUp() override {
        std::string tmpl = (fs::temp_directory_path() / "tessera_image_io_XXXXXX").string();
        ASSERT_NE(::mkdtemp(tmpl.data()), nullptr);
        dir_ = tmpl;
    }
    void TearDown() override {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    std::string path(const std::string& name) const { return (dir_ / name).string(); }
    fs::path dir_;
};

std::string file_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const std::string& path, const std::vector<unsigned char>& bytes) {
    std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

// The RGB bytes of a PNG, decoded by stb_image (not by the library that wrote it).
std::vector<unsigned char> png_rgb(std::span<const uint8_t> png, int want_w, int want_h) {
    uint64_t budget = LoadLimits{}.max_texture_bytes;
    const auto tex = decode_texture(png, LoadLimits{}, budget);
    EXPECT_EQ(tex->width, want_w);
    EXPECT_EQ(tex->height, want_h);
    std::vector<unsigned char> rgb;
    for (size_t i = 0; i < tex->rgba.size(); i += 4) rgb.insert(rgb.end(), {tex->rgba[i], tex->rgba[i + 1], tex->rgba[i + 2]});
    return rgb;
}
std::vector<unsigned char> png_rgb(const std::string& bytes, int w, int h) {
    return png_rgb({reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()}, w, h);
}

// Values that a half-float file, a lossy codec, a clamp or a premultiplication would each change.
const float kAwkward[] = {0.f,     -0.f,  1.f,  1.f / 3.f,   1e-30f,  1.0e38f, -2.5f, 65504.f,
                          65505.f, 1e-5f, 0.1f, 123456.789f, -1e-20f, 7.f,     0.5f,  1e10f};

// 5 × 3, so that a transposed or row-flipped read shows; sample counts include 0 next to
// non-zero colour (alpha 0) and values far from 1.
Image awkward_image() {
    Image img(5, 3);
    for (size_t i = 0; i < img.rgb.size(); ++i) img.rgb[i] = kAwkward[i % std::size(kAwkward)] * (1.f + float(i / 16));
    for (size_t i = 0; i < img.sample_count.size(); ++i) img.sample_count[i] = float((i * 37) % 101);
    return img;
}

void expect_same_bits(const Image& got, const Image& want) {
    ASSERT_EQ(got.width, want.width);
    ASSERT_EQ(got.height, want.height);
    ASSERT_EQ(got.rgb.size(), want.rgb.size());
    for (size_t i = 0; i < want.rgb.size(); ++i)
        EXPECT_EQ(std::bit_cast<uint32_t>(got.rgb[i]), std::bit_cast<uint32_t>(want.rgb[i]))
            << "value " << i << ": " << got.rgb[i] << " for " << want.rgb[i];
    ASSERT_EQ(got.sample_count.size(), want.sample_count.size());
    for (size_t i = 0; i < want.sample_count.size(); ++i)
        EXPECT_EQ(std::bit_cast<uint32_t>(got.sample_count[i]), std::bit_cast<uint32_t>(want.sample_count[i])) << "pixel " << i;
}

// --- EXR -------------------------------------------------------------------------------------

TEST_F(ImageIo, ExrFileReadsBackBitForBitWithItsSampleCounts) {
    const Image img = awkward_image();
    write_exr(path("a.exr"), img);
    expect_same_bits(read_image(path("a.exr")), img);
}

TEST_F(ImageIo, ExrInMemoryIsTheSameFile) {
    const Image img = awkward_image();
    const std::vector<unsigned char> bytes = exr_bytes(img);
    ASSERT_GE(bytes.size(), 4u);
    EXPECT_EQ(std::string(bytes.begin(), bytes.begin() + 4), std::string("\x76\x2f\x31\x01", 4)) << "OpenEXR's magic";
    write_bytes(path("memory.exr"), bytes);
    expect_same_bits(read_image(path("memory.exr")), img);
}

// An image without counts (one made by hand, or read from a file without them) still writes,
// its counts as zeros.
TEST_F(ImageIo, ExrWithoutSampleCountsWritesZeros) {
    Image img;
    img.width = 3;
    img.height = 2;
    img.rgb = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18};
    write_exr(path("plain.exr"), img);
    const Image back = read_image(path("plain.exr"));
    ASSERT_EQ(back.rgb, img.rgb);
    EXPECT_EQ(back.sample_count, std::vector<float>(6, 0.f));
}

// Each plane of a multilayer file reads back under its pass's channel names; a plane whose
// components or values do not fit its pass is refused, never written as zeros or as another
// pass's values (the bench's reference once wrote its own error as zeros so).
TEST_F(ImageIo, LayersReadBackByNameAndAMisfitPlaneIsRefused) {
    Image img;
    img.width = 2;
    img.height = 1;
    img.rgb = {1, 2, 3, 4, 5, 6};
    img.sample_count = {7, 8};
    AovPlane depth{Aov::depth, 1, {0.5f, 2.5f}}, variance{Aov::variance, 3, {0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f}};
    write_layers_exr(path("layers.exr"), img, {depth, variance});
    const ChannelImage back = read_channels(path("layers.exr"));
    EXPECT_EQ(back.channel("Z"), (std::vector<float>{0.5f, 2.5f}));
    const std::vector<std::string> v = aov_channel_names(Aov::variance);
    ASSERT_EQ(v.size(), 3u);
    EXPECT_EQ(back.channel(v[0]), (std::vector<float>{0.1f, 0.4f}));
    EXPECT_EQ(back.channel(v[2]), (std::vector<float>{0.3f, 0.6f}));
    EXPECT_EQ(back.channel("samples"), img.sample_count);

    AovPlane unset{Aov::variance, 0, variance.values};  // components left at its default
    EXPECT_THROW(write_layers_exr(path("unset.exr"), img, {unset}), std::invalid_argument);
    AovPlane short_plane{Aov::variance, 3, {0.1f, 0.2f, 0.3f}};  // one pixel's values for two
    EXPECT_THROW(write_layers_exr(path("short.exr"), img, {depth, short_plane}), std::invalid_argument);
    EXPECT_THROW(write_aov_exr(path("one.exr"), 2, 1, AovPlane{Aov::depth, 3, variance.values}), std::invalid_argument);
    EXPECT_FALSE(fs::exists(path("unset.exr")) || fs::exists(path("short.exr")) || fs::exists(path("one.exr")));
}

TEST_F(ImageIo, MetadataIsWrittenIntoTheFiles) {
    const Image img = awkward_image();
    const Metadata meta = {{"tessera:job", "job-7f3a"}, {"tessera:scene", "builtin:cornell_box"}};
    write_exr(path("m.exr"), img, meta);
    write_png(path("m.png"), img, ToneCurve::srgb, meta);
    for (const char* name : {"m.exr", "m.png"}) {
        const std::string bytes = file_bytes(path(name));
        for (const auto& [k, v] : meta) {
            EXPECT_NE(bytes.find(k), std::string::npos) << name << " lacks " << k;
            EXPECT_NE(bytes.find(v), std::string::npos) << name << " lacks " << v;
        }
    }
    expect_same_bits(read_image(path("m.exr")), img);
}

// --- 8-bit encodings -------------------------------------------------------------------------

// One row of linear values, three per pixel.
Image row_of(const std::vector<float>& linear) {
    Image img(int(linear.size() / 3), 1);
    img.rgb = linear;
    return img;
}

const std::vector<float> kLinear = {0.f, 0.001f, 0.01f, 0.05f, 0.18f, 0.5f, 0.9f, 1.f, 2.f, -1.f, 0.25f, 0.0625f};

// Expected bytes computed apart from the code (in double precision, rounding half away from
// zero), none within 0.01 of a rounding boundary.
TEST(Encode8, SrgbCurveKnownValues) {
    const std::vector<unsigned char> want = {0, 3, 25, 63, 118, 188, 243, 255, 255, 0, 137, 71};
    EXPECT_EQ(encode_srgb8(row_of(kLinear), ToneCurve::srgb), want);
}

TEST(Encode8, Cs184CurveKnownValues) {
    // clamp((√2·L)^(1/2.2)): L = 1/√2 is already white, which the sRGB curve is not.
    const std::vector<unsigned char> want = {0, 13, 37, 76, 137, 218, 255, 255, 255, 0, 159, 85};
    EXPECT_EQ(encode_srgb8(row_of(kLinear), ToneCurve::cs184), want);
}

// Every sRGB byte survives decoding (by the texture table) and encoding again, and values
// either side of a half step go to the nearer byte: truncation or a curve off by a little
// would each move some of them.
TEST(Encode8, SrgbRoundsToTheNearestByte) {
    std::vector<float> exact(kSrgbToLinear.begin(), kSrgbToLinear.end());
    exact.resize(258, 0.f);  // a whole number of pixels
    const std::vector<unsigned char> back = encode_srgb8(row_of(exact), ToneCurve::srgb);
    for (int b = 0; b < 256; ++b) EXPECT_EQ(back[size_t(b)], b) << "byte " << b;
    auto linear_of = [](double encoded) {
        return float(encoded <= 0.04045 ? encoded / 12.92 : std::pow((encoded + 0.055) / 1.055, 2.4));
    };
    std::vector<float> below, above;
    for (int b = 0; b < 255; ++b) {
        below.push_back(linear_of((b + 0.45) / 255.0));
        above.push_back(linear_of((b + 0.55) / 255.0));
    }
    const std::vector<unsigned char> lo = encode_srgb8(row_of(below), ToneCurve::srgb);
    const std::vector<unsigned char> hi = encode_srgb8(row_of(above), ToneCurve::srgb);
    for (int b = 0; b < 255; ++b) {
        EXPECT_EQ(lo[size_t(b)], b) << "just under " << b << ".5";
        EXPECT_EQ(hi[size_t(b)], b + 1) << "just over " << b << ".5";
    }
}

// The gain multiplies linear values before the curve and the clamp, so doubling the gain is
// the same as doubling the image (exactly, in floating point) and a bright value saturates.
TEST(Encode8, GainScalesLinearValuesBeforeTheCurve) {
    std::vector<float> half(kLinear), quadruple(kLinear);
    for (float& v : half) v *= 0.5f;
    for (float& v : quadruple) v *= 4.f;
    const auto want = encode_srgb8(row_of(kLinear), ToneCurve::srgb);
    EXPECT_EQ(encode_srgb8(row_of(half), ToneCurve::srgb, 2.f), want);
    EXPECT_EQ(encode_srgb8(row_of(quadruple), ToneCurve::srgb, 0.25f), want);
    EXPECT_EQ(encode_srgb8(row_of({0.6f, 0.6f, 0.6f}), ToneCurve::srgb, 2.f), std::vector<unsigned char>(3, 255));
    EXPECT_EQ(encode_srgb8(row_of(half), ToneCurve::cs184, 2.f), encode_srgb8(row_of(kLinear), ToneCurve::cs184));
}

// --- PNG -------------------------------------------------------------------------------------

TEST_F(ImageIo, PngFilesHoldTheEncodingOfTheirCurve) {
    Image img(5, 3);
    for (size_t i = 0; i < img.rgb.size(); ++i) img.rgb[i] = float(i) / 30.f;  // 0 … 1.47, some clamped
    write_png(path("srgb.png"), img);
    EXPECT_EQ(png_rgb(file_bytes(path("srgb.png")), 5, 3), encode_srgb8(img, ToneCurve::srgb));
    write_png(path("cs184.png"), img, ToneCurve::cs184);
    EXPECT_EQ(png_rgb(file_bytes(path("cs184.png")), 5, 3), encode_srgb8(img, ToneCurve::cs184));
    EXPECT_NE(encode_srgb8(img, ToneCurve::srgb), encode_srgb8(img, ToneCurve::cs184));
}

// Exposure in stops: +1 EV of half the image is the image, −2 EV of four times it likewise.
TEST(PngBytes, ExposureIsAPowerOfTwoOnLinearValues) {
    Image img(4, 1), half(4, 1), quadruple(4, 1);
    img.rgb = kLinear;
    half.rgb = kLinear;
    quadruple.rgb = kLinear;
    for (float& v : half.rgb) v *= 0.5f;
    for (float& v : quadruple.rgb) v *= 4.f;
    const auto want = encode_srgb8(img, ToneCurve::srgb);
    const auto plain = png_bytes(img);
    EXPECT_EQ(png_rgb(plain, 4, 1), want);
    EXPECT_EQ(png_rgb(png_bytes(half, 1.f), 4, 1), want);
    EXPECT_EQ(png_rgb(png_bytes(quadruple, -2.f), 4, 1), want);
    // A fractional exposure is 2^EV, not EV itself or e^EV.
    EXPECT_EQ(png_rgb(png_bytes(img, 1.5f), 4, 1), encode_srgb8(img, ToneCurve::srgb, std::exp2(1.5f)));
    EXPECT_NE(png_rgb(png_bytes(img, 1.5f), 4, 1), encode_srgb8(img, ToneCurve::srgb, 1.5f));
}

// --- the sample-rate heatmap -----------------------------------------------------------------

TEST(RateColors, BlueThroughGreenToRedAndClamped) {
    Image img(7, 1);
    img.sample_count = {0, 2, 4, 6, 8, 16, 1};
    const std::vector<unsigned char> want = {0,   0,   255,  // 0: blue
                                             0,   128, 128,  // 1/4: half way to green
                                             0,   255, 0,    // 1/2: green
                                             128, 128, 0,    // 3/4: half way to red
                                             255, 0,   0,    // 1: red
                                             255, 0,   0,    // above the maximum: red
                                             0,   64,  191}; // 1/8
    EXPECT_EQ(rate_colors8(img, 8), want);
    // No maximum: every pixel blue rather than a division by zero.
    std::vector<unsigned char> blue;
    for (int i = 0; i < 7; ++i) blue.insert(blue.end(), {0, 0, 255});
    EXPECT_EQ(rate_colors8(img, 0), blue);
}

TEST_F(ImageIo, RatePngHoldsTheColoursAndStatesItsScale) {
    Image img(3, 2);
    img.sample_count = {0, 16, 32, 48, 64, 100};
    write_rate_png(path("rate.png"), img, 64);
    const std::string bytes = file_bytes(path("rate.png"));
    EXPECT_EQ(png_rgb(bytes, 3, 2), rate_colors8(img, 64));
    EXPECT_NE(bytes.find("64 samples per pixel"), std::string::npos) << "the scale is not stated in the file";
    EXPECT_EQ(png_rgb(rate_png_bytes(img, 64), 3, 2), rate_colors8(img, 64));
}

// --- by extension, and failures ----------------------------------------------------------------

TEST_F(ImageIo, WriteImageChoosesTheFormatByExtensionInAnyCase) {
    const Image img = awkward_image();
    for (const char* name : {"a.png", "b.PNG", "c.Png"}) {
        write_image(path(name), img);
        EXPECT_EQ(file_bytes(path(name)).substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8)) << name;
    }
    for (const char* name : {"d.exr", "e.EXR"}) {
        write_image(path(name), img);
        expect_same_bits(read_image(path(name)), img);
    }
    for (const char* name : {"f.tiff", "g.png.txt", "h", "i.hdr", "exr"}) {
        try {
            write_image(path(name), img);
            ADD_FAILURE() << name << " was written";
        } catch (const std::runtime_error& e) {
            EXPECT_NE(std::string(e.what()).find(path(name)), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("unknown image format"), std::string::npos) << e.what();
        }
        EXPECT_FALSE(fs::exists(path(name))) << name;
    }
}

TEST_F(ImageIo, UnwritablePathsAreErrorsNamingThePath) {
    const Image img = awkward_image();
    const std::string png = path("missing/folder/a.png"), exr = path("missing/folder/a.exr"),
                      rate = path("missing/folder/r.png");
    auto expect_names = [](const std::string& p, auto&& write) {
        try {
            write();
            ADD_FAILURE() << p << " was written";
        } catch (const std::runtime_error& e) {
            EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what();
        }
    };
    expect_names(png, [&] { write_png(png, img); });
    expect_names(exr, [&] { write_exr(exr, img); });
    expect_names(rate, [&] { write_rate_png(rate, img, 8); });
}

TEST_F(ImageIo, UnreadableFilesAreErrorsNamingThePath) {
    const std::string missing = path("absent.exr");
    try {
        read_image(missing);
        ADD_FAILURE() << "read a missing file";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
    }
    const std::string text = path("text.exr");
    std::ofstream(text) << "not an image at all";
    try {
        read_image(text);
        ADD_FAILURE() << "read a text file as an image";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
    }
    // An EXR cut inside its header.
    std::vector<unsigned char> cut = exr_bytes(awkward_image());
    cut.resize(40);
    write_bytes(path("cut.exr"), cut);
    EXPECT_THROW(read_image(path("cut.exr")), std::runtime_error);
}

}  // namespace
}  // namespace tessera
