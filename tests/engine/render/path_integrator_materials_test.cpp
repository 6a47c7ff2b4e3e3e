// The path integrator with BSDFs other than Lambertian's: energy in the furnace, strategies that
// agree, delta lobes counted once.
#include <gtest/gtest.h>

#include "engine/io/scene_loader.h"
#include "engine/render/path_integrator.h"
#include "engine/scene/procedural.h"
#include "tests/engine/render/render_test_util.h"
#include "tests/test_paths.h"
#include "tests/test_scale.h"

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
    SceneDescription d = cornell_spheres();
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

// The CS184 material scenes load without a "rendered as diffuse" warning and render finite
// images whose strategies agree (CBspheres: a mirror and a glass sphere).
TEST(PathIntegratorMaterials, Cs184MaterialScenesRenderAsIntended) {
    TESSERA_REQUIRE_CS184(dir);
    for (const char* file : {"CBspheres.dae", "CBspheres_microfacet_al_ag.dae", "CBspheres_glossy.dae", "CBgems.dae",
                             "CBcoil.dae", "CBbunny_microfacet_cu.dae"}) {
        const SceneDescription d = load_scene(dir + "/sky/" + file);
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
