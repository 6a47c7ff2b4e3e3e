// The farm's records through the real scripts on a real redis-server: a run started from
// farm_run_start, tiles committed by commit_tile_script() from TileCommit::arguments, read back by
// decode_farm_run. Every counter arrives under its own name (a swapped or dropped field shows),
// a duplicate commit adds nothing, the pass's last tile queues its assembly.
#include "server/farm/farm_records.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "server/store/cluster_keys.h"
#include "server/store/cluster_lua.h"
#include "tests/server/redis_suite.h"

namespace tessera::server {
namespace {

class FarmRecords : public test::WithSuiteRedis<> {
protected:
    void SetUp() override { redis_ready("the farm's records are not tested"); }
};

FarmRun read_run(Redis& r, const std::string& id) {
    std::vector<std::string> cmd = {"HMGET", keys::job(id)};
    cmd.insert(cmd.end(), farm_run_fields().begin(), farm_run_fields().end());
    return decode_farm_run(r.command(cmd));
}

TEST_F(FarmRecords, TileCommitsAddEveryCounterUnderItsName) {
    Redis r(redis_->url());
    const std::string id = "0123456789abcdef", stream = keys::tasks(0);
    std::vector<std::string> start = {"HSET", keys::job(id), "state", "running"};
    for (const std::string& a : farm_run_start(4, 2, 123456)) start.push_back(a);
    r.command(start);
    r.command({"XGROUP", "CREATE", stream, keys::group, "0", "MKSTREAM"});
    const FarmRun fresh = read_run(r, id);
    EXPECT_EQ(fresh.state, "running");
    EXPECT_EQ(fresh.pass, 0);
    EXPECT_EQ(fresh.target, 4);
    EXPECT_EQ(fresh.tiles_total, 2);
    EXPECT_EQ(fresh.tiles_done, 0);
    EXPECT_EQ(fresh.started_ms, 123456);
    for_each_counter([](const char* name, uint64_t c) { EXPECT_EQ(c, 0u) << name; }, fresh.stats);

    const RedisScript commit{commit_tile_script()};
    auto commit_tile = [&](size_t tile, uint64_t base, float max_sample, bool timed_out) {
        const std::string task = r.command({"XADD", stream, "*", "job", id, "kind", "tile", "pass", "0", "tile", std::to_string(tile)}).text;
        TileCommit c;
        c.job = id;
        c.task_id = task;
        c.node = "node-a";
        c.tile = tile;
        c.payload = "film bytes";
        c.seconds = 0.25;
        c.timed_out = timed_out;
        uint64_t v = base;
        for_each_counter([&](const char*, uint64_t& x) { x = v++; }, c.stats);  // a distinct value per counter
        c.stats.max_sample = max_sample;
        c.sums = whole_tile_sums_text({{4, 0.5, {}}});
        return r.eval(commit, {keys::job(id), keys::film(id), keys::node_tiles(id), keys::node_seconds(id), stream, keys::sums(id)},
                      c.arguments()).as_int();
    };
    EXPECT_EQ(commit_tile(0, 10, 2.5f, false), 1);
    EXPECT_EQ(commit_tile(0, 1000, 9.0f, true), 0) << "the same tile of the same pass again: a duplicate";
    FarmRun one = read_run(r, id);
    uint64_t expect = 10;
    for_each_counter([&](const char* name, uint64_t c) { EXPECT_EQ(c, expect++) << name; }, one.stats);
    EXPECT_EQ(one.stats.max_sample, 2.5f);
    EXPECT_FALSE(one.timed_out);
    EXPECT_EQ(one.tiles_done, 1);
    EXPECT_EQ(r.command({"XLEN", stream}).as_int(), 0) << "committed tasks are acknowledged and deleted";

    EXPECT_EQ(commit_tile(1, 100, 1.0f, true), 1);
    const FarmRun two = read_run(r, id);
    expect = 0;
    for_each_counter([&](const char* name, uint64_t c) { EXPECT_EQ(c, (10 + expect) + (100 + expect)) << name; ++expect; }, two.stats);
    EXPECT_EQ(two.stats.max_sample, 2.5f) << "the largest sample, not the last";
    EXPECT_TRUE(two.timed_out);
    EXPECT_EQ(two.tiles_done, 2);
    const RedisValue queued = r.command({"XRANGE", stream, "-", "+"});
    ASSERT_EQ(queued.items.size(), 1u) << "the pass's last tile queues its assembly";
    const auto& f = queued.items[0].items[1].items;
    EXPECT_EQ(f[3].text, "assemble");
    EXPECT_EQ(r.command({"HGET", keys::node_tiles(id), "node-a"}).as_int(), 2);
    EXPECT_EQ(whole_tile_sums_from_text(r.command({"HGET", keys::sums(id), "t1"}).text).at(0).target, 4);
}

TEST(FarmRecordsText, WholeTileSumsRoundTripAndRefuseAMissingField) {
    ErrorSums e;
    e.spp = 3;
    e.est = 0.125;
    e.pixels = 7;
    e.half_buffer = true;
    const auto back = whole_tile_sums_from_text(whole_tile_sums_text({{1, 0.5, e}, {2, 1.5, e}}));
    ASSERT_EQ(back.size(), 2u);
    EXPECT_EQ(back[1].target, 2);
    EXPECT_EQ(back[1].seconds, 1.5);
    EXPECT_EQ(back[1].sums.est, 0.125);
    EXPECT_EQ(back[1].sums.pixels, 7u);
    EXPECT_TRUE(back[1].sums.half_buffer);
    nlohmann::json j = nlohmann::json::parse(whole_tile_sums_text({{1, 0.5, e}}));
    j[0]["sums"].erase("est");
    EXPECT_THROW(whole_tile_sums_from_text(j.dump()), nlohmann::json::exception) << "a node of another version fails, not silently";
}

}  // namespace
}  // namespace tessera::server
