// A glTF file posed at any time: node channels (STEP, LINEAR, CUBICSPLINE) through the
// hierarchy, cameras, morph weights and skins, each against positions worked out by hand in
// files written here from the specification; the choice of animation; refusals that name what
// cannot be played; and the Khronos animated samples posed over their whole range.
#include "engine/io/gltf_loader.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <optional>
#include <vector>

#include "engine/io/scene_loader.h"
#include "engine/scene/instancing.h"
#include "tests/engine/io/gltf_test_files.h"
#include "tests/test_paths.h"

namespace tessera {
namespace {

using namespace test::gltf;
namespace fs = std::filesystem;

// A file assembled from accessors added one by one (all in one base64 buffer). Accessor 0 is
// the triangle (0,0,0) (1,0,0) (0,1,0).
struct FileBuilder {
    Blob blob;
    std::string views, accessors;
    int count = 0;

    FileBuilder() { floats({0, 0, 0, 1, 0, 0, 0, 1, 0}, "VEC3"); }

    template <class T>
    int add(std::initializer_list<T> v, int component_type, int per_element, const char* type) {
        const size_t at = blob.add<T>(v);
        const std::string sep = count ? "," : "";
        views += sep + R"({"buffer":0,"byteOffset":)" + std::to_string(at) + R"(,"byteLength":)" + std::to_string(v.size() * sizeof(T)) + "}";
        accessors += sep + R"({"bufferView":)" + std::to_string(count) + R"(,"componentType":)" + std::to_string(component_type) +
                     R"(,"count":)" + std::to_string(v.size() / size_t(per_element)) + R"(,"type":")" + type + "\"" +
                     (component_type == 5126 ? "" : R"(,"normalized":false)") + "}";
        return count++;
    }
    int floats(std::initializer_list<float> v, const char* type) {
        const int n = std::string(type) == "SCALAR" ? 1 : std::string(type) == "VEC3" ? 3 : 4;
        return add<float>(v, 5126, n, type);
    }
    int bytes(std::initializer_list<uint8_t> v) { return add<uint8_t>(v, 5121, 4, "VEC4"); }

    // `body` holds the scenes, nodes, meshes, animations ... (without braces).
    std::string file(const std::string& body) const {
        return R"({"asset":{"version":"2.0"},)" + body + R"(,"buffers":[{"byteLength":)" + std::to_string(blob.bytes.size()) +
               R"(,"uri":")" + blob.uri() + R"("}],"bufferViews":[)" + views + R"(],"accessors":[)" + accessors + "]}";
    }
};

std::shared_ptr<const GltfDocument> document(const std::string& json) { return GltfDocument::parse(json, false, "", "anim.gltf"); }

// In world space: a mesh two nodes place is an instance (instancing_test.cpp); here only where
// each vertex lands matters.
SceneDescription posed(const std::shared_ptr<const GltfDocument>& d, double t, const std::string& animation = "", bool by_index = false) {
    SceneDescription s = d->pose(ScenePose{t, animation, by_index});
    flatten_instances(s);
    return s;
}
// At rest (nullopt), in world space.
SceneDescription posed(const std::shared_ptr<const GltfDocument>& d, std::nullopt_t) {
    SceneDescription s = d->rest();
    flatten_instances(s);
    return s;
}

std::string animation(const std::string& channels, const std::string& samplers, const std::string& name = "") {
    return R"({"name":")" + name + R"(","channels":[)" + channels + R"(],"samplers":[)" + samplers + "]}";
}
std::string sampler(int input, int output, const char* interpolation = "LINEAR") {
    return R"({"input":)" + std::to_string(input) + R"(,"output":)" + std::to_string(output) + R"(,"interpolation":")" + interpolation + "\"}";
}
std::string channel(int sampler, int node, const char* path) {
    return R"({"sampler":)" + std::to_string(sampler) + R"(,"target":{"node":)" + std::to_string(node) + R"(,"path":")" + path + "\"}}";
}

// A parent moved linearly along x carries its child (itself offset by z = 1); the still is at rest.
TEST(GltfAnimation, LinearTranslationMovesTheHierarchy) {
    FileBuilder b;
    const int times = b.floats({0, 2}, "SCALAR");
    const int moves = b.floats({0, 0, 0, 4, 0, 0}, "VEC3");
    const auto d = document(b.file(R"("scenes":[{"nodes":[0]}],"nodes":[{"children":[1]},{"mesh":0,"translation":[0,0,1]}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"animations":[)" +
                                   animation(channel(0, 0, "translation"), sampler(times, moves), "Slide") + "]"));
    expect_near(posed(d, 1.0).meshes[0].positions[0], {2, 0, 1});
    expect_near(posed(d, 0.5).meshes[0].positions[1], {2, 0, 1});
    expect_near(posed(d, -3).meshes[0].positions[0], {0, 0, 1});  // clamped before the first key
    expect_near(posed(d, 9).meshes[0].positions[0], {4, 0, 1});   // and after the last
    SceneDescription rest = d->rest();
    EXPECT_EQ(rest.instances.size(), 1u);  // a rigid mesh an animation moves is an instance
    flatten_instances(rest);
    expect_near(rest.meshes[0].positions[0], {0, 0, 1});
    ASSERT_EQ(rest.animations.size(), 1u);
    EXPECT_EQ(rest.animations[0].name, "Slide");
    EXPECT_DOUBLE_EQ(rest.animations[0].end_s, 2.0);
    EXPECT_TRUE(std::any_of(rest.warnings.begin(), rest.warnings.end(),
                            [](const std::string& w) { return w.find("a still renders it at rest") != std::string::npos; }));
}

TEST(GltfAnimation, StepRotationHoldsUntilTheNextKey) {
    FileBuilder b;
    const float h = float(std::sin(std::numbers::pi / 4));
    const int times = b.floats({0, 1}, "SCALAR");
    const int turns = b.add<float>({0, 0, 0, 1, 0, 0, h, h}, 5126, 4, "VEC4");
    const auto d = document(b.file(R"("scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
        "animations":[)" + animation(channel(0, 0, "rotation"), sampler(times, turns, "STEP")) + "]"));
    expect_near(posed(d, 0.999).meshes[0].positions[1], {1, 0, 0});
    expect_near(posed(d, 1.0).meshes[0].positions[1], {0, 1, 0});  // 90 degrees about z
}

// Scale x from 1 to 3 with out-tangent 4 at the first key: at s = 0.5 the Hermite basis gives
// 0.5·1 + 0.125·4 + 0.5·3 = 2.5.
TEST(GltfAnimation, CubicSplineScaleFollowsTheHermiteCurve) {
    FileBuilder b;
    const int times = b.floats({0, 1}, "SCALAR");
    const int scales = b.floats({0, 0, 0, 1, 1, 1, 4, 0, 0, /* key 1: */ 0, 0, 0, 3, 1, 1, 0, 0, 0}, "VEC3");
    const auto d = document(b.file(R"("scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
        "animations":[)" + animation(channel(0, 0, "scale"), sampler(times, scales, "CUBICSPLINE")) + "]"));
    expect_near(posed(d, 0.5).meshes[0].positions[1], {2.5f, 0, 0});
    expect_near(posed(d, 1.0).meshes[0].positions[1], {3, 0, 0});
}

TEST(GltfAnimation, TheCameraFollowsItsNode) {
    FileBuilder b;
    const int times = b.floats({0, 1}, "SCALAR");
    const int moves = b.floats({0, 0, 5, 0, 3, 5}, "VEC3");
    const auto d = document(b.file(R"("scenes":[{"nodes":[0,1]}],"nodes":[{"mesh":0},{"camera":0}],
        "cameras":[{"type":"perspective","perspective":{"yfov":0.6,"znear":0.1}}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"animations":[)" +
                                   animation(channel(0, 1, "translation"), sampler(times, moves)) + "]"));
    const SceneDescription s = posed(d, 0.5);
    ASSERT_TRUE(s.camera);
    expect_near(s.camera->position, {0, 1.5f, 5});
    expect_near(s.camera->look_at, {0, 1.5f, 4});
    EXPECT_NEAR(s.camera->vfov_deg, 0.6 * 180 / std::numbers::pi, 1e-4);
}

// One target lifting every vertex by z = 1: the mesh's default weight at rest, the animated
// weight when posed.
TEST(GltfAnimation, MorphWeightsAnimate) {
    FileBuilder b;
    const int lift = b.floats({0, 0, 1, 0, 0, 1, 0, 0, 1}, "VEC3");
    const int times = b.floats({0, 1}, "SCALAR");
    const int weights = b.floats({0, 1}, "SCALAR");
    const auto d = document(b.file(R"("scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
        "meshes":[{"weights":[0.25],"primitives":[{"attributes":{"POSITION":0},"targets":[{"POSITION":)" +
                                   std::to_string(lift) + R"(}]}]}],"animations":[)" +
                                   animation(channel(0, 0, "weights"), sampler(times, weights)) + "]"));
    expect_near(posed(d, std::nullopt).meshes[0].positions[1], {1, 0, 0.25f});
    expect_near(posed(d, 0.5).meshes[0].positions[1], {1, 0, 0.5f});
    expect_near(posed(d, 1.0).meshes[0].positions[2], {0, 1, 1});
}

// Vertex 0 follows joint A alone, vertex 1 half A and half B, vertex 2 joint B alone; B rises
// by z = 2. The skinned mesh's own node transform (a large offset) must not apply.
TEST(GltfAnimation, SkinnedVerticesFollowTheirWeightedJoints) {
    FileBuilder b;
    const int joints = b.bytes({0, 0, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0});
    const int weights = b.add<float>({1, 0, 0, 0, 0.5f, 0.5f, 0, 0, 1, 0, 0, 0}, 5126, 4, "VEC4");
    const int times = b.floats({0, 1}, "SCALAR");
    const int rise = b.floats({0, 0, 0, 0, 0, 2}, "VEC3");
    const auto d = document(b.file(R"("scenes":[{"nodes":[0,1,2]}],
        "nodes":[{"mesh":0,"skin":0,"translation":[100,0,0]},{},{}],"skins":[{"joints":[1,2]}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0,"JOINTS_0":)" +
                                   std::to_string(joints) + R"(,"WEIGHTS_0":)" + std::to_string(weights) +
                                   R"(}}]}],"animations":[)" + animation(channel(0, 2, "translation"), sampler(times, rise)) + "]"));
    const SceneDescription s = posed(d, 1.0);
    ASSERT_EQ(s.meshes.size(), 1u);
    expect_near(s.meshes[0].positions[0], {0, 0, 0});
    expect_near(s.meshes[0].positions[1], {1, 0, 1});
    expect_near(s.meshes[0].positions[2], {0, 1, 2});
    expect_near(posed(d, std::nullopt).meshes[0].positions[2], {0, 1, 0});
}

TEST(GltfAnimation, AJobChoosesAnAnimationByNameOrIndex) {
    FileBuilder b;
    const int times = b.floats({0, 1}, "SCALAR");
    const int walk = b.floats({0, 0, 0, 1, 0, 0}, "VEC3");
    const int run = b.floats({0, 0, 0, 0, 0, 3}, "VEC3");
    const auto d = document(b.file(R"("scenes":[{"nodes":[0,1]}],"nodes":[{"mesh":0},{"mesh":0}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"animations":[)" +
                                   animation(channel(0, 0, "translation"), sampler(times, walk), "Walk") + "," +
                                   animation(channel(0, 1, "translation"), sampler(times, run), "Run") + "]"));
    auto offsets = [&](const std::string& which) {
        const SceneDescription s = posed(d, 1.0, which);
        return std::make_pair(s.meshes[0].positions[0], s.meshes[1].positions[0]);
    };
    expect_near(offsets("").first, {1, 0, 0});  // every animation at once
    expect_near(offsets("").second, {0, 0, 3});
    expect_near(offsets("Run").first, {0, 0, 0});
    expect_near(offsets("Run").second, {0, 0, 3});
    expect_near(offsets("0").first, {1, 0, 0});
    expect_near(offsets("0").second, {0, 0, 0});
    const SceneError e = error_of([&] { posed(d, 0, "Jump"); });
    EXPECT_NE(std::string(e.what()).find("'Walk', 'Run'"), std::string::npos) << e.what();
    error_of([&] { posed(d, 0, "2"); });
    error_of([&] { posed(d, NAN); });
}

// A file may name an animation "1": a job's name "1" plays it, its index 1 (a number in the
// job) plays the animation at index 1, whatever it is named.
TEST(GltfAnimation, AnIndexIsNeverTakenForAName) {
    FileBuilder b;
    const int times = b.floats({0, 1}, "SCALAR");
    const int walk = b.floats({0, 0, 0, 1, 0, 0}, "VEC3");
    const int run = b.floats({0, 0, 0, 0, 0, 3}, "VEC3");
    const auto d = document(b.file(R"("scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"animations":[)" +
                                   animation(channel(0, 0, "translation"), sampler(times, walk), "1") + "," +
                                   animation(channel(0, 0, "translation"), sampler(times, run), "0") + "]"));
    auto at_end = [&](const std::string& which, bool by_index) { return posed(d, 1.0, which, by_index).meshes[0].positions[0]; };
    expect_near(at_end("1", false), {1, 0, 0});  // the animation named "1", at index 0
    expect_near(at_end("1", true), {0, 0, 3});   // index 1
    expect_near(at_end("0", true), {1, 0, 0});   // index 0
    expect_near(at_end("0", false), {0, 0, 3});  // named "0"
    error_of([&] { posed(d, 0, "2", true); });
}

// An animation that animates something Tessera cannot play is refused when played, naming the
// channel; the still of the same file renders.
TEST(GltfAnimation, AnUnplayableChannelIsRefusedByName) {
    FileBuilder b;
    const int times = b.floats({0, 1}, "SCALAR");
    const int values = b.floats({0, 1}, "SCALAR");
    const auto d = document(b.file(R"("scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
        "animations":[{"channels":[{"sampler":0,"target":{"node":0,"path":"pointer"}}],"samplers":[)" +
                                   sampler(times, values) + "]}]"));
    EXPECT_EQ(posed(d, std::nullopt).meshes.size(), 1u);
    const SceneError e = error_of([&] { posed(d, 0.5); });
    EXPECT_NE(std::string(e.what()).find("'pointer'"), std::string::npos) << e.what();
    EXPECT_EQ(e.where().pointer, "/animations/0");
}

TEST(GltfAnimation, MalformedKeysFailNamingTheAccessor) {
    auto file_with = [](std::initializer_list<float> times, std::initializer_list<float> values, const char* interpolation) {
        FileBuilder b;
        const int t = b.floats(times, "SCALAR");
        const int v = b.floats(values, "VEC3");
        return b.file(R"("scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
            "animations":[)" + animation(channel(0, 0, "translation"), sampler(t, v, interpolation)) + "]");
    };
    EXPECT_EQ(error_of([&] { document(file_with({1, 0}, {0, 0, 0, 1, 1, 1}, "LINEAR")); }).where().pointer, "/accessors/1");
    EXPECT_EQ(error_of([&] { document(file_with({0, NAN}, {0, 0, 0, 1, 1, 1}, "LINEAR")); }).where().pointer, "/accessors/1");
    EXPECT_EQ(error_of([&] { document(file_with({0, 1}, {0, 0, 0}, "LINEAR")); }).where().pointer, "/animations/0/samplers/0/output");
    // CUBICSPLINE needs three values per key.
    EXPECT_EQ(error_of([&] { document(file_with({0, 1}, {0, 0, 0, 1, 1, 1}, "CUBICSPLINE")); }).where().pointer,
              "/animations/0/samplers/0/output");
    EXPECT_EQ(error_of([&] { document(file_with({0, 1}, {0, 0, 0, 1, 1, 1}, "BOUNCE")); }).where().pointer,
              "/animations/0/samplers/0/interpolation");
    // A rotation key of zero length names no rotation: refused where the file is read, naming
    // its accessor, not where a frame is posed. A CUBICSPLINE key's tangents may be zero.
    auto rotations = [](std::initializer_list<float> values, const char* interpolation) {
        FileBuilder b;
        const int t = b.floats({0, 1}, "SCALAR");
        const int v = b.floats(values, "VEC4");
        return b.file(R"("scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
            "animations":[)" + animation(channel(0, 0, "rotation"), sampler(t, v, interpolation)) + "]");
    };
    const SceneError zero = error_of([&] { document(rotations({0, 0, 0, 1, 0, 0, 0, 0}, "LINEAR")); });
    EXPECT_EQ(zero.where().pointer, "/accessors/2");
    EXPECT_NE(std::string(zero.what()).find("key 1's rotation quaternion has zero length"), std::string::npos) << zero.what();
    EXPECT_NO_THROW(document(rotations({0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0}, "CUBICSPLINE")));
    EXPECT_THROW(document(rotations({0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0}, "CUBICSPLINE")), SceneError);
}

// Every Khronos animated sample poses over its whole range: finite geometry at the first key,
// between keys and at the last, and geometry that moves.
TEST(GltfAnimationSamples, EveryAnimatedSamplePosesOverItsRange) {
    std::vector<std::string> files;
    if (auto dir = test::gltf_anim_dir())
        for (const auto& e : fs::directory_iterator(*dir))
            if (e.path().extension() == ".gltf") files.push_back(e.path().string());
    if (auto pbr = test::gltf_pbr_dir())
        for (const char* name : {"Fox.gltf", "CesiumMilkTruck.gltf"}) files.push_back(*pbr + "/" + name);
    if (files.size() < 4) {
        if (test::shared_required()) FAIL() << "the animated glTF samples (../shared/scenes/gltf-anim) are missing";
        GTEST_SKIP() << "the animated glTF samples (../shared/scenes/gltf-anim) are absent";
    }
    for (const std::string& file : files) {
        SCOPED_TRACE(file);
        const SceneFile scene(file);
        ASSERT_FALSE(scene.animations().empty());
        auto world = [](SceneDescription d) {
            flatten_instances(d);  // a moving instance moves no vertex of its prototype
            return d;
        };
        const SceneDescription rest = world(scene.at(std::nullopt));
        for (size_t a = 0; a < scene.animations().size(); ++a) {
            const AnimationSummary& info = scene.animations()[a];
            ASSERT_LT(info.start_s, info.end_s);
            bool moved = false;
            for (double f : {0.0, 0.37, 0.5, 1.0}) {
                const SceneDescription s = world(scene.at(ScenePose{info.start_s + f * (info.end_s - info.start_s), std::to_string(a)}));
                ASSERT_EQ(s.meshes.size(), rest.meshes.size());
                for (size_t m = 0; m < s.meshes.size(); ++m)
                    for (size_t v = 0; v < s.meshes[m].positions.size(); ++v) {
                        const glm::vec3 p = s.meshes[m].positions[v];
                        ASSERT_TRUE(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z));
                        if (glm::length(p - rest.meshes[m].positions[v]) > 1e-4f * (1 + glm::length(p))) moved = true;
                    }
            }
            EXPECT_TRUE(moved) << "animation " << a << " moves nothing";
        }
    }
}

}  // namespace
}  // namespace tessera
