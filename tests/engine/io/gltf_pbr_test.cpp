// The 17 Khronos sample models of ../shared/scenes/gltf-pbr: each loads with its textures, the
// warnings name what is not supported, and each renders (under the default sky) with no
// non-finite sample.
#include <filesystem>
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "engine/io/scene_loader.h"
#include "engine/render/renderer.h"
#include "engine/scene/render_scene.h"
#include "engine/scene/environment.h"
#include "tests/test_paths.h"

namespace tessera {
namespace {

bool mentions(const std::vector<std::string>& lines, const std::string& what) {
    for (const auto& l : lines)
        if (l.find(what) != std::string::npos) return true;
    return false;
}

struct Expect {
    size_t images;  // the images its materials read (occlusion aside), counted from the JSON
    bool normal_map = false;
    bool alpha = false;
    bool colors = false;
    const char* warning = nullptr;  // one warning that must be there
};

const std::map<std::string, Expect> kModels = {
    {"AlphaBlendModeTest", {4, true, true, false, "occlusion textures are not used"}},
    {"BoxTextured", {1}},
    {"BoxTexturedNonPowerOfTwo", {1}},
    {"CesiumMilkTruck", {1, false, false, false, "animations are ignored"}},
    {"Duck", {1}},
    {"EmissiveStrengthTest", {1}},
    {"Fox", {1, false, false, false, "skins are not supported"}},
    {"MetalRoughSpheresNoTextures", {0}},
    {"MultiUVTest", {2}},
    {"NormalTangentMirrorTest", {3, true}},
    {"NormalTangentTest", {3, true}},
    {"OrientationTest", {0}},
    {"TextureCoordinateTest", {1}},
    {"TextureSettingsTest", {3}},
    {"TextureTransformMultiTest", {3, true, false, false, "ignored: "}},
    {"TextureTransformTest", {5}},
    {"VertexColorTest", {2, false, false, true}},
};

TEST(GltfPbr, EveryModelLoadsWithItsTexturesAndRenders) {
    TESSERA_REQUIRE_SHARED_DIR(dir, gltf_pbr_dir, "the glTF PBR sample models (../shared/scenes/gltf-pbr)");
    for (const auto& [name, want] : kModels) {
        SCOPED_TRACE(name);
        const std::string path = *dir_opt + "/" + name + ".gltf";
        ASSERT_TRUE(std::filesystem::exists(path));
        const SceneDescription d = load_scene(path);
        EXPECT_EQ(d.images.size(), want.images);
        if (want.warning) EXPECT_TRUE(mentions(d.warnings, want.warning)) << "no warning '" << want.warning << "'";
        EXPECT_FALSE(mentions(d.warnings, "textures are not supported"));
        if (name == "MetalRoughSpheresNoTextures") {
            EXPECT_GT(d.triangle_count(), 1'000'000u);
            continue;  // its load is the point; rendering 1M triangles here would only cost time
        }
        const RenderScene s = build_render_scene(d, {});
        EXPECT_EQ(!s.tangents.empty(), want.normal_map);
        EXPECT_EQ(s.has_alpha, want.alpha);
        EXPECT_EQ(!s.colors.empty(), want.colors);
        RenderSettings st;
        st.width = 32;
        st.height = 24;
        st.spp = 2;
        st.max_depth = 3;
        st.direct = DirectLighting::mis;
        st.environment = std::make_shared<const EnvironmentMap>(build_environment(1, 1, {1.f, 1.f, 1.f}, "white"));
        const RenderResult r = render(s, st);
        EXPECT_EQ(r.stats.nonfinite_samples, 0u);
        double sum = 0;
        for (float v : r.image.rgb) sum += v;
        EXPECT_GT(sum, 0.0);
    }
}

}  // namespace
}  // namespace tessera
