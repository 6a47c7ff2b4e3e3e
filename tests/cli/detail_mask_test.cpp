#include "cli/detail_mask.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace tessera {
namespace {

// A w × h picture of one kind of surface: its normal, depth and albedo per pixel, set by the test.
struct Planes {
    int w, h;
    std::vector<float> n, z, a;
    Planes(int w_, int h_) : w(w_), h(h_), n(size_t(w_) * h_ * 3, 0.f), z(size_t(w_) * h_, 2.f), a(size_t(w_) * h_ * 3, 0.5f) {
        for (size_t p = 0; p < z.size(); ++p) n[p * 3 + 2] = 1.f;
    }
    size_t at(int x, int y) const { return size_t(y) * size_t(w) + size_t(x); }
    void normal(int x, int y, float nx, float ny, float nz) {
        n[at(x, y) * 3] = nx, n[at(x, y) * 3 + 1] = ny, n[at(x, y) * 3 + 2] = nz;
    }
    std::vector<uint8_t> mask() const { return detail_mask(n.data(), z.data(), a.data(), w, h); }
};

int marked(const std::vector<uint8_t>& m) {
    int c = 0;
    for (uint8_t v : m) c += v;
    return c;
}

TEST(DetailMask, AFloorRecedingFastIsNotAnEdge) {
    // A floor seen at a grazing angle: its depth grows 5-8 % per row, which the first mask
    // (a step's size alone) took for an edge on every row. (Within two columns of the picture's
    // sides a diagonal step has no step beside it to compare with and counts by its size.)
    Planes s(12, 8);
    for (int y = 0; y < s.h; ++y)
        for (int x = 0; x < s.w; ++x) s.z[s.at(x, y)] = 1.f / (1.f - 0.05f * float(y));
    for (int y = 1; y < s.h; ++y) ASSERT_GT(s.z[s.at(0, y)] - s.z[s.at(0, y - 1)], 0.03f * s.z[s.at(0, y - 1)]);
    const std::vector<uint8_t> m = s.mask();
    for (int y = 0; y < s.h; ++y)
        for (int x = 2; x < s.w - 2; ++x) EXPECT_EQ(m[s.at(x, y)], 0) << x << "," << y;
}

TEST(DetailMask, ASmallSpheresTurningNormalIsNotAnEdge) {
    // A cylinder 20 pixels across: its normal turns 0.08-0.12 radians a pixel. (Within two rows
    // of the picture's top and bottom, a diagonal step has no step beside it to compare with,
    // and counts by its size: the rows checked are those inside.)
    Planes s(20, 8);
    for (int y = 0; y < s.h; ++y)
        for (int x = 0; x < s.w; ++x) {
            const float t = (float(x) + 0.5f) / 10.f - 1.f, phi = std::asin(t * 0.8f);
            s.normal(x, y, std::sin(phi), 0.f, std::cos(phi));
        }
    const float n0 = std::abs(s.n[s.at(1, 0) * 3] - s.n[s.at(0, 0) * 3]) + std::abs(s.n[s.at(1, 0) * 3 + 2] - s.n[s.at(0, 0) * 3 + 2]);
    ASSERT_GT(n0, 0.15f);  // a step the first mask took for an edge
    const std::vector<uint8_t> m = s.mask();
    for (int y = 2; y < s.h - 2; ++y)
        for (int x = 0; x < s.w; ++x) EXPECT_EQ(m[s.at(x, y)], 0) << x << "," << y;
}

TEST(DetailMask, ADepthStepMarksBothSides) {
    Planes s(16, 8);
    for (int y = 0; y < s.h; ++y)
        for (int x = 8; x < s.w; ++x) s.z[s.at(x, y)] = 3.f;
    const std::vector<uint8_t> m = s.mask();
    for (int y = 0; y < s.h; ++y)
        for (int x = 0; x < s.w; ++x) EXPECT_EQ(m[s.at(x, y)], x == 7 || x == 8 ? 1 : 0) << x << "," << y;
}

TEST(DetailMask, ACreaseAndAnAlbedoStepAreEdges) {
    Planes crease(16, 4), texture(16, 4);
    for (int y = 0; y < 4; ++y)
        for (int x = 8; x < 16; ++x) {
            crease.normal(x, y, 1.f, 0.f, 0.f);
            texture.a[texture.at(x, y) * 3 + 1] = 0.45f;
        }
    for (const Planes* s : {&crease, &texture}) {
        const std::vector<uint8_t> m = s->mask();
        EXPECT_EQ(marked(m), 2 * 4);
        EXPECT_EQ(m[s->at(7, 2)], 1);
        EXPECT_EQ(m[s->at(8, 2)], 1);
    }
}

TEST(DetailMask, ASurfacesRimAgainstTheVoidAndAThinObjectAreEdges) {
    // The void's depth is huge; a one-pixel wire in front of a wall steps out and back.
    Planes rim(10, 4), wire(10, 4);
    for (int y = 0; y < 4; ++y) {
        for (int x = 5; x < 10; ++x) rim.z[rim.at(x, y)] = 1e10f;
        wire.z[wire.at(4, y)] = 1.f;
    }
    const std::vector<uint8_t> r = rim.mask(), w = wire.mask();
    EXPECT_EQ(r[rim.at(4, 1)], 1);
    EXPECT_EQ(r[rim.at(5, 1)], 1);
    EXPECT_EQ(r[rim.at(2, 1)], 0);
    for (int x = 3; x <= 5; ++x) EXPECT_EQ(w[wire.at(x, 1)], 1) << x;
    EXPECT_EQ(w[wire.at(1, 1)], 0);
    EXPECT_EQ(w[wire.at(7, 1)], 0);
}

}  // namespace
}  // namespace tessera
