// Pausing and resuming jobs through the HTTP API of a real server: a paused job frees its render
// threads, keeps its film, survives a restart paused, and resumed it ends with the image it would
// have had never paused, bit for bit.
#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <string>
#include <thread>

#include "engine/io/image_io.h"
#include "tests/server/server_fixture.h"
#include "tests/test_scale.h"

namespace tessera::server {
namespace {

using nlohmann::json;

// Long enough to pause in the middle (a few seconds on two threads), small enough to finish. A
// sanitizer build renders about ten times slower: a quarter of the samples there, the same test
// (the pauses come after 4 and 20 of them).
const json kPausable = {{"scene", "builtin:cornell_spheres"}, {"width", 96}, {"height", 72}, {"spp", test::kWorkScale > 1 ? 256 : 1024},
                        {"max_depth", 4}, {"tile_size", 16}, {"seed", 5}};

class Pause : public Server {
protected:
    httplib::Result post(const std::string& id, const char* action) {
        return client_->Post("/v1/jobs/" + id + ":" + action, "", "application/json");
    }
    Image image_of(const std::string& id) { return read_image((dir_ / "jobs" / id / "image.exr").string()); }
    void wait_samples(const std::string& id, uint64_t at_least, int polls = 600) {
        for (int i = 0; i < polls; ++i) {
            const json s = status(id);
            if (s["state"] == "running" && s["progress"]["samples_done"].get<uint64_t>() >= at_least) return;
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        FAIL() << "job " << id << " did not reach " << at_least << " samples";
    }
};

bool same_pixels(const Image& a, const Image& b) {
    return a.rgb.size() == b.rgb.size() && std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)) == 0;
}

TEST_F(Pause, APausedJobFreesItsThreadsAndResumedEndsWithTheNeverPausedImage) {
    start();
    const std::string whole = submit(kPausable);
    wait_state(whole, {"succeeded"}, 120);

    const std::string id = submit(kPausable);
    wait_samples(id, 96 * 72 * 20);
    auto p = post(id, "pause");
    ASSERT_TRUE(p && p->status == 200) << (p ? p->body : "no answer");
    const json paused = wait_state(id, {"paused"}, 10);
    EXPECT_EQ(paused["finished_at"], nullptr);
    ASSERT_TRUE(std::filesystem::exists(dir_ / "jobs" / id / "checkpoint.tck"));
    // Idempotent; listed under its state; the render threads serve the next job meanwhile.
    auto again = post(id, "pause");
    ASSERT_TRUE(again && again->status == 200);
    EXPECT_EQ(json::parse(again->body)["state"], "paused");
    auto listed = client_->Get("/v1/jobs?state=paused");
    ASSERT_TRUE(listed && listed->status == 200);
    EXPECT_EQ(json::parse(listed->body)["jobs"][0]["id"], id);
    const std::string other = submit(kSmallJob);
    wait_state(other, {"succeeded"}, 30);
    EXPECT_EQ(status(id)["state"], "paused");

    // Paused, it stays paused across a restart.
    restart();
    EXPECT_EQ(status(id)["state"], "paused");

    auto r = post(id, "resume");
    ASSERT_TRUE(r && r->status == 200) << (r ? r->body : "no answer");
    EXPECT_NE(json::parse(r->body)["state"], "paused");
    const json done = wait_state(id, {"succeeded"}, 120);
    ASSERT_TRUE(done["recovered"].is_object()) << done.dump();
    EXPECT_GE(done["recovered"]["samples"].get<uint64_t>(), uint64_t(96 * 72 * 20));
    EXPECT_TRUE(same_pixels(image_of(id), image_of(whole)));
    EXPECT_FALSE(std::filesystem::exists(dir_ / "jobs" / id / "checkpoint.tck"));
    // Resuming a finished job is a conflict, as is pausing one.
    expect_problem(post(id, "resume"), 409);
    expect_problem(post(id, "pause"), 409);

    // A pause taken back before it took effect: the job goes on (queued again from its
    // checkpoint), to the same image.
    const std::string quick = submit(kPausable);
    wait_samples(quick, 96 * 72 * 20);
    ASSERT_TRUE(post(quick, "pause"));
    auto back = post(quick, "resume");
    ASSERT_TRUE(back && back->status == 200);
    // Patient: a sanitizer build on two shared cores renders it in about a minute.
    const json ended = wait_state(quick, {"succeeded", "paused"}, 400);
    ASSERT_EQ(ended["state"], "succeeded") << ended.dump();
    EXPECT_TRUE(same_pixels(image_of(quick), image_of(whole)));
}

// A shot paused inside a frame keeps that frame's checkpoint in the frame's folder (made for
// it: the frame has none until it is written), and resumed gives every frame of the never-paused
// shot, bit for bit.
TEST_F(Pause, AShotPausedInsideAFrameResumesFromTheFramesCheckpoint) {
    start();
    // A sanitizer build renders about ten times slower: a smaller frame there, the same test.
    const int w = test::kWorkScale > 1 ? 24 : 96, h = test::kWorkScale > 1 ? 18 : 72;
    const json shot = {{"scene", "cornell_shot"}, {"width", w}, {"height", h}, {"spp", 512}, {"max_depth", 3},
                       {"frames", {{"start", 0}, {"end", 24}, {"step", 12}}}};
    const std::string whole = submit(shot);
    wait_state(whole, {"succeeded"}, 300);
    const std::string id = submit(shot);
    wait_samples(id, uint64_t(w) * uint64_t(h) * 600, 6000);  // into the second frame
    ASSERT_TRUE(post(id, "pause"));
    wait_state(id, {"paused"}, 10);
    bool kept = false;
    for (const int n : {0, 12, 24}) kept = kept || std::filesystem::exists(dir_ / "jobs" / id / "frames" / std::to_string(n) / "checkpoint.tck");
    EXPECT_TRUE(kept) << "the frame in hand's checkpoint";
    ASSERT_TRUE(post(id, "resume"));
    ASSERT_EQ(wait_state(id, {"succeeded"}, 300)["state"], "succeeded");
    for (const int n : {0, 12, 24}) {
        const std::string f = "frames/" + std::to_string(n) + "/image.exr";
        EXPECT_TRUE(same_pixels(read_image((dir_ / "jobs" / id / f).string()), read_image((dir_ / "jobs" / whole / f).string()))) << f;
        EXPECT_FALSE(std::filesystem::exists(dir_ / "jobs" / id / "frames" / std::to_string(n) / "checkpoint.tck"));
    }
}

TEST_F(Pause, AQueuedJobPausedIsSkippedUntilResumed) {
    start();
    const std::string blocker = submit(kLongJob);
    wait_state(blocker, {"running"});
    const std::string a = submit(kSmallJob), b = submit(kSmallJob);
    auto p = post(a, "pause");
    ASSERT_TRUE(p && p->status == 200);
    EXPECT_EQ(json::parse(p->body)["state"], "paused");
    EXPECT_EQ(status(b)["queue_position"], 0);
    client_->Delete("/v1/jobs/" + blocker);
    wait_state(b, {"succeeded"});
    EXPECT_EQ(status(a)["state"], "paused");
    // Resuming a queued or running job changes nothing.
    auto r = post(a, "resume");
    ASSERT_TRUE(r && r->status == 200);
    wait_state(a, {"succeeded"});
}

TEST_F(Pause, APausedJobCanBeCanceledAndLeavesNoCheckpoint) {
    start();
    const std::string id = submit(kPausable);
    wait_samples(id, 96 * 72 * 4);
    ASSERT_TRUE(post(id, "pause"));
    wait_state(id, {"paused"}, 10);
    auto c = client_->Delete("/v1/jobs/" + id);
    ASSERT_TRUE(c && c->status == 200);
    EXPECT_EQ(json::parse(c->body)["state"], "canceled");
    // The checkpoint goes with the job's end (removed by the canceling request or its worker).
    for (int i = 0; i < 100 && std::filesystem::exists(dir_ / "jobs" / id / "checkpoint.tck"); ++i)
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    EXPECT_FALSE(std::filesystem::exists(dir_ / "jobs" / id / "checkpoint.tck"));
}

TEST_F(Pause, RefusalsNameTheirReason) {
    start();
    expect_problem(post("0123456789abcdef", "pause"), 404);
    expect_problem(post("0123456789abcdef", "resume"), 404);
    const std::string id = submit(kSmallJob);
    wait_state(id, {"succeeded"});
    expect_problem(post(id, "pause"), 409);
    // Only POST: another method is a 405 naming it.
    auto g = client_->Get("/v1/jobs/" + id + ":pause");
    ASSERT_TRUE(g);
    EXPECT_EQ(g->status, 405);
    EXPECT_EQ(g->get_header_value("Allow"), "POST");
    // An unknown action is no route.
    auto x = post(id, "explode");
    ASSERT_TRUE(x);
    EXPECT_NE(x->status, 200);
}

}  // namespace
}  // namespace tessera::server
