// Cryptomatte: ids are the specification's (MurmurHash3 of the name, as a float whose exponent is
// held finite; the manifest's hex as in its own example); a pixel's ranks are its samples' shares
// by object, largest first; the matte of an object over the image has the same mean as the
// first-sample object_id AOV's indicator (two unbiased estimators of its coverage).
#include "engine/render/cryptomatte.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>
#include <set>

#include <nlohmann/json.hpp>

#include "engine/render/film.h"
#include "engine/render/passes.h"
#include "engine/render/renderer.h"
#include "engine/scene/procedural.h"

namespace tessera {
namespace {

TEST(Cryptomatte, IdsAreTheSpecificationsHashes) {
    // The specification's example manifest: name to the hex of the float id's bits.
    EXPECT_EQ(crypto_hex(crypto_id(murmur3_32("bunny"))), "13851a76");
    EXPECT_EQ(crypto_hex(crypto_id(murmur3_32("default"))), "42c9679f");
    EXPECT_EQ(crypto_hex(crypto_id(murmur3_32("bunny_porcelain_mat"))), "b24b26d4");
    // Exponents 0 and 255 are held at 1 and 254: no denormal, infinity or NaN is an id.
    EXPECT_EQ(crypto_hex(crypto_id(0x00000001u)), "00800001");
    EXPECT_EQ(crypto_hex(crypto_id(0xffffffffu)), "ff7fffff");
    for (uint32_t h : {0u, 0x7f800000u, 0x7fc00000u, 0x80000000u, 0xff800001u}) {
        const float f = crypto_id(h);
        EXPECT_TRUE(std::isnormal(f)) << std::hex << h;
    }
    EXPECT_EQ(crypto_key("CryptoObject").size(), 7u);
    EXPECT_EQ(crypto_key("CryptoObject"), crypto_key("CryptoObject"));
    EXPECT_NE(crypto_key("CryptoObject"), crypto_key("CryptoMaterial"));
}

TEST(Cryptomatte, RanksAreSamplesByIdLargestFirstAndKeepSix) {
    double ranks[2 * kCryptoRanks] = {};
    // Ids 1..8 with 1..8 samples each in an interleaved order; 7 and 8 arrive when six are held.
    const int counts[9] = {0, 3, 1, 4, 1, 5, 9, 2, 6};
    for (int round = 0; round < 9; ++round)
        for (uint32_t id = 1; id <= 8; ++id)
            if (round < counts[id]) add_crypto_sample(ranks, id * 1000);
    float out[2 * kCryptoRanks];
    const double samples = 31;
    resolve_crypto(ranks, samples, out);
    // Held: ids 1..6 (they came first); 7 and 8 dropped. Ranked 6 (9), 5 (5), 3 (4), 1 (3), then
    // 2 and 4 (one each; ties by id).
    const uint32_t order[6] = {6, 5, 3, 1, 2, 4};
    for (int r = 0; r < kCryptoRanks; ++r) {
        EXPECT_EQ(out[2 * r], crypto_id(order[r] * 1000)) << r;
        EXPECT_FLOAT_EQ(out[2 * r + 1], float(counts[order[r]] / samples)) << r;
    }
    // An empty pixel has no ranks.
    const double none[2 * kCryptoRanks] = {};
    resolve_crypto(none, 0, out);
    for (float v : out) EXPECT_EQ(v, 0.f);
}

TEST(Cryptomatte, ManifestNamesEveryIdOnce) {
    const auto meta = crypto_metadata("CryptoObject", {"floor", "sphere 0", "floor"});
    std::map<std::string, std::string> m(meta.begin(), meta.end());
    const std::string p = "cryptomatte/" + crypto_key("CryptoObject") + "/";
    EXPECT_EQ(m[p + "name"], "CryptoObject");
    EXPECT_EQ(m[p + "hash"], "MurmurHash3_32");
    EXPECT_EQ(m[p + "conversion"], "uint32_to_float32");
    const nlohmann::json manifest = nlohmann::json::parse(m[p + "manifest"]);
    EXPECT_EQ(manifest.size(), 2u);
    EXPECT_EQ(manifest["floor"], crypto_hex(crypto_id(murmur3_32("floor"))));
    EXPECT_EQ(manifest["sphere 0"], crypto_hex(crypto_id(murmur3_32("sphere 0"))));
    // A name that is not UTF-8 does not stop the file being written.
    const std::string bad = "mesh \xff\xfe";
    const auto with_bad = crypto_metadata("CryptoObject", {bad});
    EXPECT_EQ(nlohmann::json::parse(with_bad.back().second).size(), 1u);
    // Past kCryptoManifestNames names, no manifest (it is optional), the rest as before.
    std::vector<std::string> many(kCryptoManifestNames + 1);
    for (size_t i = 0; i < many.size(); ++i) many[i] = "mesh " + std::to_string(i);
    const auto big = crypto_metadata("CryptoObject", many);
    EXPECT_EQ(big.size(), 3u);
    for (const auto& [k, v] : big) EXPECT_EQ(k.find("manifest"), std::string::npos);
}

const AovPlane& plane(const RenderResult& r, Aov a) {
    for (const AovPlane& p : r.aovs)
        if (p.aov == a) return p;
    throw std::runtime_error(std::string("no plane ") + aov_info(a).name);
}

// Past kCryptoManifestNames a header holds no manifest; the report says so (it said nothing,
// and a compositor showed ids without names).
TEST(Cryptomatte, AManifestLeftOutIsReported) {
    RenderScene scene = build_render_scene(builtin_scene("builtin:cornell_spheres"), {});
    RenderSettings s;
    s.width = 8;
    s.height = 8;
    s.aovs = aov_bit(Aov::crypto_object) | aov_bit(Aov::crypto_material);
    auto left_out_of = [&] {
        std::vector<std::string> built, left_out;
        const Film film(s.width, s.height, false, false, s.aovs);
        describe_render(scene, s, film, built, left_out);
        std::string all;
        for (const std::string& l : left_out) all += l + "\n";
        return all;
    };
    EXPECT_EQ(left_out_of().find("Cryptomatte manifest"), std::string::npos);
    scene.object_names.resize(kCryptoManifestNames + 1, "object");
    const std::string all = left_out_of();
    EXPECT_NE(all.find("Cryptomatte manifest of objects: 20001 names"), std::string::npos) << all;
    EXPECT_EQ(all.find("Cryptomatte manifest of materials"), std::string::npos) << all;
    EXPECT_TRUE(crypto_metadata("CryptoObject", scene.object_names).size() < crypto_metadata("CryptoObject", {"a"}).size())
        << "the header itself has no manifest";
}

TEST(Cryptomatte, CoverageOfARenderedScene) {
    // The open Cornell box with two spheres: walls, spheres and the void around the box.
    SceneDescription d = builtin_scene("builtin:cornell_spheres");
    d.camera->focal_px = 0.f;  // the whole box in view (its focal length is for 800×600)
    const RenderScene scene = build_render_scene(d, {});
    ASSERT_EQ(scene.object_names.size(), scene.object_hashes.size());
    std::set<float> objects, materials;
    for (uint32_t h : scene.object_hashes) objects.insert(crypto_id(h));
    for (uint32_t h : scene.material_hashes) materials.insert(crypto_id(h));
    EXPECT_TRUE(objects.count(crypto_id(murmur3_32("floor"))));
    EXPECT_TRUE(objects.count(crypto_id(murmur3_32("sphere 1"))));
    EXPECT_TRUE(materials.count(crypto_id(murmur3_32("white"))));
    RenderSettings s;
    s.width = 48;
    s.height = 36;
    s.spp = 64;
    s.max_depth = 1;
    s.threads = 2;
    s.aovs = aov_bit(Aov::crypto_object) | aov_bit(Aov::crypto_material) | aov_bit(Aov::object_id) | aov_bit(Aov::depth);
    const RenderResult r = render(scene, s);
    const auto& co = plane(r, Aov::crypto_object).values;
    const auto& cm = plane(r, Aov::crypto_material).values;
    const auto& first = plane(r, Aov::object_id).values;
    const size_t n = size_t(s.width) * s.height;
    size_t mixed = 0, empty = 0;
    // An object's matte summed over the image, and its first-sample indicator summed: both
    // estimate the pixels it covers.
    std::map<float, double> matte, indicator;
    for (size_t p = 0; p < n; ++p) {
        for (const auto* v : {&co, &cm}) {
            const float* px = &(*v)[p * 2 * kCryptoRanks];
            double sum = 0;
            for (int k = 0; k < kCryptoRanks; ++k) {
                sum += px[2 * k + 1];
                if (k > 0) {
                    EXPECT_LE(px[2 * k + 1], px[2 * k - 1]) << "ranked by coverage, pixel " << p;
                }
                if (px[2 * k + 1] > 0) {
                    EXPECT_TRUE((v == &co ? objects : materials).count(px[2 * k])) << "an id of the scene's";
                } else {
                    EXPECT_EQ(px[2 * k], 0.f);
                }
            }
            EXPECT_LE(sum, 1.0 + 1e-5) << "pixel " << p;
        }
        const float* px = &co[p * 2 * kCryptoRanks];
        mixed += px[3] > 0.f;
        empty += px[1] == 0.f;
        for (int k = 0; k < kCryptoRanks; ++k)
            if (px[2 * k + 1] > 0) matte[px[2 * k]] += px[2 * k + 1];
        if (first[p] > 0) indicator[crypto_id(scene.object_hashes[size_t(first[p]) - 1])] += 1.0;
        // A pixel every sample of which hit one object: that object, covering all of it.
        if (px[1] == 1.f) {
            EXPECT_EQ(px[0], crypto_id(scene.object_hashes[size_t(first[p]) - 1])) << "pixel " << p;
        }
    }
    EXPECT_GT(mixed, size_t(s.width)) << "pixels on an edge between objects hold two ranks";
    EXPECT_GT(empty, 0u) << "the void around the box";
    // Equal means: the matte (64 samples a pixel) against one sample's indicator. Their
    // difference is the indicator's noise: a Bernoulli draw in each partly covered pixel, so
    // within 5 standard deviations of the sum of p(1-p) over the pixels.
    ASSERT_FALSE(matte.empty());
    for (const auto& [id, area] : matte) {
        double var = 0;
        for (size_t p = 0; p < n; ++p)
            for (int k = 0; k < kCryptoRanks; ++k)
                if (co[p * 2 * kCryptoRanks + 2 * k] == id) {
                    const double c = co[p * 2 * kCryptoRanks + 2 * k + 1];
                    var += c * (1 - c);
                }
        EXPECT_NEAR(indicator[id], area, 5 * std::sqrt(var) + 1e-9) << "object " << crypto_hex(id);
    }
}

}  // namespace
}  // namespace tessera
