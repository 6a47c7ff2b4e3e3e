// The path integrator with BSDFs other than Lambertian's: energy in the furnace, strategies that
// agree, delta lobes counted once.
#include <gtest/gtest.h>

#include "engine/io/scene_loader.h"
#include "engine/render/path_integrator.h"
#include "engine/sampling/rng.h"
#include "engine/scene/procedural.h"
#include "engine/material/material.h"
#include "tests/engine/render/render_test_util.h"
#include "tests/test_paths.h"
#include "tests/test_scale.h"
#include "tests/seen_whole.h"

namespace tessera {
namespace {

using test::kStrategies;
using test::name;

// An enclosure that emits 1 and reflects nothing, around a sphere of `m` in front of the camera.
SceneDescription furnace_with(const MaterialDesc& m) {
    SceneDescription s = furnace_box(0.f, 1.f);
    s.materials.push_back(m);
    s.spheres.push_back({glm::vec3(0.f, 0.f, -0.5f), 0.35f, int(s.materials.size()) - 1, {}});
    return s;
}

RenderSettings furnace_settings(int depth, DirectLighting direct = DirectLighting::importance) {
    RenderSettings st;
    st.width = st.height = 32 / (test::kWorkScale > 1 ? 2 : 1);
    st.spp = 16;
    st.max_depth = depth;
    st.direct = direct;
    st.seed = 3;
    return st;
}

MaterialDesc glass(float ior) {
    MaterialDesc m;
    m.kind = MaterialKind::glass;
    m.albedo = glm::vec3(1.f);
    m.transmittance = glm::vec3(1.f);
    m.ior = ior;
    return m;
}

// Glass of index 1 is invisible, and so is a white mirror: every pixel is exactly the
// enclosure's 1 (a delta lobe's continuation counts the emission it finds, once).
TEST(PathIntegratorMaterials, IndexOneGlassAndWhiteMirrorAreInvisible) {
    MaterialDesc mirror;
    mirror.kind = MaterialKind::mirror;
    mirror.albedo = glm::vec3(1.f);
    for (const MaterialDesc& m : {glass(1.f), mirror})
        for (DirectLighting d : kStrategies) {
            const Image img = test::render_desc(furnace_with(m), furnace_settings(4, d)).image;
            for (size_t i = 0; i < img.rgb.size(); ++i) ASSERT_NEAR(img.rgb[i], 1.f, 1e-5f) << name(d) << " pixel " << i / 3;
        }
}

// Lossless glass of index 1.5 keeps the furnace uniform too, once paths are long enough to leave
// it: reflection and refraction are chosen by Fresnel and the η² radiance factors cancel on the
// way in and out.
TEST(PathIntegratorMaterials, DenseGlassConservesEnergy) {
    for (float ior : {1.5f, 2.4f}) {
        const Image img = test::render_desc(furnace_with(glass(ior)), furnace_settings(64)).image;
        const test::MeanEstimate m = test::iid_pixel_mean(img);
        EXPECT_NEAR(m.mean, 1.0, 5 * m.se + 2e-3) << "ior " << ior;
    }
}

// A rough conductor with F = 1 reflects at most what arrives and loses only what single
// scattering loses (a few per cent at α = 0.3, from the grazing pixels); a black one shows the
// enclosure only around it.
TEST(PathIntegratorMaterials, RoughConductorLosesOnlyMaskedEnergy) {
    MaterialDesc c;
    c.kind = MaterialKind::microfacet;
    c.roughness = 0.3f;
    c.eta = glm::vec3(1.f);
    c.k = glm::vec3(1e4f);
    for (DirectLighting d : kStrategies) {
        const Image img = test::render_desc(furnace_with(c), furnace_settings(8, d)).image;
        const test::MeanEstimate m = test::iid_pixel_mean(img);
        EXPECT_LE(m.mean, 1.0 + 5 * m.se) << name(d);
        EXPECT_GT(m.mean + 5 * m.se, 0.95) << name(d) << " se " << m.se;
    }
}

// Hemisphere, light and MIS sampling estimate the same image with glossy BSDFs: a Cornell box
// whose spheres are a Beckmann conductor and a glTF metal-dielectric mix, and whose walls are a
// normalised Phong lobe. MIS weights use bsdf_pdf, so a density that disagreed with sampling
// would move the MIS image away from the hemisphere one.
TEST(PathIntegratorMaterials, StrategiesAgreeOnGlossyMaterials) {
    SceneDescription d = test::seen_whole(cornell_spheres());
    MaterialDesc conductor;
    conductor.kind = MaterialKind::microfacet;
    conductor.roughness = 0.2f;
    conductor.eta = {0.2f, 0.92f, 1.1f};
    conductor.k = {3.9f, 2.45f, 2.14f};
    MaterialDesc gltf;
    gltf.kind = MaterialKind::metallic_roughness;
    gltf.albedo = {0.8f, 0.5f, 0.2f};
    gltf.metallic = 0.5f;
    gltf.roughness = 0.5f;
    MaterialDesc phong;
    phong.kind = MaterialKind::glossy;
    phong.albedo = glm::vec3(0.7f);
    phong.shininess = 8.f;
    d.materials.push_back(conductor);
    d.spheres[0].material = int(d.materials.size()) - 1;
    d.materials.push_back(gltf);
    d.spheres[1].material = int(d.materials.size()) - 1;
    d.materials[0] = phong;  // the white walls
    const RenderScene scene = build_render_scene(d, {});
    RenderSettings st;
    st.width = 48;
    st.height = 36;
    st.spp = 48 / test::kWorkScale + 4;
    st.light_rays = 2;
    st.max_depth = 3;
    test::expect_strategies_agree(scene, st);
}

MaterialDesc gltf_material(float metallic, float roughness, glm::vec3 base = glm::vec3(1.f)) {
    MaterialDesc m;
    m.kind = MaterialKind::metallic_roughness;
    m.albedo = base;
    m.metallic = metallic;
    m.roughness = roughness;
    return m;
}

// A closed furnace whose walls are a white glTF metal that emits 1, seen from inside: at depth m
// every pixel reads m + 1 when nothing is lost. A smooth metal (a delta lobe) loses nothing, so
// the image is exact under every strategy: light samples cannot find a mirror lobe, which is why
// the lobe is sampled from the BSDF whatever `direct` says. Rough metals lose only what single
// scattering masks, and every strategy estimates the same.
TEST(PathIntegratorMaterials, WhiteMetalFurnaceUnderEveryStrategy) {
    // 0.035: α = 1.2e-3, just rougher than a delta lobe, where D's precision once failed.
    for (float roughness : {0.f, 0.035f, 0.05f, 0.3f}) {
        SceneDescription d = furnace_box(0.f, 1.f);
        MaterialDesc metal = gltf_material(1.f, roughness);
        metal.emission = glm::vec3(1.f);
        metal.double_sided = true;
        d.materials[0] = metal;
        // The view stays within one wall: a camera ray that met an edge could take the other
        // face's normal there, a question of geometry rather than of the estimator.
        d.camera->vfov_deg = d.camera->hfov_deg = 60.f;
        const RenderScene scene = build_render_scene(d, {});
        for (int depth = 1; depth <= 3; ++depth) {
            double means[3], ses[3];
            for (int i = 0; i < 3; ++i) {
                RenderSettings st = furnace_settings(depth, kStrategies[i]);
                st.light_rays = 2;
                const Image img = render(scene, st).image;
                const test::MeanEstimate m = test::iid_pixel_mean(img);
                means[i] = m.mean;
                ses[i] = m.se;
                if (roughness == 0.f) {
                    for (size_t k = 0; k < img.rgb.size(); ++k)
                        ASSERT_NEAR(img.rgb[k], depth + 1.f, 1e-4f) << name(kStrategies[i]) << " depth " << depth << " pixel " << k / 3;
                } else {
                    EXPECT_LE(m.mean, depth + 1.0 + 5 * m.se) << name(kStrategies[i]) << " roughness " << roughness;
                    EXPECT_GT(m.mean, depth + 1.0 - 0.05 * depth) << name(kStrategies[i]) << " roughness " << roughness;
                }
            }
            for (int i = 1; i < 3; ++i)
                EXPECT_NEAR(means[i], means[0], 5 * std::hypot(ses[i], ses[0]) + 1e-6)
                    << name(kStrategies[i]) << " vs hemisphere, roughness " << roughness << " depth " << depth;
        }
    }
}

// A furnace that emits 1 and reflects nothing, around a flat patch of `m` seen at `theta_deg`
// from its normal through a 1° lens: every pixel's depth-1 value is the BSDF's directional
// albedo E(cos θ) = ∫ f cos θi dωi, which the test integrates from the model itself (its
// sampling weights, four million of them) and the render must reproduce under every strategy.
TEST(PathIntegratorMaterials, GlossyFurnaceKeepsTheModelsAlbedo) {
    struct Case {
        const char* what;
        MaterialDesc m;
    };
    std::vector<Case> cases;
    for (float r : {0.f, 0.05f, 0.3f, 0.7f}) {
        cases.push_back({"glTF metal", gltf_material(1.f, r, glm::vec3(0.9f))});
        cases.push_back({"glTF plastic", gltf_material(0.f, r, glm::vec3(0.8f))});
    }
    for (float a : {0.f, 0.05f, 0.3f}) {
        MaterialDesc c;
        c.kind = MaterialKind::microfacet;
        c.roughness = a;
        c.eta = {0.2f, 0.92f, 1.1f};
        c.k = {3.9f, 2.45f, 2.14f};
        cases.push_back({"Beckmann gold", c});
    }
    for (float e : {8.f, 400.f}) {
        MaterialDesc g;
        g.kind = MaterialKind::glossy;
        g.albedo = glm::vec3(0.7f);
        g.shininess = e;
        cases.push_back({"Phong", g});
    }
    for (const Case& c : cases) {
        for (float theta_deg : {0.f, 60.f, 80.f}) {
            const float th = glm::radians(theta_deg);
            // The model's own albedo at this angle, from its sampling weights.
            const Bsdf b = make_material(c.m).bsdf;
            const glm::vec3 wo(std::sin(th), 0.f, std::cos(th));
            Pcg32 rng(7, 1);
            const int n = 4'000'000 / test::kWorkScale;
            double sum = 0, sum2 = 0;
            for (int i = 0; i < n; ++i) {
                BsdfSample s;
                double w = 0;
                if (bsdf_sample(b, wo, rng.next_float(), {rng.next_float(), rng.next_float()}, s) && s.wi.z > 0.f) w = s.weight.x;
                sum += w;
                sum2 += w * w;
            }
            const double expect = sum / n, expect_se = std::sqrt(std::max(0.0, sum2 / n - expect * expect) / n);

            SceneDescription d = furnace_box(0.f, 1.f);
            d.materials.push_back(c.m);
            MeshDesc patch;
            patch.name = "patch";
            patch.material = int(d.materials.size()) - 1;
            patch.positions = {{-0.3f, -0.3f, 0.f}, {0.3f, -0.3f, 0.f}, {-0.3f, 0.3f, 0.f}, {0.3f, 0.3f, 0.f}};
            patch.indices = {0, 1, 2, 1, 3, 2};
            d.meshes.push_back(patch);
            d.camera->position = 0.5f * glm::vec3(std::sin(th), 0.f, std::cos(th));
            d.camera->look_at = glm::vec3(0.f);
            d.camera->vfov_deg = d.camera->hfov_deg = 1.f;
            const RenderScene scene = build_render_scene(d, {});
            for (DirectLighting dl : kStrategies) {
                RenderSettings st = furnace_settings(1, dl);
                st.width = st.height = 16;
                st.spp = 16;
                st.light_rays = 2;
                const Image img = render(scene, st).image;
                const test::MeanEstimate m = test::iid_pixel_mean(img);
                EXPECT_NEAR(m.mean, expect, 5 * std::hypot(m.se, expect_se) + 1e-4)
                    << c.what << " roughness " << c.m.roughness << " shininess " << c.m.shininess << " at " << theta_deg << "°, "
                    << name(dl);
            }
        }
    }
}

// Strategies agree on what glTF users render: smooth and rough metals and a smooth plastic
// (a delta coat over a diffuse base) in the Cornell box, whose small light only light samples
// find and whose mirror images only BSDF samples find.
TEST(PathIntegratorMaterials, StrategiesAgreeOnGltfMetalsAndPlastics) {
    for (float metal_roughness : {0.f, 0.05f, 0.3f}) {
        SceneDescription d = test::seen_whole(cornell_spheres());
        d.materials.push_back(gltf_material(1.f, metal_roughness, {1.f, 0.78f, 0.34f}));
        d.spheres[0].material = int(d.materials.size()) - 1;
        d.materials.push_back(gltf_material(0.f, metal_roughness == 0.3f ? 0.15f : 0.f, {0.2f, 0.4f, 0.8f}));
        d.spheres[1].material = int(d.materials.size()) - 1;
        const RenderScene scene = build_render_scene(d, {});
        RenderSettings st;
        st.width = 48;
        st.height = 36;
        st.spp = 48 / test::kWorkScale + 4;
        st.light_rays = 2;
        st.max_depth = 3;
        SCOPED_TRACE(metal_roughness);
        test::expect_strategies_agree(scene, st);
    }
}

// The CS184 material scenes load without a "rendered as diffuse" warning and render finite
// images whose strategies agree (CBspheres: a mirror and a glass sphere).
TEST(PathIntegratorMaterials, Cs184MaterialScenesRenderAsIntended) {
    TESSERA_REQUIRE_CS184(dir);
    for (const char* file : {"CBspheres.dae", "CBspheres_microfacet_al_ag.dae", "CBspheres_glossy.dae", "CBgems.dae",
                             "CBcoil.dae", "CBbunny_microfacet_cu.dae"}) {
        const SceneDescription d = test::seen_whole(load_scene(dir + "/sky/" + file));
        for (const std::string& w : d.warnings) EXPECT_EQ(w.find("rendered as diffuse"), std::string::npos) << file << ": " << w;
        RenderSettings st;
        st.width = 32;
        st.height = 24;
        st.spp = 4;
        st.max_depth = 4;
        st.direct = DirectLighting::mis;
        const RenderResult r = render(build_render_scene(d, {}), st);
        EXPECT_EQ(r.stats.nonfinite_samples, 0u) << file;
        double sum = 0;
        for (float v : r.image.rgb) sum += v;
        EXPECT_GT(sum, 0.0) << file;
    }
}

}  // namespace
}  // namespace tessera
