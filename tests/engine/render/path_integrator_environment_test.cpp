// The path integrator under an environment light: known irradiance, what escaping rays see, and
// strategies that agree.
#include <array>
#include <cmath>
#include <memory>

#include <gtest/gtest.h>

#include "engine/render/path_integrator.h"
#include "engine/scene/environment.h"
#include "engine/scene/procedural.h"
#include "tests/engine/render/render_test_util.h"
#include "tests/test_scale.h"

namespace tessera {
namespace {

using test::kStrategies;

// A floor of albedo `albedo` at y = 0, far wider than the view, seen from `eye`.
SceneDescription floor_scene(float albedo, glm::vec3 eye, glm::vec3 look_at) {
    SceneDescription s;
    s.source = "test:floor";
    MaterialDesc m;
    m.albedo = glm::vec3(albedo);
    s.materials.push_back(m);
    MeshDesc q;
    q.material = 0;
    q.flat_normals = true;
    q.positions = {{-100, 0, -100}, {-100, 0, 100}, {100, 0, 100}, {100, 0, -100}};
    q.indices = {0, 1, 2, 0, 2, 3};
    s.meshes.push_back(q);
    CameraDesc c;
    c.position = eye;
    c.look_at = look_at;
    c.up = {0, 0, -1};
    if (look_at.y == eye.y) c.up = {0, 1, 0};
    c.vfov_deg = 40.f;
    s.camera = c;
    return s;
}

std::shared_ptr<const EnvironmentMap> constant_sky(float L) {
    return std::make_shared<const EnvironmentMap>(build_environment(32, 16, std::vector<float>(32 * 16 * 3, L), "constant"));
}

RenderSettings settings(int depth, DirectLighting d, std::shared_ptr<const EnvironmentMap> env) {
    RenderSettings st;
    st.width = 24;
    st.height = 18;
    st.spp = 32 / test::kWorkScale + 4;
    st.max_depth = depth;
    st.direct = d;
    st.light_rays = 2;
    st.environment = std::move(env);
    return st;
}

// Each strategy's image mean under `sky` (spp_of(i) samples for kStrategies[i]), and the test
// that every pair agrees within 5 standard errors.
std::array<test::MeanEstimate, 3> strategies_agree(const RenderScene& scene, std::shared_ptr<const EnvironmentMap> sky,
                                                   int (*spp_of)(int)) {
    std::array<test::MeanEstimate, 3> m;
    for (int i = 0; i < 3; ++i) {
        RenderSettings st = settings(2, kStrategies[i], sky);
        st.spp = spp_of(i);
        m[size_t(i)] = test::mean_of_two_seeds(scene, st);
    }
    for (size_t i = 0; i < 3; ++i)
        for (size_t j = i + 1; j < 3; ++j)
            EXPECT_NEAR(m[i].mean, m[j].mean, 5 * std::hypot(m[i].se, m[j].se)) << i << " vs " << j;
    return m;
}

// A Lambertian floor under a uniform sky of radiance 1 reflects exactly its albedo: the
// irradiance is π from the upper hemisphere, with every strategy.
TEST(PathIntegratorEnvironment, KnownIrradianceUnderAUniformSky) {
    const RenderScene scene = build_render_scene(floor_scene(0.6f, {0, 1, 0}, {0, 0, 0}), {});
    for (DirectLighting d : kStrategies) {
        const Image img = render(scene, settings(1, d, constant_sky(1.f))).image;
        const test::MeanEstimate m = test::iid_pixel_mean(img);
        EXPECT_NEAR(m.mean, 0.6, 5 * m.se + 1e-5) << int(d);
    }
}

// Rays that leave the scene see the map: looking at the horizon, the upper half of the image
// is the sky's 2 exactly, the floor (depth 0: no light reflected) black.
TEST(PathIntegratorEnvironment, EscapingRaysSeeTheMap) {
    const RenderScene scene = build_render_scene(floor_scene(0.5f, {0, 1, 0}, {0, 1, -1}), {});
    const Image img = render(scene, settings(0, DirectLighting::importance, constant_sky(2.f))).image;
    for (int x = 0; x < img.width; ++x) {
        EXPECT_EQ(img.pixel(x, 0)[1], 2.f);
        EXPECT_EQ(img.pixel(x, img.height - 1)[1], 0.f);
    }
}

// Under a sky with a sun 10⁴ times brighter, hemisphere, light and MIS sampling estimate the
// same image of a floor with a sphere casting a shadow, two bounces deep.
TEST(PathIntegratorEnvironment, StrategiesAgreeUnderTheSun) {
    SceneDescription d = floor_scene(0.5f, {0, 2, 3}, {0, 0, 0});
    d.spheres.push_back({glm::vec3(0.f, 0.5f, 0.f), 0.5f, 0, {}});
    const RenderScene scene = build_render_scene(d, {});
    const auto sky = std::make_shared<const EnvironmentMap>(build_environment(128, 64, sky_environment(128, 64), "sky"));
    const auto m = strategies_agree(scene, sky, [](int i) { return i == 0 ? 256 / test::kWorkScale : 32 / test::kWorkScale + 4; });
    // Light sampling finds the sun: its error is far below the hemisphere's at fewer samples.
    EXPECT_LT(m[1].se, m[0].se);
    EXPECT_GT(m[1].mean, 0.1);
}

// The same with a glossy plastic floor and a rough gold sphere: the glossy lobes' light samples
// come from the compensated distribution under `mis` and `hemisphere` (all of them MIS-weighted)
// and from the full one under `importance` (whose diffuse part has them alone).
TEST(PathIntegratorEnvironment, GlossyStrategiesAgreeUnderTheSun) {
    SceneDescription d = floor_scene(0.5f, {0, 2, 3}, {0, 0, 0});
    d.materials[0].kind = MaterialKind::metallic_roughness;
    d.materials[0].roughness = 0.3f;
    MaterialDesc gold;
    gold.kind = MaterialKind::metallic_roughness;
    gold.albedo = {1.f, 0.78f, 0.34f};
    gold.metallic = 1.f;
    gold.roughness = 0.3f;
    d.materials.push_back(gold);
    d.spheres.push_back({glm::vec3(0.f, 0.5f, 0.f), 0.5f, 1, {}});
    const RenderScene scene = build_render_scene(d, {});
    const auto sky = std::make_shared<const EnvironmentMap>(build_environment(128, 64, sky_environment(128, 64), "sky"));
    const auto m = strategies_agree(scene, sky, [](int) { return 64 / test::kWorkScale + 4; });
    EXPECT_GT(m[2].mean, 0.1);
}

}  // namespace
}  // namespace tessera
