// A job's links name what it will have, and only that: every link of a finished job of each kind
// (a still, a denoising still with passes, one that ended before it could denoise, a denoising
// shot, one whose frames could not denoise and whose preview could not be made, a comparison)
// answers 200, a canceled job links to itself alone,
// and a shot's or a comparison's status names no still's image.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "tests/server/server_fixture.h"

namespace tessera::server {
namespace {

using nlohmann::json;

class JobLinks : public Server {
protected:
    // Fetches every link (frame `n` for a shot's), expecting each to be there.
    void expect_every_link_answers(const json& status, int frame) {
        ASSERT_TRUE(status["links"].is_object()) << status.dump();
        for (const auto& [name, link] : status["links"].items()) {
            std::string path = link.get<std::string>();
            if (const size_t at = path.find("{n}"); at != std::string::npos) path.replace(at, 3, std::to_string(frame));
            auto r = client_->Get(path);
            ASSERT_TRUE(r) << path;
            EXPECT_EQ(r->status, 200) << name << ": " << path << " " << r->body;
        }
    }
};

TEST_F(JobLinks, EveryLinkOfAFinishedJobIsThere) {
    start();
    const std::string still = submit(kSmallJob);
    json plain = wait_state(still, {"succeeded", "failed"});
    ASSERT_EQ(plain["state"], "succeeded") << plain.dump();
    EXPECT_TRUE(plain["links"].contains("image_png"));
    EXPECT_FALSE(plain["links"].contains("denoised_png")) << "not asked for";
    EXPECT_FALSE(plain["links"].contains("passes_exr")) << "not asked for";
    expect_every_link_answers(plain, 0);

    json asking = kSmallJob;
    asking["spp"] = 8;
    asking["denoise"] = true;
    asking["passes"] = {"albedo", "depth"};
    const std::string denoised = submit(asking);
    json d = wait_state(denoised, {"succeeded", "failed"});
    ASSERT_EQ(d["state"], "succeeded") << d.dump();
    EXPECT_TRUE(d["links"].contains("denoised_png"));
    EXPECT_TRUE(d["links"].contains("passes_exr"));
    EXPECT_TRUE(d["links"].contains("pass_depth_exr")) << "each pass alone too";
    EXPECT_TRUE(d["links"].contains("convergence_svg"));
    expect_every_link_answers(d, 0);

    // A denoising job whose time ran out before two samples a pixel made no denoised image.
    const json hurried = {{"scene", "builtin:cornell_box"}, {"width", 320}, {"height", 240}, {"spp", 65536}, {"max_depth", 5},
                          {"denoise", true}, {"time_limit_s", 0.001}};
    const std::string hid = submit(hurried);
    json h = wait_state(hid, {"succeeded", "failed"});
    ASSERT_EQ(h["state"], "succeeded") << h.dump();
    EXPECT_FALSE(h["links"].contains("denoised_png")) << h.dump();
    expect_every_link_answers(h, 0);

    const json shot = {{"scene", "cornell_shot"}, {"width", 16}, {"height", 12}, {"spp", 4}, {"max_depth", 1}, {"denoise", true},
                       {"passes", {"normal"}}, {"frames", {{"start", 0}, {"end", 24}, {"step", 24}}}};
    const std::string sid = submit(shot);
    json s = wait_state(sid, {"succeeded", "failed"});
    ASSERT_EQ(s["state"], "succeeded") << s.dump();
    EXPECT_FALSE(s["links"].contains("image_png")) << "a shot's images are per frame";
    EXPECT_TRUE(s["links"].contains("frame_denoised_png"));
    EXPECT_TRUE(s["links"].contains("frame_pass_normal_exr"));
    EXPECT_TRUE(s["links"].contains("frame_report"));
    expect_every_link_answers(s, 24);

    // A shot whose frames' time ran out before two samples a pixel has no denoised frames, and
    // one rendered where ffmpeg cannot run has no preview: neither is linked.
    ::setenv("TESSERA_FFMPEG", "/nonexistent/ffmpeg", 1);
    const json hurried_shot = {{"scene", "cornell_shot"}, {"width", 320}, {"height", 240}, {"spp", 65536}, {"max_depth", 5},
                               {"denoise", true}, {"time_limit_s", 0.001}, {"frames", {{"start", 0}, {"end", 24}, {"step", 24}}}};
    const std::string hsid = submit(hurried_shot);
    json hs = wait_state(hsid, {"succeeded", "failed"});
    ::unsetenv("TESSERA_FFMPEG");
    ASSERT_EQ(hs["state"], "succeeded") << hs.dump();
    EXPECT_FALSE(hs["links"].contains("frame_denoised_png")) << hs.dump();
    EXPECT_FALSE(hs["links"].contains("preview")) << hs.dump();
    expect_every_link_answers(hs, 24);

    // A canceled job keeps nothing: it links to itself alone.
    json slow = kSmallJob;
    slow["width"] = 200;
    slow["height"] = 150;
    slow["spp"] = 65536;
    const std::string cid0 = submit(slow);
    client_->Delete("/v1/jobs/" + cid0);
    json canceled = wait_state(cid0, {"canceled"});
    EXPECT_EQ(canceled["links"], json({{"self", "/v1/jobs/" + cid0}})) << canceled.dump();

    const json comparison = {{"scene", "builtin:cornell_box"}, {"width", 16}, {"height", 12}, {"seconds", 0.05}, {"reps", 1},
                             {"reference_spp", 16}, {"max_depth", 2},
                             {"configs", json::array({{{"label", "a"}, {"direct", "hemisphere"}}, {{"label", "b"}, {"direct", "importance"}}})}};
    auto r = client_->Post("/v1/comparisons", comparison.dump(), "application/json");
    ASSERT_TRUE(r && r->status == 202) << (r ? r->body : "no answer");
    const std::string cid = json::parse(r->body)["id"];
    json c = wait_state(cid, {"succeeded", "failed"});
    ASSERT_EQ(c["state"], "succeeded") << c.dump();
    EXPECT_FALSE(c["links"].contains("image_png")) << "a comparison makes no image";
    expect_every_link_answers(c, 0);
}

}  // namespace
}  // namespace tessera::server
