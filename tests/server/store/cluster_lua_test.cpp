// The farm's Lua scripts on a real redis-server: each compiles (SCRIPT LOAD), so a typo fails
// here and not as a render node retrying a task forever; and the failure scripts' rules, driven
// directly: a failed task is queued again naming its node until max_retries, a node is
// blocklisted at blocklist_after, and a job fails with every reason when no retry or no node
// is left.
#include "server/store/cluster_lua.h"

#include <gtest/gtest.h>

#include <map>

#include "server/farm/farm_records.h"
#include "server/store/cluster_keys.h"
#include "tests/server/redis_suite.h"

namespace tessera::server {
namespace {

class ClusterLua : public test::WithSuiteRedis<> {
protected:
    void SetUp() override { redis_ready("the farm's scripts are not tested"); }
};

TEST_F(ClusterLua, EveryScriptCompiles) {
    if (!redis_) return;
    Redis r(redis_->url());
    const std::pair<const char*, std::string> scripts[] = {
        {"transition", lua::transition},       {"add_chunks", lua::add_chunks},     {"chunk_done", lua::chunk_done},
        {"add_tiles", lua::add_tiles},         {"commit_tile", commit_tile_script()}, {"begin_run", lua::begin_run},
        {"advance_pass", lua::advance_pass},   {"complete_run", lua::complete_run}, {"transition_job", lua::transition_job},
        {"pause_job", lua::pause_job},         {"resume_job", lua::resume_job},     {"release_job", lua::release_job},
        {"fail_task", lua::fail_task},         {"pass_on", lua::pass_on},           {"strand_job", lua::strand_job},
        {"renew_claim", lua::renew_claim},     {"append_log", lua::append_log},     {"read_log", lua::read_log}};
    for (const auto& [name, source] : scripts) {
        SCOPED_TRACE(name);
        EXPECT_NO_THROW(r.command({"SCRIPT", "LOAD", source}));
    }
}

// fail_task's arguments for one failure of `node` on tile 0 of pass 0.
std::vector<std::string> failure(const std::string& id, const std::string& entry, const std::string& node, int max_retries,
                                 int blocklist_after, const std::vector<std::string>& live) {
    std::vector<std::string> a = {keys::prefix, id, entry, "tile:0:0", node, node + ": tile 0 of pass 0: it broke",
                                  std::to_string(max_retries), std::to_string(blocklist_after), "1700000000", "tile", "0", "0", "",
                                  "tile 0 of pass 0", "0", "c/0"};
    a.insert(a.end(), live.begin(), live.end());
    return a;
}

TEST_F(ClusterLua, AFailedTaskIsQueuedAgainUntilItsRetriesOrItsNodesRunOut) {
    if (!redis_) return;
    Redis r(redis_->url());
    const RedisScript fail{lua::fail_task};
    const std::string id = "00000000000000f1", stream = keys::tasks(0);
    auto keys_of = [&] {
        return std::vector<std::string>{keys::job(id), keys::failures(id), keys::failure_reasons(id), keys::blocklist(id), stream,
                                        keys::node_failed_tasks};
    };
    r.command({"HSET", keys::job(id), "state", "running", "seq", "1", "priority", "0"});
    r.command({"XGROUP", "CREATE", stream, keys::group, "0", "MKSTREAM"});
    // A delivery held by consumer c/0, as a node's thread holds it.
    auto entry = [&] {
        const std::string e = r.command({"XADD", stream, "*", "job", id, "kind", "tile", "pass", "0", "tile", "0"}).text;
        r.command({"XREADGROUP", "GROUP", keys::group, "c/0", "COUNT", "100", "STREAMS", stream, ">"});
        return e;
    };
    // One not held by this consumer (taken over, or settled already) is left alone.
    {
        const std::string other = r.command({"XADD", stream, "*", "job", id, "kind", "tile", "pass", "0", "tile", "0"}).text;
        r.command({"XREADGROUP", "GROUP", keys::group, "someone-else/0", "COUNT", "100", "STREAMS", stream, ">"});
        EXPECT_EQ(r.eval(fail, keys_of(), failure(id, other, "a", 2, 2, {"a", "b"})).items[0].as_int(), 0);
        EXPECT_TRUE(r.command({"HGET", keys::failures(id), "total"}).is_nil()) << "nothing counted";
        r.command({"XACK", stream, keys::group, other});
        r.command({"XDEL", stream, other});
    }
    // Two nodes live, max_retries 2, blocklist_after 2.
    RedisValue v = r.eval(fail, keys_of(), failure(id, entry(), "a", 2, 2, {"a", "b"}));
    EXPECT_EQ(v.items[0].as_int(), 1) << "queued again";
    EXPECT_EQ(v.items[1].as_int(), 0) << "a not yet blocklisted";
    // The failed delivery is gone, and a copy naming `a` is queued in its place.
    const RedisValue all = r.command({"XRANGE", stream, "-", "+"});
    ASSERT_EQ(all.items.size(), 1u);
    const auto& fields = all.items[0].items[1].items;
    std::map<std::string, std::string> f;
    for (size_t i = 0; i + 1 < fields.size(); i += 2) f[fields[i].text] = fields[i + 1].text;
    EXPECT_EQ(f["avoid"], "a");
    EXPECT_EQ(f["attempt"], "2");
    v = r.eval(fail, keys_of(), failure(id, entry(), "a", 2, 2, {"a", "b"}));
    EXPECT_EQ(v.items[0].as_int(), 1) << "b can still take it";
    EXPECT_EQ(v.items[1].as_int(), 1) << "a blocklisted at its second failure";
    EXPECT_EQ(r.command({"SISMEMBER", keys::blocklist(id), "a"}).as_int(), 1);
    EXPECT_TRUE(r.command({"HGET", keys::node_blocklisted_jobs, "a"}).is_nil()) << "counted across jobs only when another node finishes the job";
    v = r.eval(fail, keys_of(), failure(id, entry(), "b", 2, 2, {"a", "b"}));
    EXPECT_EQ(v.items[0].as_int(), 2) << "a third failure is past max_retries 2";
    EXPECT_EQ(r.command({"HGET", keys::job(id), "state"}).text, "failed");
    const std::string error = r.command({"HGET", keys::job(id), "error"}).text;
    EXPECT_NE(error.find("tile 0 of pass 0 failed 3 times, more than the job's max_retries (2)"), std::string::npos) << error;
    EXPECT_NE(error.find("a: tile 0 of pass 0: it broke; a: tile 0 of pass 0: it broke; b: "), std::string::npos) << "every reason: " << error;
    EXPECT_EQ(r.eval(fail, keys_of(), failure(id, entry(), "b", 2, 2, {"a", "b"})).items[0].as_int(), 0) << "a failed job counts nothing more";

    // One node live, blocklisted at its first failure: no node left.
    const std::string id2 = "00000000000000f2";
    r.command({"HSET", keys::job(id2), "state", "running", "seq", "2", "priority", "0"});
    const std::string e2 = r.command({"XADD", stream, "*", "job", id2, "kind", "tile", "pass", "0", "tile", "0"}).text;
    r.command({"XREADGROUP", "GROUP", keys::group, "c/0", "COUNT", "100", "STREAMS", stream, ">"});
    v = r.eval(fail, {keys::job(id2), keys::failures(id2), keys::failure_reasons(id2), keys::blocklist(id2), stream, keys::node_failed_tasks},
               failure(id2, e2, "a", 3, 1, {"a"}));
    EXPECT_EQ(v.items[0].as_int(), 2);
    const std::string error2 = r.command({"HGET", keys::job(id2), "error"}).text;
    EXPECT_NE(error2.find("no live render node can take its tasks: a failed 1 of them each"), std::string::npos) << error2;
    EXPECT_EQ(r.command({"HGET", keys::node_failed_tasks, "a"}).as_int(), 3) << "a's failures, every job's";
    EXPECT_TRUE(r.command({"HGET", keys::node_blocklisted_jobs, "a"}).is_nil()) << "no job it was blocklisted for succeeded";

    // A job that another node finished counts its blocklisted nodes against them, across jobs.
    const std::string id3 = "00000000000000f3";
    r.command({"HSET", keys::job(id3), "state", "running", "seq", "3", "priority", "0"});
    r.command({"SADD", keys::blocklist(id3), "a", "c"});
    const RedisScript transition{lua::transition_job};
    ASSERT_EQ(r.eval(transition, {}, {keys::prefix, id3, "succeeded", "running", "1700000001", "", ""}).as_int(), 1);
    EXPECT_EQ(r.command({"HGET", keys::node_blocklisted_jobs, "a"}).as_int(), 1);
    EXPECT_EQ(r.command({"HGET", keys::node_blocklisted_jobs, "c"}).as_int(), 1);
}

// A reader's `from` names the same line after the oldest lines are dropped.
TEST_F(ClusterLua, ALogLinesIndexStaysItsOwnWhenTheOldestAreDropped) {
    if (!redis_) return;
    Redis r(redis_->url());
    const RedisScript append{lua::append_log}, read{lua::read_log};
    const std::string id = "00000000000000a1";
    const std::vector<std::string> ks = {keys::task_log(id), keys::task_log_count(id), keys::job(id)};
    r.command({"HSET", keys::job(id), "state", "running"});
    for (int i = 0; i < 10; ++i) r.eval(append, ks, {"line " + std::to_string(i), "4"});  // keeps the newest 4
    // The first line's number, then the lines.
    auto from = [&](int n, int limit = 100, int bytes = 1 << 20) {
        std::vector<std::string> out;
        const auto items = r.eval(read, ks, {std::to_string(n), std::to_string(limit), std::to_string(bytes)}).items;
        if (!items.empty()) out.push_back(std::to_string(items[0].as_int()));
        for (size_t i = 1; i < items.size(); ++i) out.push_back(items[i].text);
        return out;
    };
    EXPECT_EQ(from(8), (std::vector<std::string>{"8", "line 8", "line 9"}));
    EXPECT_EQ(from(0), (std::vector<std::string>{"6", "line 6", "line 7", "line 8", "line 9"})) << "the dropped ones skipped";
    EXPECT_EQ(from(10), (std::vector<std::string>{"10"}));
    EXPECT_EQ(from(99), (std::vector<std::string>{"10"})) << "past the end: where the log ends";
    EXPECT_EQ(from(6, 2), (std::vector<std::string>{"6", "line 6", "line 7"})) << "at most limit lines";
    EXPECT_EQ(from(6, 100, 10), (std::vector<std::string>{"6", "line 6"})) << "about the bytes asked (line and newline: 7)";
    EXPECT_EQ(from(6, 100, 1), (std::vector<std::string>{"6", "line 6"})) << "one line at least";

    // Past one batch of the script's reads (100 lines): every line once, in order, to the limit.
    const std::string id2 = "00000000000000a2";
    const std::vector<std::string> ks2 = {keys::task_log(id2), keys::task_log_count(id2), keys::job(id2)};
    r.command({"HSET", keys::job(id2), "state", "running"});
    for (int i = 0; i < 250; ++i) r.eval(append, ks2, {"l" + std::to_string(i), "1000"});
    auto read2 = [&](int n, int limit) { return r.eval(read, ks2, {std::to_string(n), std::to_string(limit), "1000000"}).items; };
    const auto got = read2(5, 230);
    ASSERT_EQ(got.size(), 231u);
    EXPECT_EQ(got[0].as_int(), 5);
    for (size_t i = 1; i < got.size(); ++i) ASSERT_EQ(got[i].text, "l" + std::to_string(4 + i));
    EXPECT_EQ(read2(200, 1000).size(), 51u) << "the last 50, then the end";
    EXPECT_EQ(read2(0, 100).size(), 101u) << "exactly one batch";
}

}  // namespace
}  // namespace tessera::server
