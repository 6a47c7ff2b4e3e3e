// AOVs: the light split sums to the image on every kind of scene, strategy and bounce setting;
// the geometric AOVs hold what a known scene makes them (a constant albedo, a plane at a known
// distance); a lambertian scene has no glossy light, a depth-1 render no indirect light; the
// multilayer EXR names its channels as compositors read them.
#include "engine/render/aov.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "engine/io/image_io.h"
#include "engine/render/film.h"
#include "engine/render/renderer.h"
#include "engine/scene/environment.h"
#include "engine/scene/procedural.h"
#include "tests/scratch_dir.h"
#include "tests/seen_whole.h"

namespace tessera {
namespace {

constexpr AovSet kLight = kLightAovs;
constexpr AovSet kAll = (AovSet(1) << kAovCount) - 1;

const AovPlane& plane(const RenderResult& r, Aov a) {
    for (const AovPlane& p : r.aovs)
        if (p.aov == a) return p;
    throw std::runtime_error(std::string("no plane ") + aov_info(a).name);
}

// Every pixel's light split sums to its colour, to float rounding of the parts.
void expect_split_sums_to_image(const RenderResult& r) {
    const size_t n = r.image.rgb.size();
    size_t bad = 0;
    double worst = 0;
    for (size_t i = 0; i < n; ++i) {
        double sum = 0, mag = std::abs(double(r.image.rgb[i]));
        for (Aov a : {Aov::emission, Aov::environment, Aov::diffuse_direct, Aov::diffuse_indirect, Aov::glossy_direct, Aov::glossy_indirect}) {
            const float v = plane(r, a).values[i];
            sum += v;
            mag += std::abs(double(v));
        }
        const double err = std::abs(sum - r.image.rgb[i]);
        worst = std::max(worst, err / (mag + 1e-6));
        if (err > 2e-5 * mag + 1e-6) ++bad;
    }
    EXPECT_EQ(bad, 0u) << "pixels whose split does not sum to the image (worst relative error " << worst << ")";
}

RenderSettings small(int spp = 4, int depth = 4) {
    RenderSettings s;
    s.width = 40;
    s.height = 30;
    s.spp = spp;
    s.max_depth = depth;
    s.threads = 2;
    s.aovs = kAll;
    return s;
}

TEST(Aov, LightSplitSumsToTheImageEverywhere) {
    struct Case {
        const char* scene;
        DirectLighting direct;
        bool environment;
        LightingOutput output;
        BounceMode bounces;
    };
    const Case cases[] = {
        {"builtin:cornell_spheres", DirectLighting::mis, false, LightingOutput::all, BounceMode::accumulate},
        {"builtin:cornell_spheres", DirectLighting::importance, false, LightingOutput::all, BounceMode::accumulate},
        {"builtin:cornell_spheres", DirectLighting::hemisphere, false, LightingOutput::all, BounceMode::accumulate},
        {"builtin:cornell_glossy", DirectLighting::mis, false, LightingOutput::all, BounceMode::accumulate},
        {"builtin:cornell_glossy", DirectLighting::importance, true, LightingOutput::all, BounceMode::accumulate},
        {"builtin:cornell_glossy", DirectLighting::hemisphere, true, LightingOutput::all, BounceMode::accumulate},
        {"builtin:lamp_room", DirectLighting::mis, false, LightingOutput::all, BounceMode::accumulate},
        {"builtin:cornell_spheres", DirectLighting::mis, true, LightingOutput::indirect, BounceMode::accumulate},
        {"builtin:cornell_glossy", DirectLighting::mis, false, LightingOutput::all, BounceMode::nth},
        {"builtin:furnace", DirectLighting::mis, false, LightingOutput::all, BounceMode::accumulate},
        {"builtin:displaced_sphere?triangles=2000", DirectLighting::mis, true, LightingOutput::all, BounceMode::accumulate},
    };
    // A sky brighter toward the top, so that environment light differs by direction.
    std::vector<float> sky(32 * 16 * 3);
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 32 * 3; ++x) sky[size_t(y) * 96 + size_t(x)] = 0.2f + 2.f * float(16 - y) / 16.f;
    const auto env = std::make_shared<const EnvironmentMap>(build_environment(32, 16, sky, "gradient"));
    for (const Case& c : cases) {
        SCOPED_TRACE(std::string(c.scene) + " direct " + std::to_string(int(c.direct)) + (c.environment ? " +environment" : ""));
        const RenderScene scene = build_render_scene(test::seen_whole(builtin_scene(c.scene)), {});
        RenderSettings s = small();
        s.direct = c.direct;
        s.output = c.output;
        s.bounces = c.bounces;
        if (c.environment) s.environment = env;
        const RenderResult r = render(scene, s);
        expect_split_sums_to_image(r);
        // Asking for AOVs changes nothing in the image.
        RenderSettings plain = s;
        plain.aovs = 0;
        EXPECT_EQ(render(scene, plain).image.rgb, r.image.rgb);
    }
}

TEST(Aov, TheSplitGoesWhereTheLightDoes) {
    const RenderScene box = build_render_scene(test::seen_whole(builtin_scene("builtin:cornell_box")), {});
    RenderSettings s = small(4, 1);
    const RenderResult direct_only = render(box, s);
    double emission = 0, direct = 0, indirect = 0, glossy = 0, environment = 0;
    for (size_t i = 0; i < direct_only.image.rgb.size(); ++i) {
        emission += plane(direct_only, Aov::emission).values[i];
        direct += plane(direct_only, Aov::diffuse_direct).values[i];
        indirect += plane(direct_only, Aov::diffuse_indirect).values[i];
        glossy += plane(direct_only, Aov::glossy_direct).values[i] + plane(direct_only, Aov::glossy_indirect).values[i];
        environment += plane(direct_only, Aov::environment).values[i];
    }
    EXPECT_GT(direct, 0.0);
    EXPECT_EQ(indirect, 0.0) << "max_depth 1 has no indirect light";
    EXPECT_EQ(glossy, 0.0) << "a diffuse box reflects no glossy light";
    EXPECT_EQ(environment, 0.0) << "nothing is seen beyond the box";
    s.max_depth = 4;
    const RenderResult bounced = render(box, s);
    double ind = 0;
    for (float v : plane(bounced, Aov::diffuse_indirect).values) ind += v;
    EXPECT_GT(ind, 0.0);
    // Walls that glow, seen directly: their emission is the emission pass, to float rounding (each
    // pixel takes its walls' exact coverage, seen_emitters.h; where two triangles share a pixel
    // their coverages sum to 1 in float).
    const RenderScene glow = build_render_scene(furnace_box(0.5f, 1.f), {});
    const RenderResult g = render(glow, small(2, 2));
    for (float v : plane(g, Aov::emission).values) EXPECT_NEAR(v, 1.f, 1e-5f);
}

TEST(Aov, GeometryOfAKnownScene) {
    // The furnace: a closed box of half-size 2, one diffuse material of albedo 0.6, the camera at
    // its centre looking down -z with a 90° view: every pixel sees the wall at z = -2 first.
    const float half = 2.f;
    const RenderScene scene = build_render_scene(furnace_box(0.6f, 0.1f, half), {});
    RenderSettings s = small(8, 2);
    s.width = s.height = 32;
    const RenderResult r = render(scene, s);
    const auto& albedo = plane(r, Aov::albedo).values;
    const auto& depth = plane(r, Aov::depth).values;
    const auto& position = plane(r, Aov::position).values;
    const auto& normal = plane(r, Aov::normal).values;
    for (size_t p = 0; p < size_t(s.width) * s.height; ++p) {
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(albedo[p * 3 + k], 0.6f, 1e-6f) << "pixel " << p;
        EXPECT_NEAR(position[p * 3 + 2], -half, 1e-4f) << "pixel " << p;
        EXPECT_NEAR(std::abs(normal[p * 3 + 2]), 1.f, 1e-5f) << "pixel " << p;
        // The nearest sample of the pixel: at least the plane's distance, at most its corner's.
        const int x = int(p) % s.width, y = int(p) / s.width;
        const float fx = std::max(std::abs(2.f * float(x) / s.width - 1.f), std::abs(2.f * float(x + 1) / s.width - 1.f));
        const float fy = std::max(std::abs(2.f * float(y) / s.height - 1.f), std::abs(2.f * float(y + 1) / s.height - 1.f));
        EXPECT_GE(depth[p], half * (1.f - 1e-5f));
        EXPECT_LE(depth[p], half * std::sqrt(1.f + fx * fx + fy * fy) * (1.f + 1e-5f));
    }
    // The centre pixels: the plane's distance to within their footprint.
    const size_t centre = size_t(s.height / 2) * s.width + size_t(s.width / 2);
    EXPECT_NEAR(depth[centre], half, half * 0.01f);
    EXPECT_EQ(plane(r, Aov::material_id).values[centre], 1.f);
    EXPECT_EQ(plane(r, Aov::object_id).values[centre], 1.f);
}

TEST(Aov, NothingSeenLeavesTheBackground) {
    // A camera looking away from the only mesh: depth is Blender's "nothing", ids are 0.
    SceneDescription d = furnace_box(0.5f, 0.f, 1.f, glm::vec3(0.f, 0.f, -100.f));
    d.camera->position = glm::vec3(0.f);
    d.camera->look_at = glm::vec3(0.f, 0.f, 1.f);
    const RenderScene scene = build_render_scene(d, {});
    const RenderResult r = render(scene, small(2, 1));
    for (float z : plane(r, Aov::depth).values) EXPECT_EQ(z, float(kNoDepth));
    for (float id : plane(r, Aov::object_id).values) EXPECT_EQ(id, 0.f);
    for (float a : plane(r, Aov::albedo).values) EXPECT_EQ(a, 0.f);
}

TEST(Aov, VarianceIsThatOfThePixelMean) {
    // A furnace of emission 1 and albedo 0 at depth 0: every sample is exactly 1, no variance.
    const RenderScene scene = build_render_scene(furnace_box(0.f, 1.f), {});
    const RenderResult r = render(scene, small(16, 0));
    for (float v : plane(r, Aov::variance).values) EXPECT_EQ(v, 0.f);
    // With bounces the samples differ: the variance of the mean is positive and falls as 1/n.
    const RenderScene lit = build_render_scene(test::seen_whole(builtin_scene("builtin:cornell_box")), {});
    RenderSettings s = small(8, 3);
    s.sampler = SamplerKind::independent;
    double v8 = 0, v32 = 0;
    const RenderResult r8 = render(lit, s);  // bound: a range-for over a temporary's member would dangle
    for (float v : plane(r8, Aov::variance).values) v8 += v;
    s.spp = 32;
    const RenderResult r32 = render(lit, s);
    for (float v : plane(r32, Aov::variance).values) v32 += v;
    EXPECT_GT(v8, 0.0);
    EXPECT_NEAR(v8 / v32, 4.0, 1.0) << "the variance of the mean falls as 1/n";
}

TEST(Aov, MultilayerExrNamesChannelsAsCompositorsReadThem) {
    const RenderScene scene = build_render_scene(test::seen_whole(builtin_scene("builtin:cornell_spheres")), {});
    const RenderResult r = render(scene, small(2, 2));
    const std::filesystem::path dir = test::scratch_dir("aov_exr");
    const std::string path = (dir / "passes.exr").string();
    write_layers_exr(path, r.image, r.aovs);
    const ChannelImage c = read_channels(path);
    for (const char* name : {"R", "G", "B", "samples", "albedo.R", "albedo.G", "albedo.B", "N.X", "N.Y", "N.Z", "Z", "P.X",
                             "object_id", "material_id", "emission.R", "environment.B", "diffuse_direct.G", "diffuse_indirect.R",
                             "glossy_direct.R", "glossy_indirect.B", "variance.R"})
        EXPECT_NE(std::find(c.names.begin(), c.names.end(), name), c.names.end()) << name;
    for (const char* name : {"CryptoObject00.R", "CryptoObject00.A", "CryptoObject02.B", "CryptoMaterial01.G"})
        EXPECT_NE(std::find(c.names.begin(), c.names.end(), name), c.names.end()) << name;
    EXPECT_EQ(c.names.size(), 4u + 3 * 10 + 3 + 2 * 2 * kCryptoRanks);
    // The values are the planes'.
    const std::vector<float> z = c.channel("Z");
    EXPECT_EQ(z, plane(r, Aov::depth).values);
    // One pass alone.
    const std::string one = (dir / "albedo.exr").string();
    write_aov_exr(one, r.image.width, r.image.height, plane(r, Aov::albedo));
    EXPECT_EQ(read_channels(one).names, (std::vector<std::string>{"albedo.R", "albedo.G", "albedo.B"}));
    test::remove_scratch_dir(dir);
}

TEST(Aov, NamesRoundTrip) {
    for (const AovInfo& i : kAovInfo) {
        Aov a;
        ASSERT_TRUE(aov_named(i.name, a));
        EXPECT_EQ(a, i.aov);
    }
    Aov a;
    EXPECT_FALSE(aov_named("beauty", a));
    EXPECT_EQ(aov_names(aov_bit(Aov::depth) | aov_bit(Aov::albedo)), (std::vector<std::string>{"albedo", "depth"}));
    // The film keeps only what is asked for.
    const Film f(4, 4, false, false, aov_bit(Aov::depth));
    EXPECT_EQ(f.aov_layout.stride, 1);
    EXPECT_EQ(f.aov.size(), 16u);
    EXPECT_TRUE(f.sum_odd.empty());
    EXPECT_EQ(Film(4, 4, false, false).aov.size(), 0u);
}

}  // namespace
}  // namespace tessera
