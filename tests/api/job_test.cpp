#include "api/job.h"

#include "engine/render/film.h"
#include "engine/render/passes.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

namespace tessera::api {
namespace {

using nlohmann::json;

std::string pointer_of(const json& body) {
    try {
        parse_render_job(body);
    } catch (const InvalidJob& e) {
        return e.pointer();
    }
    return "<accepted>";
}

TEST(RenderJob, OnlySceneIsRequiredAndDefaultsAreDocumented) {
    const RenderJob j = parse_render_job(json{{"scene", "builtin:cornell_box"}});
    EXPECT_EQ(j.scene, "builtin:cornell_box");
    EXPECT_EQ(j.render.width, 800);
    EXPECT_EQ(j.render.height, 600);
    EXPECT_EQ(j.render.spp, 1);
    EXPECT_FALSE(j.render.adaptive.has_value());
    EXPECT_EQ(j.scene_options.bvh.type, BvhType::sah);
    const json back = to_json(j);
    EXPECT_EQ(back["bvh"], "sah");
    EXPECT_EQ(parse_render_job(back).render.spp, 1) << "to_json round-trips";
}

TEST(RenderJob, ParsesEveryField) {
    const RenderJob j = parse_render_job(json::parse(R"({"scene":"x.dae","width":480,"height":360,"spp":64,"light_rays":4,
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
    EXPECT_DOUBLE_EQ(j.render.time_limit_s, 12.5);
    EXPECT_EQ(j.render.integrator, Integrator::normals);
}

TEST(RenderJob, ErrorsNameTheField) {
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
    EXPECT_THROW(parse_render_job(json{{"scene", "a"}, {"width", 100}, {"height", 100}}, tight), InvalidJob);
}

// Passes multiply a pixel's film, counted as the runners render the job: they estimate its
// error for the curve, so a job without denoising keeps the half-sample buffers too (they were
// left out of the count, and a job of every pass went 15 % past the bound it was held to).
TEST(RenderJob, PassesAreCountedWithTheBuffersTheRunnersKeep) {
    JobLimits limits;
    limits.max_pixels = 1'000'000;
    const json every = {"albedo", "normal", "depth", "position", "object_id", "material_id", "emission", "environment",
                        "diffuse_direct", "diffuse_indirect", "glossy_direct", "glossy_indirect", "variance", "crypto_object",
                        "crypto_material"};
    auto job = [&](int w, int h) { return json{{"scene", "a"}, {"width", w}, {"height", h}, {"passes", every}}; };
    const RenderSettings largest_plain = [] {
        RenderSettings s;
        s.estimate_error = true;
        return s;
    }();
    const PassPlan plain = plan_passes(largest_plain, false, true);
    const double bound = 1e6 * double(Film::bytes_per_pixel(plain.half_buffer, plain.adaptive, plain.aovs));
    RenderSettings as_run = parse_render_job(job(16, 16), limits).render;
    as_run.estimate_error = true;
    const PassPlan plan = plan_passes(as_run, false, true);
    ASSERT_TRUE(plan.half_buffer);
    const double per_pixel = double(Film::bytes_per_pixel(plan.half_buffer, plan.adaptive, plan.aovs));
    // The largest square within the bound is taken, the next one up refused on /passes.
    const int side = int(std::sqrt(bound / per_pixel));
    EXPECT_NO_THROW(parse_render_job(job(side, side), limits));
    try {
        parse_render_job(job(side + 1, side + 1), limits);
        ADD_FAILURE() << "a job of every pass past the bound was taken";
    } catch (const InvalidJob& e) {
        EXPECT_EQ(e.pointer(), "/passes");
    }
}

// A shot's frame times (n / fps, and its shutter's) must be times an animation can be asked
// about; such a job was taken and then failed on every try.
TEST(RenderJob, FrameTimesPastAnyAnimationAreRefusedOnFps) {
    auto shot = [](json frames, double fps) { return json{{"scene", "a"}, {"frames", frames}, {"fps", fps}}; };
    EXPECT_EQ(pointer_of(shot(json::array({10000000}), 1e-302)), "/fps");
    EXPECT_EQ(pointer_of(shot(json::array({0, 1, 2}), 1e-320)), "/fps");
    EXPECT_EQ(pointer_of(shot(json::array({-10000000, 5}), 1e-3)), "/fps");
    EXPECT_EQ(pointer_of(shot({{"start", 1}, {"end", 250}}, 24)), "<accepted>");
    EXPECT_EQ(pointer_of(shot(json::array({10000000}), 0.01)), "<accepted>");  // 10^9 s: the edge
    json blurred = shot(json::array({10000000}), 0.01);
    blurred["shutter"] = {{"open", -0.5}, {"close", 0.5}};
    EXPECT_EQ(pointer_of(blurred), "/fps");
    // And denoising needs two samples a pixel to compare.
    EXPECT_EQ(pointer_of(json{{"scene", "a"}, {"denoise", true}, {"spp", 1}}), "/denoise");
    EXPECT_EQ(pointer_of(json{{"scene", "a"}, {"denoise", true}, {"spp", 2}}), "<accepted>");
    // Both at submission only: a job stored before these checks still reads back.
    EXPECT_NO_THROW(parse_render_job(shot(json::array({10000000}), 1e-302), JobLimits::none()));
    EXPECT_NO_THROW(parse_render_job(json{{"scene", "a"}, {"denoise", true}, {"spp", 1}}, JobLimits::none()));
    EXPECT_NO_THROW(job_from_json(json{{"scene", "a"}, {"denoise", true}, {"spp", 1}}));
}

// A refused value is quoted back cut short: a megabyte of it made a megabyte of answer.
TEST(RenderJob, ARefusedValueIsQuotedCutShort) {
    const std::string huge(1 << 20, 'A');
    for (const json& body : {json{{"scene", "a"}, {"bvh", huge}}, json{{"scene", "a"}, {"passes", {huge}}}, json{{"scene", "a"}, {huge, 1}},
                             json{{"scene", "a"}, {"frames", {{"start", 1}, {"end", 2}, {huge, 3}}}},
                             json{{"scene", "a"}, {"bvh", std::string(78, 'x') + "\xc3\xa9" + huge}}}) {
        try {
            parse_render_job(body);
            ADD_FAILURE() << "taken";
        } catch (const InvalidJob& e) {
            const std::string what = e.what();
            EXPECT_LT(what.size(), 1100u) << what.substr(0, 600);
            EXPECT_LT(e.pointer().size(), 300u);
            EXPECT_NE(what.find("bytes)"), std::string::npos) << what.substr(0, 600);
            EXPECT_NO_THROW((void)json(what).dump()) << "valid UTF-8";
        }
    }
}

// The limits in force at submission apply to the submission only: a stored job reads back
// whatever limits the server has since.
TEST(RenderJob, StoredJobsReadBackWithoutLimits) {
    JobLimits tight;
    tight.max_spp = 8;
    EXPECT_EQ(pointer_of(json{{"scene", "a"}, {"spp", 64}}), "<accepted>");
    EXPECT_THROW(parse_render_job(json{{"scene", "a"}, {"spp", 64}}, tight), InvalidJob);
    const Job back = job_from_json(to_json(parse_render_job(json{{"scene", "a"}, {"spp", 64}})));
    ASSERT_TRUE(std::holds_alternative<RenderJob>(back));
    EXPECT_EQ(std::get<RenderJob>(back).render.spp, 64);
}

// Names: each way to be wrong says which, and a name with a NUL or a line break is refused
// whole rather than cut short in the message that echoes it.
TEST(RenderJob, SceneNamesSayWhatIsWrong) {
    auto message = [](const json& body) -> std::string {
        try {
            parse_render_job(body);
        } catch (const InvalidJob& e) {
            EXPECT_EQ(e.pointer(), "/scene");
            return e.what();
        }
        return "accepted";
    };
    EXPECT_EQ(message({{"scene", ""}}), "/scene must not be empty");
    EXPECT_EQ(message({{"scene", std::string(4097, 'a')}}), "/scene is 4097 characters long; at most 4096 are allowed");
    EXPECT_EQ(message({{"scene", std::string("box\0evil", 8)}}), "/scene must not contain control characters (0x00 at offset 3)");
    EXPECT_EQ(message({{"scene", "box\r\nX"}}), "/scene must not contain control characters (0x0d at offset 3)");
    EXPECT_EQ(message({{"scene", std::string(4096, 'a')}}), "accepted");
}

TEST(RenderJob, SeedCoversInt64AndNoMore) {
    EXPECT_EQ(parse_render_job(json::parse(R"({"scene":"a","seed":9223372036854775807})")).render.seed,
              9223372036854775807ull);
    EXPECT_EQ(pointer_of(json::parse(R"({"scene":"a","seed":9223372036854775808})")), "/seed");
    EXPECT_EQ(pointer_of(json::parse(R"({"scene":"a","seed":9.3e18})")), "/seed");
    EXPECT_EQ(pointer_of(json::parse(R"({"scene":"a","seed":-1})")), "/seed");
}

// `after`: distinct job ids, at most kMaxAfter; each refusal names its place.
TEST(RenderJob, AfterTakesDistinctJobIds) {
    EXPECT_EQ(parse_render_job(json::parse(R"({"scene":"x","after":["00000000000000aa"]})")).after,
              std::vector<std::string>{"00000000000000aa"});
    EXPECT_TRUE(parse_render_job(json::parse(R"({"scene":"x"})")).after.empty());
    for (const auto& [body, pointer] : std::vector<std::pair<const char*, const char*>>{
             {R"({"scene":"x","after":"00000000000000aa"})", "/after"},
             {R"({"scene":"x","after":["00000000000000AA"]})", "/after/0"},
             {R"({"scene":"x","after":["00000000000000aa", 5]})", "/after/1"},
             {R"({"scene":"x","after":["00000000000000aa","00000000000000aa"]})", "/after/1"},
             {R"({"scene":"x","after":["../../etc/passwd"]})", "/after/0"}}) {
        try {
            parse_render_job(json::parse(body));
            ADD_FAILURE() << body << " was accepted";
        } catch (const InvalidJob& e) {
            EXPECT_EQ(e.pointer(), pointer) << body;
        }
    }
    json many = {{"scene", "x"}, {"after", json::array()}};
    for (size_t i = 0; i <= kMaxAfter; ++i) {
        char id[17];
        std::snprintf(id, sizeof id, "%016zx", i);
        many["after"].push_back(id);
    }
    EXPECT_THROW(parse_render_job(many), InvalidJob);
}

// `notify`: an http or https URL with no user, a boolean `frames`, nothing else; each refusal names its place.
TEST(RenderJob, NotifyTakesAnHttpUrl) {
    const RenderJob j = parse_render_job(json::parse(R"({"scene":"x","notify":{"url":"http://h:81/p?q=1"}})"));
    ASSERT_TRUE(j.notify);
    EXPECT_EQ(j.notify->url, "http://h:81/p?q=1");
    EXPECT_FALSE(j.notify->frames);
    EXPECT_FALSE(parse_render_job(json::parse(R"({"scene":"x","notify":null})")).notify);
    EXPECT_EQ(parse_render_job(json::parse(R"({"scene":"x","notify":{"url":"https://h/p"}})")).notify->url, "https://h/p");
    for (const auto& [body, pointer] : std::vector<std::pair<const char*, const char*>>{
             {R"({"scene":"x","notify":"http://h/"})", "/notify"},
             {R"({"scene":"x","notify":{}})", "/notify/url"},
             {R"({"scene":"x","notify":{"url":"ftp://h/"}})", "/notify/url"},
             {R"({"scene":"x","notify":{"url":"https://u@h/"}})", "/notify/url"},
             {R"({"scene":"x","notify":{"url":"http://u:p@h/"}})", "/notify/url"},
             {R"({"scene":"x","notify":{"url":"http://h/a b"}})", "/notify/url"},
             {R"({"scene":"x","notify":{"url":"http:///x"}})", "/notify/url"},
             {R"({"scene":"x","notify":{"url":"http://h/","frames":"yes"}})", "/notify/frames"},
             {R"({"scene":"x","notify":{"url":"http://h/","secret":"x"}})", "/notify/secret"}}) {
        try {
            parse_render_job(json::parse(body));
            ADD_FAILURE() << body << " was accepted";
        } catch (const InvalidJob& e) {
            EXPECT_EQ(e.pointer(), pointer) << body;
        }
    }
}

// `requires`: distinct node tags of one form, at most 16; each refusal names its place.
TEST(RenderJob, RequiresTakesDistinctNodeTags) {
    EXPECT_EQ(parse_render_job(json::parse(R"({"scene":"x","requires":["b.2","a-1","c_3"]})")).tasks.required_tags,
              (std::vector<std::string>{"a-1", "b.2", "c_3"}));
    json many = json::array();
    for (int i = 0; i < 17; ++i) many.push_back("t" + std::to_string(i));
    for (const auto& [body, pointer] : std::vector<std::pair<json, const char*>>{
             {json::parse(R"({"scene":"x","requires":"gpu"})"), "/requires"},
             {json::parse(R"({"scene":"x","requires":["gpu","gpu"]})"), "/requires/1"},
             {json::parse(R"({"scene":"x","requires":["GPU"]})"), "/requires/0"},
             {json::parse(R"({"scene":"x","requires":[""]})"), "/requires/0"},
             {json::parse(R"({"scene":"x","requires":["-x"]})"), "/requires/0"},
             {json::parse(R"({"scene":"x","requires":["a,b"]})"), "/requires/0"},
             {json::parse(R"({"scene":"x","requires":["a|b"]})"), "/requires/0"},
             {json::parse(R"({"scene":"x","requires":[7]})"), "/requires/0"},
             {json::parse(R"({"scene":"x","requires":["aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa"]})"), "/requires/0"},
             {json{{"scene", "x"}, {"requires", many}}, "/requires"},
             {json::parse(R"({"scene":"x","max_retries":-1})"), "/max_retries"},
             {json::parse(R"({"scene":"x","max_retries":101})"), "/max_retries"},
             {json::parse(R"({"scene":"x","blocklist_after":0})"), "/blocklist_after"},
             {json::parse(R"({"scene":"x","denoise":true,"guided_sampling":"yes"})"), "/guided_sampling"},
             {json::parse(R"({"scene":"x","denoise":true,"guided_sampling":1})"), "/guided_sampling"},
             {json::parse(R"({"scene":"x","denoise":true,"guided_sampling":null})"), "/guided_sampling"},
             {json::parse(R"({"scene":"x","denoise":true,"guided_sampling":{"on":true}})"), "/guided_sampling"}}) {
        try {
            parse_render_job(body);
            ADD_FAILURE() << body.dump() << " was accepted";
        } catch (const InvalidJob& e) {
            EXPECT_EQ(e.pointer(), pointer) << body.dump();
        }
    }
}

// Every field survives to_json and back, for a job far from the defaults.
TEST(RenderJob, RoundTripsEveryField) {
    const json body = json::parse(R"({"scene":"x.dae","width":48,"height":36,"spp":64,"light_rays":4,
        "max_depth":5,"bvh":"median","direct":"mis","russian_roulette":0.5,"bounces":"nth","lighting":"indirect",
        "light_selection":"power","adaptive":{"batch":16,"tolerance":0.25},"tile_size":16,"seed":7,"priority":3,
        "time_limit_s":12.5,"target_error":0.125,"reference":"0123456789abcdef","max_leaf_size":4,
        "triangle_test":"moller_trumbore","integrator":"path","sampler":"independent","environment":"sky",
        "lens_radius":0.25,"focal_distance":3.5,"passes":["variance","albedo"],"denoise":true,"guided_sampling":false,
        "after":["00000000000000aa","0123456789abcdef"],"notify":{"url":"http://hooks.test:8080/done","frames":true},
        "requires":["gpu","bigmem"],"max_retries":0,"blocklist_after":7})");
    json want = body;
    want.update({{"frames", nullptr}, {"fps", 24.0}, {"chunk", 0}, {"animation", nullptr}, {"shutter", nullptr}});
    want["passes"] = {"albedo", "variance"};  // in the table's order
    want["requires"] = {"bigmem", "gpu"};     // sorted: one set of tags, one lane
    const json back = to_json(parse_render_job(body));
    EXPECT_EQ(back, want) << back.dump();
    EXPECT_EQ(to_json(std::get<RenderJob>(job_from_json(back))), back);
}

// A shot's fields survive to_json and back in both forms of `frames`, and `animation` as a name
// or as an index.
TEST(RenderJob, ShotFieldsRoundTrip) {
    for (const char* text : {R"({"scene":"x.gltf","frames":{"start":-3,"end":9,"step":4},"fps":30,"animation":"Walk"})",
                             R"({"scene":"x.gltf","frames":[7,1,4],"fps":12.5,"animation":"2"})",
                             R"({"scene":"x.gltf","frames":[7],"fps":24.0,"animation":2})"}) {
        const json body = json::parse(text);
        const json back = to_json(parse_render_job(body));
        for (const char* k : {"frames", "fps", "animation"}) EXPECT_EQ(back[k], body[k]) << k << " of " << text;
        EXPECT_EQ(to_json(std::get<RenderJob>(job_from_json(back))), back);
    }
    // A number is an index, and stays one (a file may name an animation "3").
    EXPECT_EQ(to_json(parse_render_job(json::parse(R"({"scene":"x","frames":[1],"animation":3})")))["animation"], 3);
    EXPECT_TRUE(parse_render_job(json::parse(R"({"scene":"x","frames":[1],"animation":3})")).animation_index);
    EXPECT_FALSE(parse_render_job(json::parse(R"({"scene":"x","frames":[1],"animation":"3"})")).animation_index);
    const RenderJob range = parse_render_job(json::parse(R"({"scene":"x","frames":{"start":-3,"end":9,"step":4}})"));
    EXPECT_EQ(range.frames->frames(), (std::vector<int>{-3, 1, 5, 9}));
    EXPECT_EQ(range.frames->count(), 4u);
    EXPECT_EQ(parse_render_job(json::parse(R"({"scene":"x","frames":{"start":5,"end":5}})")).frames->frames(), (std::vector<int>{5}));
    for (int f = -6; f <= 12; ++f) {
        const auto all = range.frames->frames();
        EXPECT_EQ(range.frames->contains(f), std::find(all.begin(), all.end(), f) != all.end()) << f;
    }
    EXPECT_TRUE(parse_render_job(json::parse(R"({"scene":"x","frames":[7,1,4]})")).frames->contains(4));
    EXPECT_FALSE(parse_render_job(json::parse(R"({"scene":"x","frames":[7,1,4]})")).frames->contains(5));
}

TEST(RenderJob, BadShotsAreRefusedNamingTheField) {
    auto refused = [](const char* text) { return pointer_of(json::parse(text)); };
    EXPECT_EQ(refused(R"({"scene":"x","frames":[]})"), "/frames");
    EXPECT_EQ(refused(R"({"scene":"x","frames":[1,2,1]})"), "/frames");
    EXPECT_EQ(refused(R"({"scene":"x","frames":[1,2.5]})"), "/frames/1");
    EXPECT_EQ(refused(R"({"scene":"x","frames":{"start":9,"end":1}})"), "/frames/end");
    EXPECT_EQ(refused(R"({"scene":"x","frames":{"start":1,"end":9,"step":0}})"), "/frames/step");
    EXPECT_EQ(refused(R"({"scene":"x","frames":{"start":1}})"), "/frames");
    EXPECT_EQ(refused(R"({"scene":"x","frames":{"start":1,"end":2,"every":3}})"), "/frames/every");
    EXPECT_EQ(refused(R"({"scene":"x","frames":{"start":0,"end":2000000000}})"), "/frames/end");
    EXPECT_EQ(refused(R"({"scene":"x","frames":{"start":-10000000,"end":10000000}})"), "/frames");  // over max_frames
    EXPECT_EQ(refused(R"({"scene":"x","frames":"1-10"})"), "/frames");
    json long_list = {{"scene", "x"}, {"frames", json::array()}};
    for (int f = 0; f < 1001; ++f) long_list["frames"].push_back(f);
    EXPECT_EQ(pointer_of(long_list), "/frames");  // a list is kept short: it comes back with every status
    long_list["frames"].erase(1000);
    EXPECT_EQ(pointer_of(long_list), "<accepted>");
    EXPECT_EQ(refused(R"({"scene":"x","frames":[1],"fps":0})"), "/fps");
    EXPECT_EQ(refused(R"({"scene":"x","frames":[1],"animation":""})"), "/animation");
    EXPECT_EQ(refused(R"({"scene":"x","frames":[1],"animation":-1})"), "/animation");
    EXPECT_EQ(refused(R"({"scene":"x","frames":[1],"reference":"0123456789abcdef"})"), "/reference");
    // The shutter: {open, close} in frames, open before close, within a frame either way; a shot's only; our BVH's.
    EXPECT_EQ(pointer_of(json::parse(R"({"scene":"x","frames":[1],"shutter":{"open":-0.25,"close":0.25}})")), "<accepted>");
    EXPECT_EQ(pointer_of(json::parse(R"({"scene":"x","frames":[1],"shutter":null})")), "<accepted>");
    EXPECT_EQ(refused(R"({"scene":"x","shutter":{"open":-0.25,"close":0.25}})"), "/shutter");  // a still
    EXPECT_EQ(refused(R"({"scene":"x","frames":[1],"bvh":"embree","shutter":{"open":0,"close":0.5}})"), "/shutter");
    EXPECT_EQ(refused(R"({"scene":"x","frames":[1],"shutter":{"open":0.25,"close":0.25}})"), "/shutter/close");
    EXPECT_EQ(refused(R"({"scene":"x","frames":[1],"shutter":{"open":-2,"close":0.25}})"), "/shutter/open");
    EXPECT_EQ(refused(R"({"scene":"x","frames":[1],"shutter":{"open":0}})"), "/shutter/close");
    EXPECT_EQ(refused(R"({"scene":"x","frames":[1],"shutter":{"open":"0","close":1}})"), "/shutter/open");
    EXPECT_EQ(refused(R"({"scene":"x","frames":[1],"shutter":{"open":0,"close":1,"angle":180}})"), "/shutter/angle");
    EXPECT_EQ(refused(R"({"scene":"x","frames":[1],"shutter":[0,1]})"), "/shutter");
    const RenderJob blurred = parse_render_job(json::parse(R"({"scene":"x","frames":[1],"shutter":{"open":-0.5,"close":0}})"));
    ASSERT_TRUE(blurred.shutter);
    EXPECT_EQ(blurred.shutter->first, -0.5);
    EXPECT_EQ(to_json(blurred)["shutter"], json::parse(R"({"open":-0.5,"close":0.0})"));
    JobLimits small;
    small.max_frames = 10;
    EXPECT_THROW(parse_render_job(json::parse(R"({"scene":"x","frames":{"start":1,"end":11}})"), small), InvalidJob);
    EXPECT_NO_THROW(parse_render_job(json::parse(R"({"scene":"x","frames":{"start":1,"end":10}})"), small));
}

// Frame seeds: a pure function of (seed, frame), different for neighbouring frames and seeds,
// within the seed field's range.
TEST(RenderJob, FrameSeedsAreDistinctAndStable) {
    std::set<uint64_t> seen;
    for (uint64_t seed : {0ull, 1ull, 42ull})
        for (int f = -50; f <= 50; ++f) {
            const uint64_t s = frame_seed(seed, f);
            EXPECT_EQ(s, frame_seed(seed, f));
            EXPECT_LE(s, uint64_t(std::numeric_limits<int64_t>::max()));
            seen.insert(s);
        }
    EXPECT_EQ(seen.size(), 3u * 101u);
}

ComparisonJob comparison(const json& body) { return parse_comparison_job(body); }

std::string comparison_pointer(const json& body) {
    try {
        parse_comparison_job(body);
    } catch (const InvalidJob& e) {
        return e.pointer();
    }
    return "<accepted>";
}

TEST(ComparisonJob, DefaultsBoundsAndConfigs) {
    const ComparisonJob c = comparison(json{{"scene", "builtin:cornell_box"}});
    EXPECT_EQ(c.width, 160);
    EXPECT_EQ(c.height, 120);
    EXPECT_EQ(c.max_depth, 5);
    EXPECT_DOUBLE_EQ(c.seconds, 2.0);
    EXPECT_EQ(c.reps, 3);
    EXPECT_EQ(c.reference_spp, 1024);
    EXPECT_TRUE(c.standard_configs);
    EXPECT_EQ(comparison_pointer(json{{"width", 64}}), "/scene");
    EXPECT_EQ(comparison_pointer(json{{"scene", "a"}, {"width", 4}}), "/width");
    EXPECT_EQ(comparison_pointer(json{{"scene", "a"}, {"seconds", 0}}), "/seconds");
    EXPECT_EQ(comparison_pointer(json{{"scene", "a"}, {"target_error", 0}}), "/target_error");
    EXPECT_EQ(comparison_pointer(json{{"scene", "a"}, {"spp", 4}}), "/spp");
    EXPECT_EQ(comparison_pointer(json{{"scene", "a"}, {"configs", json::array()}}), "/configs");
    EXPECT_EQ(comparison_pointer(json::parse(R"({"scene":"a","configs":[{"direct":"mis"}]})")), "/configs/0");
    EXPECT_EQ(comparison_pointer(json::parse(R"({"scene":"a","configs":[{"label":"x","spp":4}]})")), "/configs/0/spp");
    EXPECT_EQ(comparison_pointer(json::parse(R"({"scene":"a","configs":[{"label":"x","bvh":"kd"}]})")), "/configs/0/bvh");
    EXPECT_EQ(comparison_pointer(json::parse(R"({"scene":"a","configs":[{"label":"x","adaptive":{"tol":1}}]})")),
              "/configs/0/adaptive/tol");
    // A comparison's depth has the jobs' bound (the server's --max-depth), not one of its own.
    EXPECT_EQ(comparison_pointer(json{{"scene", "a"}, {"max_depth", 500}}), "<accepted>");
    JobLimits tight;
    tight.max_depth = 10;
    EXPECT_THROW(parse_comparison_job(json{{"scene", "a"}, {"max_depth", 11}}, tight), InvalidJob);

    const json body = json::parse(R"({"scene":"a","configs":[{"label":"MIS","direct":"mis","light_rays":4}],"reps":2})");
    const ComparisonJob parsed = comparison(body);
    ASSERT_EQ(parsed.configs.size(), 1u);
    EXPECT_EQ(parsed.configs[0].label, "MIS");
    EXPECT_EQ(parsed.configs[0].job.render.direct, DirectLighting::mis);
    EXPECT_EQ(parsed.configs[0].job.render.light_rays, 4);
    const json stored = to_json(parsed);
    EXPECT_EQ(stored["kind"], "comparison");
    const Job back = job_from_json(stored);
    ASSERT_TRUE(std::holds_alternative<ComparisonJob>(back));
    EXPECT_EQ(to_json(std::get<ComparisonJob>(back)), stored);
}

}  // namespace
}  // namespace tessera::api
