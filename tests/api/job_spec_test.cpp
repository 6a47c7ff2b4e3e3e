#include "api/job_spec.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace tessera::api {
namespace {

using nlohmann::json;

std::string pointer_of(const json& body) {
    try {
        parse_job(body);
    } catch (const InvalidJob& e) {
        return e.pointer();
    }
    return "<accepted>";
}

TEST(JobSpec, OnlySceneIsRequiredAndDefaultsAreDocumented) {
    const JobSpec j = parse_job(json{{"scene", "builtin:cornell_box"}});
    EXPECT_EQ(j.scene, "builtin:cornell_box");
    EXPECT_EQ(j.render.width, 800);
    EXPECT_EQ(j.render.height, 600);
    EXPECT_EQ(j.render.spp, 1);
    EXPECT_FALSE(j.render.adaptive.has_value());
    EXPECT_EQ(j.scene_options.bvh.type, BvhType::sah);
    const json back = to_json(j);
    EXPECT_EQ(back["bvh"], "sah");
    EXPECT_EQ(parse_job(back).render.spp, 1) << "to_json round-trips";
}

TEST(JobSpec, ParsesEveryField) {
    const JobSpec j = parse_job(json::parse(R"({"scene":"x.dae","width":480,"height":360,"spp":64,"light_rays":4,
        "max_depth":5,"bvh":"median","direct":"mis","russian_roulette":0.7,"bounces":"nth",
        "adaptive":{"batch":16,"tolerance":0.02},"tile_size":16,"seed":7,"priority":3,"time_limit_s":12.5,
        "max_leaf_size":8,"triangle_test":"moller_trumbore","integrator":"normals"})"));
    EXPECT_EQ(j.render.light_rays, 4);
    EXPECT_EQ(j.render.direct, DirectLighting::mis);
    EXPECT_EQ(j.render.bounces, BounceMode::nth);
    ASSERT_TRUE(j.render.adaptive);
    EXPECT_EQ(j.render.adaptive->batch, 16);
    EXPECT_FLOAT_EQ(j.render.russian_roulette, 0.7f);
    EXPECT_EQ(j.scene_options.bvh.type, BvhType::median);
    EXPECT_EQ(j.scene_options.triangle_test, TriangleTest::moller_trumbore);
    EXPECT_EQ(j.priority, 3);
    EXPECT_EQ(j.render.integrator, Integrator::normals);
}

TEST(JobSpec, ErrorsNameTheField) {
    EXPECT_EQ(pointer_of(json{{"spp", 4}}), "/scene");
    EXPECT_EQ(pointer_of(json{{"scene", "a"}, {"spps", 4}}), "/spps");
    EXPECT_EQ(pointer_of(json{{"scene", "a"}, {"spp", "4"}}), "/spp");
    EXPECT_EQ(pointer_of(json{{"scene", "a"}, {"spp", 0}}), "/spp");
    EXPECT_EQ(pointer_of(json{{"scene", "a"}, {"spp", 1.5}}), "/spp");
    EXPECT_EQ(pointer_of(json{{"scene", "a"}, {"width", 100000}}), "/width");
    EXPECT_EQ(pointer_of(json{{"scene", "a"}, {"bvh", "kd"}}), "/bvh");
    EXPECT_EQ(pointer_of(json{{"scene", "a"}, {"russian_roulette", 1.5}}), "/russian_roulette");
    EXPECT_EQ(pointer_of(json{{"scene", "a"}, {"adaptive", {{"batch", 8}, {"tol", 1}}}}), "/adaptive/tol");
    EXPECT_EQ(pointer_of(json{{"scene", "a"}, {"adaptive", 3}}), "/adaptive");
    EXPECT_EQ(pointer_of(json{{"scene", 3}}), "/scene");
    EXPECT_EQ(pointer_of(json::array()), "");
    EXPECT_EQ(pointer_of(json{{"scene", "a"}, {"width", 16384}, {"height", 16384}, {"spp", 1}}), "<accepted>");
    JobLimits tight;
    tight.max_pixels = 1000;
    EXPECT_THROW(parse_job(json{{"scene", "a"}, {"width", 100}, {"height", 100}}, tight), InvalidJob);
}

}  // namespace
}  // namespace tessera::api
