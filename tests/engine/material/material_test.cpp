// Holds engine/material/material.cpp to material.h: make_material turns each loader kind into
// the BSDF it names (CS184's mirror, glass, Beckmann conductor and normalised Phong; emission and
// diffuse as Lambertian; glTF metallic-roughness) and carries over exactly the parameters that
// BSDF reads, with the documented conversions and clamps (α = roughness² for glTF, α = roughness
// for the Beckmann conductor, no negative exponent or specular factor, metallic in [0, 1]); the
// emission and two-sidedness pass through for every kind; and emitter_material is an emitter that
// reflects nothing. (bsdf_test.cpp tests the BSDFs themselves.)
#include "engine/material/material.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace tessera {
namespace {

MaterialDesc desc(MaterialKind kind) {
    MaterialDesc d;
    d.kind = kind;
    d.albedo = {0.9f, 0.6f, 0.3f};
    d.transmittance = {0.8f, 0.7f, 0.1f};
    d.ior = 1.33f;
    d.roughness = 0.4f;
    d.metallic = 0.25f;
    d.specular = 0.7f;
    d.shininess = 30.f;
    d.eta = {0.2f, 0.92f, 1.1f};
    d.k = {3.9f, 2.45f, 2.14f};
    return d;
}

// Emission and double_sided pass through whatever the kind; a fresh material names no textures
// (build_render_scene attaches them).
TEST(Material, EmissionAndSidednessPassThroughForEveryKind) {
    for (MaterialKind kind : {MaterialKind::diffuse, MaterialKind::emission, MaterialKind::mirror, MaterialKind::glass,
                              MaterialKind::microfacet, MaterialKind::glossy, MaterialKind::metallic_roughness}) {
        MaterialDesc d = desc(kind);
        d.emission = {0.f, 2.5f, 0.f};
        d.double_sided = true;
        const Material m = make_material(d);
        EXPECT_EQ(m.emission, d.emission) << int(kind);
        EXPECT_TRUE(m.emissive()) << int(kind);
        EXPECT_TRUE(m.double_sided) << int(kind);
        EXPECT_EQ(m.textures, kNoTextures) << int(kind);
        EXPECT_EQ(m.bsdf.albedo, d.albedo) << int(kind) << ": every kind keeps the albedo (reflectance, base colour)";

        d.emission = glm::vec3(0.f);
        d.double_sided = false;
        const Material dark = make_material(d);
        EXPECT_FALSE(dark.emissive()) << int(kind);
        EXPECT_FALSE(dark.double_sided) << int(kind);
    }
    // One positive channel is enough to emit; zero everywhere is not.
    MaterialDesc d = desc(MaterialKind::emission);
    for (glm::vec3 e : {glm::vec3(1e-6f, 0.f, 0.f), glm::vec3(0.f, 0.f, 3.f)}) {
        d.emission = e;
        EXPECT_TRUE(make_material(d).emissive());
    }
}

TEST(Material, DiffuseAndEmissionAreLambertian) {
    for (MaterialKind kind : {MaterialKind::diffuse, MaterialKind::emission}) {
        MaterialDesc d = desc(kind);
        d.emission = kind == MaterialKind::emission ? glm::vec3(5.f) : glm::vec3(0.f);
        const Material m = make_material(d);
        EXPECT_EQ(m.bsdf.kind, BsdfKind::lambertian);
        EXPECT_EQ(m.bsdf.albedo, d.albedo) << "an emitter reflects as diffuse, by its albedo";
        const glm::vec3 wo(0.f, 0.6f, 0.8f), wi(0.6f, 0.f, 0.8f);
        EXPECT_EQ(bsdf_f(m.bsdf, wo, wi), d.albedo * kInvPi);
        EXPECT_FALSE(bsdf_has_delta(m.bsdf));
    }
}

TEST(Material, MirrorKeepsItsReflectance) {
    const MaterialDesc d = desc(MaterialKind::mirror);
    const Material m = make_material(d);
    EXPECT_EQ(m.bsdf.kind, BsdfKind::mirror);
    EXPECT_EQ(m.bsdf.albedo, d.albedo);
    EXPECT_TRUE(bsdf_is_delta(m.bsdf));
    BsdfSample s;
    ASSERT_TRUE(bsdf_sample(m.bsdf, glm::vec3(0.6f, 0.f, 0.8f), 0.5f, {0.5f, 0.5f}, s));
    EXPECT_EQ(s.weight, d.albedo);
}

// Glass reads its reflectance, transmittance and index; the index decides the Fresnel split.
TEST(Material, GlassKeepsTransmittanceAndIndex) {
    const MaterialDesc d = desc(MaterialKind::glass);
    const Material m = make_material(d);
    EXPECT_EQ(m.bsdf.kind, BsdfKind::glass);
    EXPECT_EQ(m.bsdf.albedo, d.albedo);
    EXPECT_EQ(m.bsdf.transmittance, d.transmittance);
    EXPECT_EQ(m.bsdf.ior, d.ior);
    // Below the reflectance at normal incidence the sample reflects; above it, it refracts and
    // is weighted by the transmittance over η².
    const float f = fresnel_dielectric(1.f, d.ior);
    BsdfSample s;
    ASSERT_TRUE(bsdf_sample(m.bsdf, glm::vec3(0.f, 0.f, 1.f), 0.5f * f, {0.f, 0.f}, s));
    EXPECT_GT(s.wi.z, 0.f);
    EXPECT_EQ(s.weight, d.albedo);
    ASSERT_TRUE(bsdf_sample(m.bsdf, glm::vec3(0.f, 0.f, 1.f), 0.5f + 0.5f * f, {0.f, 0.f}, s));
    EXPECT_LT(s.wi.z, 0.f);
    EXPECT_EQ(s.weight, d.transmittance / (d.ior * d.ior));
}

// The CS184 microfacet material is a Beckmann conductor whose α is the roughness as written,
// with the complex index per channel; a roughness of zero (or below, clamped) is a mirror.
TEST(Material, MicrofacetIsABeckmannConductor) {
    MaterialDesc d = desc(MaterialKind::microfacet);
    Material m = make_material(d);
    EXPECT_EQ(m.bsdf.kind, BsdfKind::conductor);
    EXPECT_EQ(m.bsdf.alpha, d.roughness) << "Beckmann α is the roughness itself, not its square";
    EXPECT_EQ(m.bsdf.eta, d.eta);
    EXPECT_EQ(m.bsdf.k, d.k);
    EXPECT_TRUE(bsdf_has_glossy(m.bsdf));
    for (float r : {0.f, -0.5f}) {
        d.roughness = r;
        m = make_material(d);
        EXPECT_EQ(m.bsdf.alpha, 0.f) << r;
        EXPECT_TRUE(bsdf_is_delta(m.bsdf)) << "roughness " << r << " is a smooth conductor";
        BsdfSample s;
        const glm::vec3 wo(0.6f, 0.f, 0.8f);
        ASSERT_TRUE(bsdf_sample(m.bsdf, wo, 0.5f, {0.3f, 0.7f}, s));
        EXPECT_EQ(s.weight, fresnel_conductor(wo.z, d.eta, d.k)) << "the conductor's own Fresnel";
    }
}

// CS184's glossy material is the normalised Phong lobe with the shininess as its exponent; a
// negative shininess is clamped to 0 (a cosine lobe), and a very large one is a mirror.
TEST(Material, GlossyIsPhongWithTheShininessAsExponent) {
    MaterialDesc d = desc(MaterialKind::glossy);
    Material m = make_material(d);
    EXPECT_EQ(m.bsdf.kind, BsdfKind::phong);
    EXPECT_EQ(m.bsdf.exponent, d.shininess);
    EXPECT_TRUE(bsdf_has_glossy(m.bsdf));
    d.shininess = -3.f;
    m = make_material(d);
    EXPECT_EQ(m.bsdf.exponent, 0.f);
    EXPECT_TRUE(std::isfinite(bsdf_f(m.bsdf, glm::vec3(0.f, 0.f, 1.f), glm::vec3(0.f, 0.f, 1.f)).x));
    d.shininess = 2.f * kSmoothPhongExponent;
    EXPECT_TRUE(bsdf_is_delta(make_material(d).bsdf));
}

// glTF metallic-roughness: α is the square of the perceptual roughness, metallic is clamped to
// [0, 1], the specular factor to >= 0, and the index (KHR_materials_ior) is kept.
TEST(Material, MetallicRoughnessSquaresTheRoughness) {
    MaterialDesc d = desc(MaterialKind::metallic_roughness);
    Material m = make_material(d);
    EXPECT_EQ(m.bsdf.kind, BsdfKind::metallic_roughness);
    EXPECT_FLOAT_EQ(m.bsdf.alpha, 0.16f);
    EXPECT_EQ(m.bsdf.metallic, d.metallic);
    EXPECT_EQ(m.bsdf.specular, d.specular);
    EXPECT_EQ(m.bsdf.ior, d.ior);
    EXPECT_TRUE(bsdf_has_glossy(m.bsdf));
    d.metallic = 1.7f;
    d.specular = -0.2f;
    m = make_material(d);
    EXPECT_EQ(m.bsdf.metallic, 1.f);
    EXPECT_EQ(m.bsdf.specular, 0.f);
    d.metallic = -0.4f;
    EXPECT_EQ(make_material(d).bsdf.metallic, 0.f);
    // A roughness of 0.03 is α = 9e-4, below kSmoothAlpha: a smooth coat, a delta lobe. A fully
    // metallic smooth surface is nothing but that lobe.
    d.roughness = 0.03f;
    d.metallic = 1.f;
    m = make_material(d);
    EXPECT_LT(m.bsdf.alpha, kSmoothAlpha);
    EXPECT_TRUE(bsdf_has_delta(m.bsdf));
    EXPECT_TRUE(bsdf_is_delta(m.bsdf));
    d.metallic = 0.f;
    EXPECT_FALSE(bsdf_is_delta(make_material(d).bsdf)) << "a smooth plastic keeps its diffuse base";
}

// The description's defaults make the engine's default: a grey Lambertian that emits nothing.
TEST(Material, DefaultDescriptionIsTheDefaultGrey) {
    const Material m = make_material(MaterialDesc{});
    const Material grey{};
    EXPECT_EQ(m.bsdf.kind, grey.bsdf.kind);
    EXPECT_EQ(m.bsdf.albedo, grey.bsdf.albedo);
    EXPECT_FALSE(m.emissive());
    EXPECT_FALSE(m.double_sided);
}

// A CS184 lamp turned into a mesh: it emits its radiance, one-sided, and reflects nothing, so
// that light arriving at a lamp ends there.
TEST(Material, EmitterMaterialEmitsAndReflectsNothing) {
    const Material m = emitter_material({4.f, 3.f, 2.f});
    EXPECT_EQ(m.emission, glm::vec3(4.f, 3.f, 2.f));
    EXPECT_TRUE(m.emissive());
    EXPECT_FALSE(m.double_sided);
    EXPECT_EQ(m.textures, kNoTextures);
    EXPECT_TRUE(bsdf_is_black(m.bsdf));
    EXPECT_EQ(bsdf_f(m.bsdf, glm::vec3(0.f, 0.f, 1.f), glm::normalize(glm::vec3(1.f, 0.f, 1.f))), glm::vec3(0.f));
    EXPECT_FALSE(emitter_material(glm::vec3(0.f)).emissive());
}

}  // namespace
}  // namespace tessera
