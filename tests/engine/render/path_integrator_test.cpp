#include "engine/render/path_integrator.h"

#include <gtest/gtest.h>

#include "engine/io/scene_loader.h"
#include "engine/scene/procedural.h"
#include "tests/engine/render/render_test_util.h"
#include "tests/test_paths.h"
#include "tests/test_scale.h"
#include "tests/seen_whole.h"

namespace tessera {
namespace {

using test::kStrategies;
using test::name;

RenderSettings furnace_settings(DirectLighting direct, int depth, float rr) {
    RenderSettings s;
    s.width = 32 / (test::kWorkScale > 1 ? 2 : 1);
    s.height = s.width;
    s.spp = 16;
    s.max_depth = depth;
    s.direct = direct;
    s.russian_roulette = rr;
    s.seed = 17;
    return s;
}

// White furnace: walls that emit 1 and reflect with albedo a give Σ_{k ≤ depth} a^k exactly,
// at every pixel, for every strategy, with and without Russian roulette.
TEST(PathIntegrator, WhiteFurnace) {
    const float a = 0.5f;
    for (int depth : {0, 1, 3, 6}) {
        double expected = 0;
        for (int k = 0; k <= depth; ++k) expected += std::pow(a, k);
        for (DirectLighting d : kStrategies) {
            for (float rr : {0.f, 0.6f}) {
                const Image img = test::render_desc(furnace_box(a, 1.f), furnace_settings(d, depth, rr)).image;
                const test::MeanEstimate m = test::iid_pixel_mean(img);
                // 5 standard errors, plus float rounding of the sums.
                EXPECT_NEAR(m.mean, expected, 5 * m.se + 1e-5 * expected)
                    << name(d) << " depth " << depth << " rr " << rr << " se " << m.se;
            }
        }
    }
}

// The estimate stays finite and unbiased at depth 1000 with Russian roulette, and for albedo
// 0 and 1 (albedo 1 with depth n gives exactly n + 1).
TEST(PathIntegrator, FurnaceExtremes) {
    {
        const Image img = test::render_desc(furnace_box(0.8f, 1.f), furnace_settings(DirectLighting::importance, 1000, 0.8f)).image;
        const test::MeanEstimate m = test::iid_pixel_mean(img);
        EXPECT_NEAR(m.mean, (1 - std::pow(0.8, 1001)) / 0.2, 5 * m.se + 1e-4);
    }
    {
        const Image img = test::render_desc(furnace_box(1.f, 1.f), furnace_settings(DirectLighting::mis, 10, 0.f)).image;
        const test::MeanEstimate m = test::iid_pixel_mean(img);
        EXPECT_NEAR(m.mean, 11.0, 5 * m.se + 1e-4);
    }
    {
        const Image img = test::render_desc(furnace_box(0.f, 1.f), furnace_settings(DirectLighting::importance, 5, 0.f)).image;
        EXPECT_NEAR(test::iid_pixel_mean(img).mean, 1.0, 1e-6);
    }
}

// The furnace at 1e-4 and 1e4 and far from the origin: self-intersection would darken it.
TEST(PathIntegrator, FurnaceAtExtremeScales) {
    for (auto [scale, offset] : {std::pair{1e-4f, 0.f}, {1e4f, 0.f}, {1.f, 1e4f}, {1.f, 1e5f}}) {
        const Image img = test::render_desc(furnace_box(0.5f, 1.f, scale, glm::vec3(offset)),
                                            furnace_settings(DirectLighting::importance, 4, 0.f)).image;
        const test::MeanEstimate m = test::iid_pixel_mean(img);
        EXPECT_NEAR(m.mean, 1.9375, 5 * m.se + 1e-5) << "scale " << scale << " offset " << offset;
    }
}

// Bounce-by-bounce images sum to the accumulated one (equal means; same seeds differ in paths,
// so compare within noise).
TEST(PathIntegrator, NthBouncesSumToAccumulate) {
    const float a = 0.6f;
    for (int k = 0; k <= 3; ++k) {
        RenderSettings s = furnace_settings(DirectLighting::importance, k, 0.f);
        s.bounces = BounceMode::nth;
        const test::MeanEstimate m = test::iid_pixel_mean(test::render_desc(furnace_box(a, 1.f), s).image);
        EXPECT_NEAR(m.mean, std::pow(a, k), 5 * m.se + 1e-6) << "bounce " << k;
    }
}

// Known irradiance: a Lambertian floor under a square lamp of side 2s at height h, seen at the
// point below the lamp's centre, reflects albedo · L · F with F the point-to-square form
// factor (four corner rectangles, Howell's catalogue C-11).
TEST(PathIntegrator, KnownIrradianceUnderSquareLight) {
    const float s = 0.5f, h = 1.f, L = 4.f, albedo = 0.8f;
    SceneDescription d;
    d.materials.push_back({});
    d.materials[0].albedo = glm::vec3(albedo);
    MaterialDesc lamp;
    lamp.kind = MaterialKind::emission;
    lamp.albedo = glm::vec3(0.f);
    lamp.emission = glm::vec3(L);
    d.materials.push_back(lamp);
    MeshDesc floor;
    floor.positions = {{-50, 0, -50}, {50, 0, -50}, {50, 0, 50}, {-50, 0, 50}};
    floor.indices = {0, 2, 1, 0, 3, 2};
    floor.material = 0;
    MeshDesc light;
    light.positions = {{-s, h, -s}, {s, h, -s}, {s, h, s}, {-s, h, s}};
    light.indices = {0, 1, 2, 0, 2, 3};  // normal −y: emits downward
    light.material = 1;
    d.meshes = {floor, light};
    CameraDesc c;
    c.position = {0, 0.5f, 0};
    c.look_at = {0, 0, 0};
    c.up = {0, 0, -1};
    c.focal_px = 1e7f;  // a pencil of rays: every pixel sees the point below the centre
    d.camera = c;
    const double X = s / h;
    const double Fc = 1 / (2 * M_PI) * 2 * (X / std::sqrt(1 + X * X) * std::atan(X / std::sqrt(1 + X * X)));
    const double expected = albedo * L * 4 * Fc;
    for (DirectLighting dl : kStrategies) {
        RenderSettings st;
        st.width = st.height = 16;
        st.spp = 64;
        st.light_rays = 4;
        st.max_depth = 1;
        st.direct = dl;
        const test::MeanEstimate m = test::iid_pixel_mean(test::render_desc(d, st).image);
        EXPECT_NEAR(m.mean, expected, 5 * m.se + 1e-5) << name(dl) << " se " << m.se;
    }
}

// All three strategies estimate the same image of CBspheres_lambertian (the CS184 starter's
// light pdf error makes light sampling ~35% too bright; this catches anything near that).
TEST(PathIntegrator, StrategiesAgreeOnCBspheresLambertian) {
    TESSERA_REQUIRE_CS184(dir);
    const SceneDescription d = test::seen_whole(load_scene(dir + "/sky/CBspheres_lambertian.dae"));
    const RenderScene scene = build_render_scene(d, {});
    RenderSettings st;
    st.width = 64;
    st.height = 48;
    st.spp = 32 / test::kWorkScale + 2;
    st.light_rays = 2;
    st.max_depth = 2;
    test::expect_strategies_agree(scene, st);
}

// Russian roulette changes the variance, never the mean (a Cornell box, depth 4).
TEST(PathIntegrator, RussianRouletteIsUnbiased) {
    const RenderScene scene = build_render_scene(test::seen_whole(cornell_spheres()), {});
    double means[2], ses[2];
    int i = 0;
    for (float rr : {0.f, 0.5f}) {
        RenderSettings st;
        st.width = 48;
        st.height = 36;
        st.spp = 32 / test::kWorkScale + 2;
        st.max_depth = 4;
        st.russian_roulette = rr;
        st.seed = 3;
        const Image a = render(scene, st).image;
        st.seed = 4;
        const Image b = render(scene, st).image;
        const test::MeanEstimate m = test::paired_mean(a, b);
        means[i] = m.mean;
        ses[i++] = m.se;
    }
    EXPECT_NEAR(means[1], means[0], 5 * std::hypot(ses[0], ses[1]));
}

TEST(PathIntegrator, NoLightsGivesBlackWithoutShadowRays) {
    SceneDescription d = cornell_spheres();
    d.materials[3].emission = glm::vec3(0.f);  // the lamp
    d.materials[3].kind = MaterialKind::diffuse;
    const RenderScene scene = build_render_scene(d, {});
    EXPECT_FALSE(scene.has_lights());
    RenderSettings st;
    st.width = 16;
    st.height = 12;
    st.max_depth = 3;
    const RenderResult r = render(scene, st);
    EXPECT_EQ(r.stats.shadow_rays, 0u);
    for (float v : r.image.rgb) ASSERT_EQ(v, 0.f);
}

}  // namespace
}  // namespace tessera

namespace tessera {
namespace {

// Direct-only plus indirect-only equals everything, in the furnace: 1 + a and Σ_{k=2..d} a^k.
TEST(PathIntegrator, DirectPlusIndirectIsAll) {
    const float a = 0.5f;
    RenderSettings s = furnace_settings(DirectLighting::importance, 4, 0.f);
    s.output = LightingOutput::direct;
    const test::MeanEstimate direct = test::iid_pixel_mean(test::render_desc(furnace_box(a, 1.f), s).image);
    s.output = LightingOutput::indirect;
    const test::MeanEstimate indirect = test::iid_pixel_mean(test::render_desc(furnace_box(a, 1.f), s).image);
    EXPECT_NEAR(direct.mean, 1.5, 5 * direct.se + 1e-6);
    EXPECT_NEAR(indirect.mean, 0.25 + 0.125 + 0.0625, 5 * indirect.se + 1e-6);
}

}  // namespace
}  // namespace tessera

namespace tessera {
namespace {

// Choosing one light by power per sample estimates the same image as sampling every light.
TEST(PathIntegrator, LightSelectionByPowerIsUnbiased) {
    const RenderScene scene = build_render_scene(many_lights(16), {});
    ASSERT_EQ(scene.area_lights.size(), 16u);
    double means[2][2], ses[2][2];
    for (int mis = 0; mis < 2; ++mis) {
        for (int k = 0; k < 2; ++k) {
            RenderSettings st;
            st.width = 40;
            st.height = 30;
            st.spp = 16 / test::kWorkScale + 2;
            st.light_rays = 4;
            st.max_depth = 2;
            st.direct = mis ? DirectLighting::mis : DirectLighting::importance;
            st.light_selection = k ? LightSelection::power : LightSelection::all;
            st.seed = 5;
            const Image a = render(scene, st).image;
            st.seed = 6;
            const Image b = render(scene, st).image;
            const test::MeanEstimate m = test::paired_mean(a, b);
            means[mis][k] = m.mean;
            ses[mis][k] = m.se;
        }
        EXPECT_NEAR(means[mis][1], means[mis][0], 5 * std::hypot(ses[mis][0], ses[mis][1])) << (mis ? "mis" : "importance");
    }
}

}  // namespace
}  // namespace tessera

namespace tessera {
namespace {

// The whole image's mean over six seeds, with its standard error from the seeds' spread: for
// equal-mean tests between two ways of rendering the same image.
test::MeanEstimate mean_over_seeds(const RenderScene& scene, RenderSettings s) {
    const int seeds = 6;
    std::vector<double> m;
    for (int seed = 1; seed <= seeds; ++seed) {
        s.seed = uint64_t(seed);
        const Image img = render(scene, s).image;
        double sum = 0;
        for (float v : img.rgb) sum += v;
        m.push_back(sum / double(img.rgb.size()));
    }
    double mean = 0, var = 0;
    for (double x : m) mean += x / seeds;
    for (double x : m) var += (x - mean) * (x - mean) / (seeds - 1);
    return {mean, std::sqrt(var / seeds)};
}

void expect_equal_means(const test::MeanEstimate& a, const test::MeanEstimate& b, const char* what) {
    const double se = std::sqrt(a.se * a.se + b.se * b.se);
    EXPECT_NEAR(a.mean, b.mean, 4.5 * se + 1e-6) << what << ": " << a.mean << " against " << b.mean << ", se " << se;
}

// Sobol points and independent numbers estimate the same image: the Cornell box with spheres,
// MIS, three bounces.
TEST(PathIntegrator, SobolAndIndependentSamplingAgree) {
    const RenderScene scene = build_render_scene(test::seen_whole(cornell_spheres()), {});
    RenderSettings s;
    s.width = 40;
    s.height = 30;
    s.spp = 8;
    s.max_depth = 3;
    s.direct = DirectLighting::mis;
    s.sampler = SamplerKind::independent;
    const test::MeanEstimate independent = mean_over_seeds(scene, s);
    s.sampler = SamplerKind::sobol;
    expect_equal_means(independent, mean_over_seeds(scene, s), "independent against Sobol");
}

// Light selection by the light tree is unbiased: the furnace sphere (128 emitting triangles)
// stays exact with light sampling and with MIS, and on the scattered-lights box the tree and
// sampling every light agree in the mean.
TEST(PathIntegrator, LightTreeKeepsTheFurnaceExact) {
    for (DirectLighting d : {DirectLighting::importance, DirectLighting::mis})
        for (SamplerKind k : {SamplerKind::independent, SamplerKind::sobol}) {
            RenderSettings s = furnace_settings(d, 3, 0.f);
            s.light_selection = LightSelection::tree;
            s.sampler = k;
            const test::MeanEstimate m = test::iid_pixel_mean(test::render_desc(furnace_sphere(0.5f, 1.f), s).image);
            EXPECT_NEAR(m.mean, 1.875, 5 * m.se + 1e-6) << "mis " << (d == DirectLighting::mis) << " sobol " << (k == SamplerKind::sobol);
        }
}

TEST(PathIntegrator, LightTreeAndEveryLightAgree) {
    const RenderScene scene = build_render_scene(scattered_lights(60), {});
    RenderSettings s;
    s.width = 32;
    s.height = 24;
    s.spp = 8;
    s.max_depth = 2;
    s.light_rays = 2;
    s.direct = DirectLighting::mis;
    s.light_selection = LightSelection::all;
    const test::MeanEstimate all = mean_over_seeds(scene, s);
    s.light_selection = LightSelection::tree;
    expect_equal_means(all, mean_over_seeds(scene, s), "every light against the tree");
}

// The same on the lamp field, where what matters is distance and occlusion (lamps among
// blocks): light sampling and MIS, the tree against every lamp.
TEST(PathIntegrator, LightTreeAndEveryLightAgreeAmongBlocks) {
    const RenderScene scene = build_render_scene(lamp_field(150), {});
    for (DirectLighting d : {DirectLighting::importance, DirectLighting::mis}) {
        RenderSettings s;
        s.width = 32;
        s.height = 24;
        s.spp = 8;
        s.max_depth = 2;
        s.direct = d;
        s.light_selection = LightSelection::all;
        const test::MeanEstimate all = mean_over_seeds(scene, s);
        s.light_selection = LightSelection::tree;
        expect_equal_means(all, mean_over_seeds(scene, s), d == DirectLighting::mis ? "MIS" : "light sampling");
    }
}

// Automatic selection takes the tree above kTreeAboveLights area lights and every light up to
// it, and renders exactly what the explicit choice renders.
TEST(PathIntegrator, AutomaticLightSelectionFollowsTheLightCount) {
    const RenderScene few = build_render_scene(many_lights(int(kTreeAboveLights)), {});
    const RenderScene many = build_render_scene(many_lights(int(kTreeAboveLights) + 1), {});
    ASSERT_EQ(few.area_lights.size(), kTreeAboveLights);
    EXPECT_EQ(chosen_light_selection(few, LightSelection::automatic), LightSelection::all);
    EXPECT_EQ(chosen_light_selection(many, LightSelection::automatic), LightSelection::tree);
    EXPECT_EQ(chosen_light_selection(many, LightSelection::power), LightSelection::power);
    RenderSettings s;
    s.width = 24;
    s.height = 16;
    s.spp = 2;
    s.direct = DirectLighting::mis;
    for (const RenderScene* scene : {&few, &many}) {
        s.light_selection = LightSelection::automatic;
        const Image a = render(*scene, s).image;
        s.light_selection = chosen_light_selection(*scene, LightSelection::automatic);
        EXPECT_EQ(a.rgb, render(*scene, s).image.rgb) << scene->area_lights.size() << " lights";
    }
}

}  // namespace
}  // namespace tessera
