// A job's log through the HTTP API of a real server: one task a JSON line, what the server logged
// while it ran it, how it ended; a shot's frames each a task; a failure's reason; a paused and
// resumed job's two runs.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tests/server/server_fixture.h"

namespace tessera::server {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

class JobLog : public Server {
protected:
    std::vector<json> log_of(const std::string& id, size_t from = 0) {
        auto r = client_->Get("/v1/jobs/" + id + "/log?from=" + std::to_string(from));
        EXPECT_TRUE(r && r->status == 200) << (r ? r->body : "no answer");
        EXPECT_EQ(r->get_header_value("Content-Type"), "application/x-ndjson");
        std::vector<json> out;
        std::istringstream in(r->body);
        for (std::string line; std::getline(in, line);) out.push_back(json::parse(line));
        return out;
    }
};

TEST_F(JobLog, AStillHasOneTaskAndAShotOneAFrame) {
    start();
    const std::string still = submit(kSmallJob);
    wait_state(still, {"succeeded"});
    const auto a = log_of(still);
    ASSERT_EQ(a.size(), 1u);
    EXPECT_EQ(a[0]["task"], "render");
    EXPECT_EQ(a[0]["outcome"], "done");
    EXPECT_EQ(a[0]["node"], "local");
    EXPECT_EQ(a[0]["attempt"], 1);
    EXPECT_LE(a[0]["start"].get<double>(), a[0]["end"].get<double>());
    ASSERT_FALSE(a[0]["lines"].empty());
    EXPECT_NE(a[0]["lines"][0].get<std::string>().find("running (attempt 1)"), std::string::npos) << a[0].dump();
    EXPECT_TRUE(log_of(still, 1).empty()) << "from skips what was read";

    const json shot = {{"scene", "cornell_shot"}, {"width", 16}, {"height", 12}, {"spp", 1}, {"max_depth", 1},
                       {"frames", {{"start", 0}, {"end", 48}, {"step", 24}}}};
    const std::string id = submit(shot);
    wait_state(id, {"succeeded"});
    const auto b = log_of(id);
    ASSERT_EQ(b.size(), 4u);  // three frames, then the shot
    for (int i = 0; i < 3; ++i) {
        EXPECT_EQ(b[size_t(i)]["task"], "frame");
        EXPECT_EQ(b[size_t(i)]["frame"], 24 * i);
        EXPECT_EQ(b[size_t(i)]["outcome"], "done");
    }
    EXPECT_EQ(b[3]["task"], "shot");
}

TEST_F(JobLog, AFailureSaysWhyAndAPauseIsARunOfItsOwn) {
    start();
    fs::create_directories(dir_ / "uploads" / "0000000000000000");
    std::ofstream(dir_ / "uploads" / "0000000000000000" / "broken.dae") << "<?xml version=\"1.0\"?><COLLADA><asset>";
    json broken = kSmallJob;
    broken["scene"] = "upload/0000000000000000/broken";
    broken["max_retries"] = 1;  // a run each time: two, both failed
    const std::string bad = submit(broken);
    wait_state(bad, {"failed"});
    const auto a = log_of(bad);
    ASSERT_EQ(a.size(), 2u);
    for (size_t run = 0; run < a.size(); ++run) {
        EXPECT_EQ(a[run]["outcome"], "failed");
        EXPECT_EQ(a[run]["attempt"], run + 1);
        ASSERT_FALSE(a[run]["errors"].empty());
        EXPECT_NE(a[run]["errors"][0].get<std::string>().find("broken.dae"), std::string::npos) << a[run].dump();
    }

    const std::string id = submit(kLongJob);
    wait_state(id, {"running"});
    client_->Post("/v1/jobs/" + id + ":pause", "", "application/json");
    wait_state(id, {"paused"});
    client_->Delete("/v1/jobs/" + id);
    wait_state(id, {"canceled"});
    const auto b = log_of(id);
    ASSERT_EQ(b.size(), 1u);
    EXPECT_EQ(b[0]["outcome"], "paused");
    expect_problem(client_->Get("/v1/jobs/0123456789abcdef/log"), 404);
    expect_problem(client_->Get("/v1/jobs/" + id + "/log?from=-1"), 400, "from");
    expect_problem(client_->Get("/v1/jobs/" + id + "/log?limit=0"), 400, "limit");
    expect_problem(client_->Get("/v1/jobs/" + id + "/log?limit=10001"), 400, "limit");
}

// A long log is read in pages: at most `limit` lines an answer, and Next-From where the next
// page starts, so that no answer holds a whole shot's log.
TEST_F(JobLog, ALongLogIsReadInPages) {
    start();
    const json shot = {{"scene", "cornell_shot"}, {"width", 8}, {"height", 6}, {"spp", 1}, {"max_depth", 1},
                       {"frames", {{"start", 0}, {"end", 11}}}};
    const std::string id = submit(shot);
    wait_state(id, {"succeeded"});
    const auto all = log_of(id);
    ASSERT_EQ(all.size(), 13u);  // twelve frames, then the shot
    std::vector<json> paged;
    size_t from = 0;
    for (int page = 0; page < 10; ++page) {
        auto r = client_->Get("/v1/jobs/" + id + "/log?limit=5&from=" + std::to_string(from));
        ASSERT_TRUE(r && r->status == 200);
        std::istringstream in(r->body);
        size_t lines = 0;
        for (std::string line; std::getline(in, line); ++lines) paged.push_back(json::parse(line));
        EXPECT_LE(lines, 5u);
        ASSERT_TRUE(r->has_header("Next-From"));
        const size_t next = std::stoul(r->get_header_value("Next-From"));
        EXPECT_EQ(next, from + lines);
        if (lines == 0) break;
        from = next;
    }
    EXPECT_EQ(from, 13u);
    EXPECT_EQ(paged, all) << "the pages are the log, in order, each line once";
    auto past = client_->Get("/v1/jobs/" + id + "/log?from=40");
    ASSERT_TRUE(past && past->status == 200);
    EXPECT_TRUE(past->body.empty());
    EXPECT_EQ(past->get_header_value("Next-From"), "13") << "a reader ahead of the log is told where it ends";
}

}  // namespace
}  // namespace tessera::server
