// Jobs that run after others (`after`), through the HTTP API of a real server: a chain runs in
// order; a failed or canceled job fails or cancels the jobs that run after it, each naming the
// job it waited for; unknown ids are refused before anything is stored.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "tests/server/server_fixture.h"

namespace tessera::server {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

json after(json job, std::initializer_list<std::string> ids) {
    job["after"] = json::array();
    for (const std::string& id : ids) job["after"].push_back(id);
    return job;
}

const json kShortJob = {{"scene", "builtin:cornell_box"}, {"width", 48}, {"height", 36}, {"spp", 64}, {"max_depth", 3}};

TEST_F(Server, AChainOfJobsRunsInOrder) {
    start();
    const std::string a = submit(kShortJob);
    const std::string b = submit(after(kShortJob, {a}));
    const std::string c = submit(after(kSmallJob, {b, a}));
    EXPECT_EQ(status(c)["state"], "waiting");
    EXPECT_EQ(status(c)["queue_position"], nullptr);
    EXPECT_EQ(status(c)["settings"]["after"], json::array({b, a}));
    const json sa = wait_state(a, {"succeeded"}), sb = wait_state(b, {"succeeded"}), sc = wait_state(c, {"succeeded"});
    EXPECT_GE(sb["started_at"].get<double>(), sa["finished_at"].get<double>());
    EXPECT_GE(sc["started_at"].get<double>(), sb["finished_at"].get<double>());
    // After a job that has succeeded already: queued at once.
    const json now = json::parse(post_job(after(kSmallJob, {c}))->body);
    EXPECT_NE(now["state"], "waiting");
}

TEST_F(Server, AFailedJobFailsTheJobsAfterItNamingIt) {
    start();
    fs::create_directories(dir_ / "uploads" / "0000000000000000");
    std::ofstream(dir_ / "uploads" / "0000000000000000" / "broken.dae") << "<?xml version=\"1.0\"?><COLLADA><asset>";
    json broken = kSmallJob;
    broken["scene"] = "upload/0000000000000000/broken";
    const std::string blocker = submit(kLongJob);  // so that the chain is submitted before its first job fails
    const std::string a = submit(broken);
    const std::string b = submit(after(kSmallJob, {a}));
    const std::string c = submit(after(kSmallJob, {b}));
    client_->Delete("/v1/jobs/" + blocker);
    EXPECT_EQ(wait_state(a, {"failed", "succeeded"})["state"], "failed");
    const json sb = wait_state(b, {"failed", "succeeded", "canceled"}), sc = wait_state(c, {"failed", "succeeded", "canceled"});
    EXPECT_EQ(sb["state"], "failed");
    EXPECT_NE(sb["error"].get<std::string>().find("job " + a + ", which it runs after, failed"), std::string::npos) << sb.dump();
    EXPECT_NE(sb["error"].get<std::string>().find("broken.dae"), std::string::npos) << "with the reason it failed";
    EXPECT_EQ(sc["state"], "failed");
    EXPECT_NE(sc["error"].get<std::string>().find("job " + b), std::string::npos) << sc.dump();
    EXPECT_EQ(sb["started_at"], nullptr) << "never started";
}

TEST_F(Server, ACanceledJobCancelsTheJobsAfterIt) {
    start();
    const std::string a = submit(kLongJob);
    wait_state(a, {"running"});
    const std::string b = submit(after(kSmallJob, {a}));
    const std::string c = submit(after(kSmallJob, {b}));
    // A waiting job can be canceled itself, and the jobs after it follow.
    const std::string d = submit(after(kSmallJob, {a}));
    const std::string e = submit(after(kSmallJob, {d}));
    auto cd = client_->Delete("/v1/jobs/" + d);
    ASSERT_TRUE(cd && cd->status == 200);
    EXPECT_EQ(json::parse(cd->body)["state"], "canceled");
    EXPECT_EQ(wait_state(e, {"canceled", "failed", "succeeded"})["state"], "canceled");
    client_->Delete("/v1/jobs/" + a);
    const json sb = wait_state(b, {"canceled", "failed", "succeeded"}), sc = wait_state(c, {"canceled", "failed", "succeeded"});
    EXPECT_EQ(sb["state"], "canceled");
    EXPECT_NE(sb["error"].get<std::string>().find("job " + a + ", which it runs after, was canceled"), std::string::npos) << sb.dump();
    EXPECT_EQ(sc["state"], "canceled");
}

TEST_F(Server, WaitingJobsWaitAcrossARestart) {
    start();
    const std::string a = submit(kLongJob);
    wait_state(a, {"running"});
    const std::string b = submit(after(kSmallJob, {a}));
    // Nothing to pause yet: a conflict that says so.
    auto p = client_->Post("/v1/jobs/" + b + ":pause", "", "application/json");
    ASSERT_TRUE(p);
    EXPECT_EQ(p->status, 409);
    EXPECT_NE(p->body.find("job-waiting"), std::string::npos) << p->body;
    restart();
    EXPECT_EQ(status(b)["state"], "waiting");
    client_->Delete("/v1/jobs/" + a);
    EXPECT_EQ(wait_state(b, {"canceled", "failed", "succeeded"})["state"], "canceled");
}

// Waiting jobs count against --max-queued: each will be queued, so a client cannot pile up
// jobs behind one that never ends.
TEST_F(Server, WaitingJobsCountAgainstTheQueuesBound) {
    start(3);
    const std::string first = submit(kLongJob);
    wait_state(first, {"running"});
    for (int i = 0; i < 3; ++i) submit(after(kSmallJob, {first}));
    const auto r = post_job(after(kSmallJob, {first}));
    expect_problem(r, 429);
    EXPECT_NE(r->body.find("queue-full"), std::string::npos) << r->body;
    EXPECT_NE(r->body.find("queued or waiting"), std::string::npos) << r->body;
    ASSERT_EQ(client_->Delete("/v1/jobs/" + first)->status, 200);
}

TEST_F(Server, UnknownOrMalformedJobsToRunAfterAreRefused) {
    start();
    const std::string a = submit(kSmallJob);
    expect_problem(post_job(after(kSmallJob, {a, "0123456789abcdef"})), 400, "/after/1");
    expect_problem(post_job(after(kSmallJob, {"not-an-id"})), 400, "/after/0");
    expect_problem(post_job(after(kSmallJob, {a, a})), 400, "/after/1");
    auto list = client_->Get("/v1/jobs?state=waiting");
    ASSERT_TRUE(list && list->status == 200);
    EXPECT_TRUE(json::parse(list->body)["jobs"].empty()) << "nothing refused was stored";
}

}  // namespace
}  // namespace tessera::server
