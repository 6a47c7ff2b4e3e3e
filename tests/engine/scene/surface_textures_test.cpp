// Textured surfaces: known texels read back through a mesh's coordinates, wrap modes and the
// transform; alpha cut-outs and stochastic transparency in intersection (ours and Embree's);
// generated tangents and normal maps; vertex colours; and textured emitters that every
// light-sampling strategy sees alike.
#include "engine/scene/surface_textures.h"

#include <cmath>
#include <memory>

#include <gtest/gtest.h>

#include "engine/render/renderer.h"
#include "engine/scene/intersect.h"
#include "engine/sampling/rng.h"
#include "tests/engine/render/render_test_util.h"
#include "tests/test_scale.h"

namespace tessera {
namespace {

// A unit quad in z = `z` facing +z, with glTF-style coordinates: (x, y) has uv (x, 1 − y) (the
// image's top row at the top of the quad).
MeshDesc quad(int material, float z = 0.f, bool mirror_u = false) {
    MeshDesc q;
    q.name = "quad";
    q.material = material;
    q.positions = {{0, 0, z}, {1, 0, z}, {1, 1, z}, {0, 1, z}};
    q.normals.assign(4, glm::vec3(0, 0, 1));
    q.indices = {0, 1, 2, 0, 2, 3};
    q.uv[0] = {{0, 1}, {1, 1}, {1, 0}, {0, 0}};
    if (mirror_u)
        for (auto& t : q.uv[0]) t.x = 1.f - t.x;
    return q;
}

std::shared_ptr<const TextureImage> image(int w, int h, std::vector<uint8_t> rgba) {
    auto img = std::make_shared<TextureImage>();
    img->width = w;
    img->height = h;
    img->rgba = std::move(rgba);
    return img;
}

// 4 × 2 texels with distinct red values 10·x + 60·y + 5.
std::shared_ptr<const TextureImage> numbered() {
    std::vector<uint8_t> px;
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 4; ++x) px.insert(px.end(), {uint8_t(10 * x + 60 * y + 5), 100, 50, 255});
    return image(4, 2, px);
}

MaterialDesc textured_diffuse(int texture) {
    MaterialDesc m;
    m.name = "textured";
    m.albedo = glm::vec3(1.f);
    m.base_color_tex.texture = texture;
    return m;
}

// The BSDF at the point (x, y) of the quad in z = 0, seen from above.
Bsdf bsdf_at(const RenderScene& s, float x, float y, glm::vec3* ns = nullptr) {
    Ray r;
    r.o = {x, y, 1.f};
    r.d = {0, 0, -1};
    Hit hit;
    TraversalCounters tc;
    EXPECT_TRUE(intersect(s, r, hit, tc));
    SurfaceInteraction si = surface_at(s, r, hit);
    const Material& m = s.materials[si.material];
    Bsdf b = m.bsdf;
    if (m.textures != kNoTextures) apply_textures(s, s.material_textures[m.textures], hit.prim, hit.b1, hit.b2, b, si.ns, si.ng);
    if (ns) *ns = si.ns;
    return b;
}

TEST(SurfaceTextures, KnownTexelsReadBackThroughCoordinatesWrapAndTransform) {
    SceneDescription d;
    d.images = {numbered()};
    d.textures = {Texture{0, Wrap::repeat, Wrap::repeat, true}};
    d.materials = {textured_diffuse(0)};
    d.meshes = {quad(0)};
    const RenderScene s = build_render_scene(d, {});
    ASSERT_EQ(s.uv[0].size(), 4u);
    EXPECT_TRUE(s.uv[1].empty() && s.colors.empty() && s.tangents.empty());  // nothing reads them
    for (int ty = 0; ty < 2; ++ty)
        for (int tx = 0; tx < 4; ++tx) {
            // Texel (tx, ty)'s centre is at u = (tx + ½)/4, v = (ty + ½)/2, i.e. y = 1 − v.
            const float x = (tx + 0.5f) / 4.f, y = 1.f - (ty + 0.5f) / 2.f;
            EXPECT_NEAR(bsdf_at(s, x, y).albedo.x, kSrgbToLinear[size_t(10 * tx + 60 * ty + 5)], 1e-6) << tx << "," << ty;
            EXPECT_NEAR(bsdf_at(s, x, y).albedo.y, kSrgbToLinear[100], 1e-6);
        }
    // KHR_texture_transform: an offset of one texel reads the next one; a scale of 2 with
    // repeat reads the texture twice across the quad; clamp holds the edge.
    SceneDescription t = d;
    set_texture_transform(t.materials[0].base_color_tex, {0.25f, 0.f}, 0.f, {1.f, 1.f});
    const RenderScene shifted = build_render_scene(t, {});
    EXPECT_NEAR(bsdf_at(shifted, 0.125f, 0.75f).albedo.x, kSrgbToLinear[15], 1e-6);   // texel (1, 0)
    EXPECT_NEAR(bsdf_at(shifted, 0.875f, 0.75f).albedo.x, kSrgbToLinear[5], 1e-6);    // wrapped to texel (0, 0)
    set_texture_transform(t.materials[0].base_color_tex, {0.f, 0.f}, 0.f, {2.f, 1.f});
    const RenderScene twice = build_render_scene(t, {});
    EXPECT_NEAR(bsdf_at(twice, 0.5f + 0.0625f, 0.75f).albedo.x, kSrgbToLinear[5], 1e-6);  // u' = 1.125: texel 0 again
    t.textures[0].wrap_s = Wrap::clamp;
    const RenderScene clamped = build_render_scene(t, {});
    EXPECT_NEAR(bsdf_at(clamped, 0.9f, 0.75f).albedo.x, kSrgbToLinear[35], 1e-6);  // u' = 1.8: the last texel
}

TEST(SurfaceTextures, UntexturedScenesBuildNoneOfIt) {
    SceneDescription d;
    MaterialDesc m;
    d.materials = {m};
    d.meshes = {quad(0)};
    const RenderScene s = build_render_scene(d, {});
    EXPECT_EQ(s.materials[0].textures, kNoTextures);
    EXPECT_TRUE(s.uv[0].empty() && s.colors.empty() && s.tangents.empty() && s.images.empty());
    EXPECT_FALSE(s.has_alpha);
    bool said = false;
    for (const auto& l : s.report.left_out) said |= l.find("textures: no material reads one") != std::string::npos;
    EXPECT_TRUE(said);
}

TEST(SurfaceTextures, VertexColoursMultiplyTheBaseColour) {
    SceneDescription d;
    MaterialDesc m;
    m.albedo = {0.8f, 0.8f, 0.4f};
    d.materials = {m};
    d.meshes = {quad(0)};
    d.meshes[0].colors.assign(4, glm::vec4(0.5f, 0.25f, 1.f, 1.f));
    const RenderScene s = build_render_scene(d, {});
    ASSERT_NE(s.materials[0].textures, kNoTextures);
    const Bsdf b = bsdf_at(s, 0.3f, 0.6f);
    EXPECT_NEAR(b.albedo.x, 0.4f, 1e-6);
    EXPECT_NEAR(b.albedo.y, 0.2f, 1e-6);
    EXPECT_NEAR(b.albedo.z, 0.4f, 1e-6);
}

// An alpha texture of two texels, transparent on the left half of the quad, opaque on the right;
// an opaque quad lies behind at z = −1.
SceneDescription masked_scene(AlphaMode mode) {
    SceneDescription d;
    d.images = {image(2, 1, {255, 255, 255, 0, 255, 255, 255, 255})};
    d.textures = {Texture{0, Wrap::clamp, Wrap::clamp, true}};
    MaterialDesc leaf = textured_diffuse(0);
    leaf.alpha_mode = mode;
    d.materials = {leaf, MaterialDesc{}};
    d.meshes = {quad(0), quad(1, -1.f)};
    return d;
}

TEST(SurfaceTextures, AlphaMaskCutsOutInEveryQuery) {
    for (const bool embree : {false, true}) {
        if (embree && !embree_available()) continue;
        RenderSceneOptions o;
        if (embree) o.bvh.type = BvhType::embree;
        const RenderScene s = build_render_scene(masked_scene(AlphaMode::mask), o);
        ASSERT_TRUE(s.has_alpha);
        TraversalCounters tc;
        for (float x : {0.1f, 0.3f, 0.45f, 0.55f, 0.7f, 0.9f}) {
            Ray r;
            r.o = {x, 0.5f, 1.f};
            r.d = {0, 0, -1};
            Hit hit;
            ASSERT_TRUE(intersect(s, r, hit, tc));
            // The left half lets the ray through to the quad behind (t = 2).
            EXPECT_NEAR(hit.t, x < 0.5f ? 2.f : 1.f, 1e-5) << "x " << x << (embree ? " (Embree)" : "");
            Ray shadow;
            shadow.o = {x, 0.5f, 1.f};
            shadow.d = {0, 0, -1};
            shadow.tmax = 1.5f;  // stops before the back quad
            EXPECT_EQ(occluded(s, shadow, tc), x > 0.5f) << "x " << x << (embree ? " (Embree)" : "");
        }
    }
}

TEST(SurfaceTextures, BlendLetsThroughOneMinusAlphaOfTheRaysAndDecidesOnce) {
    for (const bool embree : {false, true}) {
        if (embree && !embree_available()) continue;
        SceneDescription d = masked_scene(AlphaMode::blend);
        d.textures.clear();
        d.images.clear();
        d.materials[0].base_color_tex = {};
        d.materials[0].alpha = 0.3f;
        RenderSceneOptions o;
        if (embree) o.bvh.type = BvhType::embree;
        const RenderScene s = build_render_scene(d, o);
        Pcg32 rng(7, 1);
        TraversalCounters tc;
        const int n = 4000;
        int stopped = 0;
        for (int i = 0; i < n; ++i) {
            Ray r;
            r.o = {0.1f + 0.8f * rng.next_float(), 0.1f + 0.8f * rng.next_float(), 1.f};
            r.d = {0.01f * (rng.next_float() - 0.5f), 0.01f * (rng.next_float() - 0.5f), -1.f};
            Hit a, b;
            Ray r2 = r;
            ASSERT_TRUE(intersect(s, r, a, tc));
            ASSERT_TRUE(intersect(s, r2, b, tc));
            EXPECT_EQ(a.t, b.t);  // the same ray decides the same way
            const bool front = a.t < 1.5f;
            stopped += front;
            Ray shadow = r2;
            shadow.tmax = 1.5f;
            shadow.o = r.o;
            EXPECT_EQ(occluded(s, shadow, tc), front);  // and any-hit queries agree with closest-hit ones
        }
        // Binomial: 0.3 of the rays stop, within five standard deviations.
        EXPECT_NEAR(double(stopped) / n, 0.3, 5 * std::sqrt(0.3 * 0.7 / n)) << (embree ? "Embree" : "ours");
    }
}

TEST(SurfaceTextures, GeneratedTangentsFollowUAndMarkMirroredCoordinates) {
    for (const bool mirror : {false, true}) {
        SceneDescription d;
        d.images = {image(1, 1, {128, 128, 255, 255})};
        d.textures = {Texture{}};
        MaterialDesc m;
        m.normal_tex.texture = 0;
        d.materials = {m};
        d.meshes = {quad(0, 0.f, mirror)};
        const RenderScene s = build_render_scene(d, {});
        ASSERT_EQ(s.tangents.size(), 4u);
        for (const glm::vec4& t : s.tangents) {
            // Along increasing u: +x, or −x where u runs backwards ...
            EXPECT_NEAR(t.x, mirror ? -1.f : 1.f, 1e-6);
            EXPECT_NEAR(t.y, 0.f, 1e-6);
            EXPECT_NEAR(t.z, 0.f, 1e-6);
            // ... and the bitangent cross(n, t)·w points to the image's top (+y) either way.
            const glm::vec3 b = glm::cross(glm::vec3(0, 0, 1), glm::vec3(t)) * t.w;
            EXPECT_NEAR(b.y, 1.f, 1e-6);
        }
    }
}

TEST(SurfaceTextures, NormalMapsBendTheShadingNormalInTangentSpace) {
    // Texel (255, 128, 255): +x in tangent space as much as +z, a 45° tilt toward increasing u;
    // (128, 255, 255): toward the image's top. The mirrored quad tilts the other way in x.
    struct Case { uint8_t r, g; bool mirror; float scale; glm::vec3 want; };
    const float g = 128 / 255.f * 2 - 1;  // 0.0039: the encoding's own offset
    const Case cases[] = {
        {255, 128, false, 1.f, glm::normalize(glm::vec3(1, g, 1))},
        {255, 128, true, 1.f, glm::normalize(glm::vec3(-1, g, 1))},
        {128, 255, false, 1.f, glm::normalize(glm::vec3(g, 1, 1))},
        {128, 255, true, 1.f, glm::normalize(glm::vec3(-g, 1, 1))},
        {255, 128, false, 0.5f, glm::normalize(glm::vec3(0.5f, 0.5f * g, 1))},
    };
    for (const Case& c : cases) {
        SceneDescription d;
        d.images = {image(1, 1, {c.r, c.g, 255, 255})};
        d.textures = {Texture{}};
        MaterialDesc m;
        m.normal_tex.texture = 0;
        m.normal_tex.scale = c.scale;
        d.materials = {m};
        d.meshes = {quad(0, 0.f, c.mirror)};
        const RenderScene s = build_render_scene(d, {});
        glm::vec3 ns;
        bsdf_at(s, 0.4f, 0.6f, &ns);
        EXPECT_NEAR(ns.x, c.want.x, 1e-5) << int(c.r) << "," << int(c.g) << " mirror " << c.mirror;
        EXPECT_NEAR(ns.y, c.want.y, 1e-5) << int(c.r) << "," << int(c.g) << " mirror " << c.mirror;
        EXPECT_NEAR(ns.z, c.want.z, 1e-5) << int(c.r) << "," << int(c.g) << " mirror " << c.mirror;
        // Tangents given by the file are used as given.
        d.meshes[0].tangents.assign(4, glm::vec4(c.mirror ? -1 : 1, 0, 0, c.mirror ? -1 : 1));
        const RenderScene given = build_render_scene(d, {});
        glm::vec3 ns2;
        bsdf_at(given, 0.4f, 0.6f, &ns2);
        EXPECT_NEAR(glm::distance(ns, ns2), 0.f, 1e-5);
    }
}

TEST(SurfaceTextures, MetallicRoughnessTextureScalesTheFactors) {
    SceneDescription d;
    d.images = {image(1, 1, {0, 128, 64, 255})};  // roughness in green, metallic in blue
    d.textures = {Texture{}};
    MaterialDesc m;
    m.kind = MaterialKind::metallic_roughness;
    m.metallic = 1.f;
    m.roughness = 0.8f;
    m.metallic_roughness_tex.texture = 0;
    d.materials = {m};
    d.meshes = {quad(0)};
    const RenderScene s = build_render_scene(d, {});
    const Bsdf b = bsdf_at(s, 0.5f, 0.5f);
    const float roughness = 0.8f * 128 / 255.f;
    EXPECT_NEAR(b.alpha, roughness * roughness, 1e-6);
    EXPECT_NEAR(b.metallic, 64 / 255.f, 1e-6);
}

// A textured emitter (a 2 × 2 checker of radiance 4 and 0.5 in red) over a white floor: light
// sampling reads the texture at the sampled point, hemisphere sampling where its ray lands;
// the three strategies must agree.
TEST(SurfaceTextures, TexturedEmittersLookTheSameToEveryStrategy) {
    SceneDescription d;
    d.images = {image(2, 2, {255, 255, 255, 255, 80, 255, 255, 255, 80, 255, 255, 255, 255, 255, 255, 255})};
    d.textures = {Texture{0, Wrap::clamp, Wrap::clamp, true}};
    MaterialDesc lamp;
    lamp.kind = MaterialKind::emission;
    lamp.albedo = glm::vec3(0.f);
    lamp.emission = glm::vec3(4.f);
    lamp.emissive_tex.texture = 0;
    MaterialDesc floor;
    floor.albedo = glm::vec3(0.8f);
    d.materials = {lamp, floor};
    MeshDesc l = quad(0, 0.f);
    for (auto& p : l.positions) p = {p.x - 0.5f, 1.f, p.y - 0.5f};  // a 1 × 1 lamp at y = 1 facing down
    l.normals.assign(4, glm::vec3(0, -1, 0));  // (x, 0, z) edges wound as before now face −y
    MeshDesc f;
    f.material = 1;
    f.flat_normals = true;
    f.positions = {{-3, 0, -3}, {-3, 0, 3}, {3, 0, 3}, {3, 0, -3}};
    f.indices = {0, 1, 2, 0, 2, 3};
    d.meshes = {l, f};
    CameraDesc c;
    c.position = {0, 0.5f, 2.5f};
    c.look_at = {0, 0, 0};
    c.vfov_deg = 50.f;
    d.camera = c;
    const RenderScene s = build_render_scene(d, {});
    ASSERT_TRUE(s.textured_emission);
    RenderSettings st;
    st.width = 24;
    st.height = 18;
    st.spp = 64 / test::kWorkScale + 8;
    st.max_depth = 1;
    st.light_rays = 2;
    test::expect_strategies_agree(s, st);
}

}  // namespace
}  // namespace tessera
