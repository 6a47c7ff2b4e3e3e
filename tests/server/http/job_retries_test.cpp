// Failures on one process, through the HTTP API of a real server: a run that fails for a reason
// other than its input runs again up to the job's max_retries, then the job fails with every
// reason, each run in its log; a job requiring node tags this process lacks is refused.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "tests/server/server_fixture.h"

namespace tessera::server {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

TEST_F(Server, ARunThatFailsRunsAgainUpToMaxRetriesThenFailsWithEveryReason) {
    // A map of the test's own: taken away after the job is accepted, so that its runs fail.
    const fs::path sky = fs::temp_directory_path() / ("tessera_retries_" + std::to_string(::getpid()));
    fs::create_directories(sky);
    fs::copy_file(fs::path(TESSERA_PROJECT_SCENES) / "sky.exr", sky / "gone_sky.exr", fs::copy_options::overwrite_existing);
    scene_dirs_ = {sky.string()};
    start();
    for (const int retries : {2, 0}) {
        SCOPED_TRACE("max_retries " + std::to_string(retries));
        fs::copy_file(fs::path(TESSERA_PROJECT_SCENES) / "sky.exr", sky / "gone_sky.exr", fs::copy_options::overwrite_existing);
        const std::string hold = submit(kLongJob);
        wait_state(hold, {"running"});
        json job = kSmallJob;
        job["environment"] = "gone_sky";
        job["max_retries"] = retries;
        const std::string id = submit(job);
        fs::remove(sky / "gone_sky.exr");
        ASSERT_EQ(client_->Delete("/v1/jobs/" + hold)->status, 200);
        const json s = wait_state(id, {"failed", "succeeded"});
        ASSERT_EQ(s["state"], "failed") << s.dump();
        const std::string error = s["error"];
        const int runs = retries + 1;
        EXPECT_EQ(s["attempts"], runs) << "each run is a start";
        EXPECT_EQ(error.rfind("scene: ", 0), 0u) << "the reason itself first: " << error;
        EXPECT_NE(error.find("gone_sky"), std::string::npos) << error;
        if (retries > 0)
            EXPECT_NE(error.find("(failed " + std::to_string(runs) + " times, more than the job's max_retries (" + std::to_string(retries) +
                                 "), each time so)"),
                      std::string::npos) << error;
        else
            EXPECT_EQ(error.find("failed 1 times"), std::string::npos) << error;
        // Every run in the job's log, each failed with its error.
        auto log = client_->Get("/v1/jobs/" + id + "/log");
        ASSERT_TRUE(log && log->status == 200);
        int failed = 0;
        std::istringstream lines(log->body);
        for (std::string line; std::getline(lines, line);) {
            const json t = json::parse(line);
            if (t["task"] == "render" && t["outcome"] == "failed") {
                ++failed;
                EXPECT_FALSE(t["errors"].empty());
            }
        }
        EXPECT_EQ(failed, runs);
    }
    // A map that comes back between runs: the job succeeds on a later run.
    fs::copy_file(fs::path(TESSERA_PROJECT_SCENES) / "sky.exr", sky / "gone_sky.exr", fs::copy_options::overwrite_existing);
    const std::string hold = submit(kLongJob);
    wait_state(hold, {"running"});
    json job = kSmallJob;
    job["environment"] = "gone_sky";
    job["max_retries"] = 100;
    const std::string id = submit(job);
    fs::rename(sky / "gone_sky.exr", sky / "away.exr");
    ASSERT_EQ(client_->Delete("/v1/jobs/" + hold)->status, 200);
    for (int i = 0; i < 500 && status(id)["attempts"].get<int>() < 3; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    fs::rename(sky / "away.exr", sky / "gone_sky.exr");
    const json back = wait_state(id, {"failed", "succeeded"});
    EXPECT_EQ(back["state"], "succeeded") << back.dump();
    EXPECT_GE(back["attempts"].get<int>(), 3);
    std::error_code ec;
    fs::remove_all(sky, ec);
}

// One process has only its own --tags: no node will ever come that has others.
TEST_F(Server, AJobRequiringTagsThisProcessLacksIsRefused) {
    start();
    json job = kSmallJob;
    job["requires"] = {"bigmem"};
    const auto r = post_job(job);
    expect_problem(r, 400, "/requires");
    EXPECT_NE(r->body.find("no-node-has-tags"), std::string::npos) << r->body;
    EXPECT_NE(r->body.find("bigmem"), std::string::npos) << r->body;
    expect_problem(post_job({{"scene", "builtin:cornell_box"}, {"requires", {"Big Mem"}}}), 400, "/requires/0");
    EXPECT_EQ(wait_state(submit(kSmallJob), {"succeeded", "failed"})["state"], "succeeded") << "and the server goes on";
}

}  // namespace
}  // namespace tessera::server
