// What the Redis job store (server/store/redis_job_store.h) keeps beyond the JobStore contract
// (job_store_contract_test.cpp runs that against it): a queued job's place in run order and its
// first task on its priority's stream, the newest ids per state, a render's live progress as the
// farm writes it, the scene and environment bytes published once per content and the job's
// reference to them, the render nodes' heartbeats, removal taking the job's farm keys with it,
// its byte bound, and Redis being full or away reported as full or unavailable.
// Against a real redis-server started for the suite.
#include "server/store/redis_job_store.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "server/store/cluster_keys.h"
#include "server/store/scene_ref.h"
#include "tests/server/job_records.h"
#include "tests/server/raw_socket.h"
#include "tests/server/redis_suite.h"

namespace tessera::server {
namespace {

using namespace std::string_literals;
using test::hex_id;
using test::make_job;

class RedisJobStoreFarmSide : public test::WithSuiteRedis<> {
protected:
    void SetUp() override {
        if (!redis_ready("the Redis job store's farm side is not tested")) return;
        store_ = std::make_unique<RedisJobStore>(redis_->url());
    }
    // Whatever a test left behind, the next one gets a running server without a memory limit.
    void TearDown() override {
        store_.reset();
        if (!redis_) return;
        if (stopped_) redis_->start();
        stopped_ = false;
        if (memory_limited_) unlimit_memory();
    }

    // A command of the test's own, beside the store (what a render node or an operator does).
    RedisValue cmd(const std::vector<std::string>& args) const { return Redis(redis_->url()).command(args); }
    bool exists(const std::string& key) const { return cmd({"EXISTS", key}).as_int() == 1; }

    // A task stream's entries, each as its fields.
    std::vector<std::map<std::string, std::string>> tasks_in(const std::string& stream) const {
        std::vector<std::map<std::string, std::string>> out;
        for (const RedisValue& entry : cmd({"XRANGE", stream, "-", "+"}).items) {
            std::map<std::string, std::string> fields;
            const auto& kv = entry.items.at(1).items;
            for (size_t i = 0; i + 1 < kv.size(); i += 2) fields[kv[i].text] = kv[i + 1].text;
            out.push_back(std::move(fields));
        }
        return out;
    }

    std::vector<std::string> queued_ids() const {
        std::vector<std::string> ids;
        for (const JobRecord& r : store_->queued_in_order()) ids.push_back(r.id);
        return ids;
    }

    void stop_server() {
        stopped_ = true;
        redis_->stop();
    }
    bool start_server() {
        stopped_ = false;
        return redis_->start();
    }

    // Redis refuses every write from here on (noeviction, and it always holds more than a byte).
    void limit_memory() {
        saved_maxmemory_ = cmd({"CONFIG", "GET", "maxmemory"}).items.at(1).text;
        saved_policy_ = cmd({"CONFIG", "GET", "maxmemory-policy"}).items.at(1).text;
        memory_limited_ = true;
        cmd({"CONFIG", "SET", "maxmemory-policy", "noeviction"});
        cmd({"CONFIG", "SET", "maxmemory", "1"});
    }
    void unlimit_memory() {
        cmd({"CONFIG", "SET", "maxmemory", saved_maxmemory_});
        cmd({"CONFIG", "SET", "maxmemory-policy", saved_policy_});
        memory_limited_ = false;
    }

    std::unique_ptr<RedisJobStore> store_;
    bool stopped_ = false;
    bool memory_limited_ = false;
    std::string saved_maxmemory_, saved_policy_;
};

// Runs `fn`, which must fail as the store being unusable for now (503), not full (507).
template <class Fn>
void expect_unavailable(const char* what, Fn&& fn) {
    try {
        fn();
        ADD_FAILURE() << what << " answered while Redis was away";
    } catch (const StoreError& e) {
        EXPECT_FALSE(e.full) << what << ": " << e.what();
    }
}

TEST_F(RedisJobStoreFarmSide, QueuePositionIsThePlaceInRunOrder) {
    const int priorities[] = {0, 5, 0, 10, 5};
    for (uint64_t i = 0; i < 5; ++i) {
        JobRecord r = make_job(i + 1, priorities[i]);
        store_->insert(r);
    }
    // Run order: priority descending, then submission order.
    EXPECT_EQ(store_->queue_position(hex_id(4)), 0);
    EXPECT_EQ(store_->queue_position(hex_id(2)), 1);
    EXPECT_EQ(store_->queue_position(hex_id(5)), 2);
    EXPECT_EQ(store_->queue_position(hex_id(1)), 3);
    EXPECT_EQ(store_->queue_position(hex_id(3)), 4);
    EXPECT_EQ(store_->queue_position("ffffffffffffffff"), -1) << "no such job";

    ASSERT_TRUE(store_->mark_running(hex_id(4), 1.0));
    EXPECT_EQ(store_->queue_position(hex_id(4)), -1) << "a running job has no place in the queue";
    EXPECT_EQ(store_->queue_position(hex_id(2)), 0) << "the others moved up";
    ASSERT_TRUE(store_->finish(hex_id(5), JobState::canceled, 2.0, "", ""));
    EXPECT_EQ(store_->queue_position(hex_id(5)), -1);
    EXPECT_EQ(store_->queue_position(hex_id(1)), 1);
    ASSERT_TRUE(store_->requeue(hex_id(4)));
    EXPECT_EQ(store_->queue_position(hex_id(4)), 0) << "requeued, its priority puts it first again";

    JobRecord done = make_job(6, 100);
    done.state = JobState::succeeded;
    store_->insert(done);
    EXPECT_EQ(store_->queue_position(done.id), -1) << "a job recorded as finished never joins the queue";

    const std::vector<std::string> order = queued_ids();
    ASSERT_EQ(order.size(), 4u);
    for (size_t i = 0; i < order.size(); ++i) EXPECT_EQ(store_->queue_position(order[i]), static_cast<long long>(i)) << order[i];
}

TEST_F(RedisJobStoreFarmSide, IdsAreTheNewestInAState) {
    for (uint64_t i = 1; i <= 5; ++i) {
        JobRecord r = make_job(i);
        store_->insert(r);
    }
    ASSERT_TRUE(store_->finish(hex_id(2), JobState::succeeded, 1.0, "", "{}"));
    ASSERT_TRUE(store_->finish(hex_id(4), JobState::succeeded, 1.0, "", "{}"));
    ASSERT_TRUE(store_->mark_running(hex_id(3), 1.0));

    using Ids = std::vector<std::string>;
    EXPECT_EQ(store_->ids(std::nullopt, 3), (Ids{hex_id(5), hex_id(4), hex_id(3)}));
    EXPECT_EQ(store_->ids(std::nullopt, 100), (Ids{hex_id(5), hex_id(4), hex_id(3), hex_id(2), hex_id(1)}));
    EXPECT_EQ(store_->ids(JobState::succeeded, 10), (Ids{hex_id(4), hex_id(2)}));
    EXPECT_EQ(store_->ids(JobState::queued, 10), (Ids{hex_id(5), hex_id(1)}));
    EXPECT_EQ(store_->ids(JobState::running, 1), (Ids{hex_id(3)}));
    EXPECT_TRUE(store_->ids(JobState::failed, 10).empty());
    EXPECT_TRUE(store_->ids(std::nullopt, 0).empty());

    // The same jobs, in the same order, as list() gives with their records.
    Ids listed;
    for (const JobRecord& r : store_->list(JobState::succeeded, 0, 10)) listed.push_back(r.id);
    EXPECT_EQ(store_->ids(JobState::succeeded, 10), listed);

    ASSERT_TRUE(store_->remove_final(hex_id(2)));
    EXPECT_EQ(store_->ids(JobState::succeeded, 10), (Ids{hex_id(4)}));
    EXPECT_EQ(store_->ids(std::nullopt, 10).size(), 4u);
}

TEST_F(RedisJobStoreFarmSide, LiveProgressIsWhatTheRenderWrote) {
    EXPECT_FALSE(store_->live_progress("ffffffffffffffff").has_value()) << "no such job";
    JobRecord r = make_job(1);
    store_->insert(r);
    EXPECT_FALSE(store_->live_progress(r.id).has_value()) << "queued: no render has started";
    ASSERT_TRUE(store_->mark_running(r.id, 1.0));
    EXPECT_FALSE(store_->live_progress(r.id).has_value()) << "running, but no node has written its fields yet";

    // What a render node's scripts write on the job's hash (farm_run_start, commit_tile).
    cmd({"HSET", keys::job(r.id), "tiles_done", "3", "tiles_total", "12", "samples", "5000000000", "pass", "2"});
    const auto p = store_->live_progress(r.id);
    ASSERT_TRUE(p.has_value());
    EXPECT_EQ(p->tiles_done, 3u);
    EXPECT_EQ(p->tiles_total, 12u);
    EXPECT_EQ(p->samples, 5000000000ULL) << "past 32 bits";
    EXPECT_EQ(p->pass, 2);

    cmd({"HINCRBY", keys::job(r.id), "tiles_done", "1"});
    EXPECT_EQ(store_->live_progress(r.id)->tiles_done, 4u) << "read afresh, not remembered";
}

TEST_F(RedisJobStoreFarmSide, PutScenePublishesTheBytesOncePerContent) {
    const std::string bytes = "glTF\0\x01\x02 scene bytes\r\n"s;
    const SceneRef ref{"/scenes/box.gltf", content_hash(bytes), ".gltf", "box.gltf"};
    store_->put_scene(hex_id(1), ref, &bytes);

    EXPECT_EQ(cmd({"GET", keys::scene(ref.hash)}).text, bytes) << "a render node loads exactly these bytes";
    const SceneRef back = SceneRef::decode(cmd({"GET", keys::job_scene(hex_id(1))}).text);
    EXPECT_EQ(back.source, ref.source);
    EXPECT_EQ(back.hash, ref.hash);
    EXPECT_EQ(back.ext, ref.ext);

    // A second job on the same file shares the one copy.
    store_->put_scene(hex_id(2), ref, &bytes);
    EXPECT_EQ(cmd({"KEYS", keys::scene("*")}).items.size(), 1u);
    EXPECT_EQ(SceneRef::decode(cmd({"GET", keys::job_scene(hex_id(2))}).text).hash, ref.hash);

    // Bytes once published under a hash never change: a node may be loading them.
    const std::string other = "other bytes";
    store_->put_scene(hex_id(3), ref, &other);
    EXPECT_EQ(cmd({"GET", keys::scene(ref.hash)}).text, bytes);

    // A built-in scene has no bytes: only the job's reference is written.
    const SceneRef builtin{"builtin:cornell_box", "", "", "builtin:cornell_box"};
    store_->put_scene(hex_id(4), builtin, nullptr);
    const SceneRef b = SceneRef::decode(cmd({"GET", keys::job_scene(hex_id(4))}).text);
    EXPECT_EQ(b.source, "builtin:cornell_box");
    EXPECT_EQ(b.hash, "");
    EXPECT_FALSE(exists(keys::scene("")));
    EXPECT_EQ(cmd({"KEYS", keys::scene("*")}).items.size(), 1u);
}

TEST_F(RedisJobStoreFarmSide, PutEnvironmentPublishesTheMapBesideTheScene) {
    const std::string map = "#?RADIANCE\n\0\xff map bytes"s;
    const SceneRef ref{"/scenes/sky.hdr", content_hash(map), ".hdr", "sky.hdr"};
    store_->put_environment(hex_id(1), ref, map);

    EXPECT_EQ(cmd({"GET", keys::scene(ref.hash)}).text, map);
    const SceneRef back = SceneRef::decode(cmd({"GET", keys::job_environment(hex_id(1))}).text);
    EXPECT_EQ(back.source, ref.source);
    EXPECT_EQ(back.hash, ref.hash);
    EXPECT_EQ(back.ext, ".hdr");
    EXPECT_FALSE(exists(keys::job_scene(hex_id(1)))) << "the environment is not the job's scene";

    store_->put_environment(hex_id(2), ref, map);
    EXPECT_EQ(cmd({"KEYS", keys::scene("*")}).items.size(), 1u) << "one copy per content";
    EXPECT_EQ(SceneRef::decode(cmd({"GET", keys::job_environment(hex_id(2))}).text).hash, ref.hash);
}

TEST_F(RedisJobStoreFarmSide, NodesAreTheHeartbeatsRenderNodesWrote) {
    EXPECT_TRUE(store_->nodes().empty());
    const std::string a = R"({"tiles":3,"last_seen":1700000000.5})", b = R"({"tiles":0})";
    cmd({"HSET", keys::nodes, "node-a", a, "node-b", b});
    auto nodes = store_->nodes();
    std::sort(nodes.begin(), nodes.end());
    EXPECT_EQ(nodes, (std::vector<std::pair<std::string, std::string>>{{"node-a", a}, {"node-b", b}}));

    cmd({"HDEL", keys::nodes, "node-a"});
    nodes = store_->nodes();
    ASSERT_EQ(nodes.size(), 1u);
    EXPECT_EQ(nodes[0].first, "node-b");
}

TEST_F(RedisJobStoreFarmSide, AQueuedJobIsScheduledOnceOnItsPrioritysStream) {
    JobRecord r = make_job(1, 3);
    store_->insert(r);
    const auto tasks = tasks_in(keys::tasks(3));
    ASSERT_EQ(tasks.size(), 1u) << "inserting a queued job schedules it";
    EXPECT_EQ(tasks[0].at("job"), r.id);
    EXPECT_EQ(tasks[0].at("kind"), "start");
    EXPECT_EQ(tasks[0].at("pass"), "0");
    EXPECT_EQ(tasks[0].at("tile"), "0");
    EXPECT_EQ(cmd({"ZSCORE", keys::priorities, "3"}).as_int(), 3) << "the nodes find the stream through the priorities set";

    // The render nodes read through their group, which must exist before they ask.
    bool has_group = false;
    for (const RedisValue& group : cmd({"XINFO", "GROUPS", keys::tasks(3)}).items)
        for (size_t i = 0; i + 1 < group.items.size(); i += 2)
            if (group.items[i].text == "name" && group.items[i + 1].text == keys::group) has_group = true;
    EXPECT_TRUE(has_group);

    // A refused duplicate schedules nothing.
    JobRecord dup = make_job(1, 3);
    EXPECT_THROW(store_->insert(dup), StoreError);
    EXPECT_EQ(tasks_in(keys::tasks(3)).size(), 1u);

    JobRecord other = make_job(2, 3);
    store_->insert(other);
    ASSERT_EQ(tasks_in(keys::tasks(3)).size(), 2u) << "a second job on the same stream and group";
    EXPECT_EQ(tasks_in(keys::tasks(3))[1].at("job"), other.id);

    // A job recorded in another state is not scheduled.
    JobRecord done = make_job(3, 4);
    done.state = JobState::succeeded;
    store_->insert(done);
    EXPECT_FALSE(exists(keys::tasks(4)));
    EXPECT_TRUE(cmd({"ZSCORE", keys::priorities, "4"}).is_nil());
}

// A job that requires node tags is queued in its lane (its priority and its tags); a lane no
// unfinished job uses and whose stream is empty is removed; and only so many lanes of tags are
// open at once, so that a client cannot grow what every node reads with a new set per job.
TEST_F(RedisJobStoreFarmSide, TaggedJobsHaveLanesThatGoWhenUnusedAndAreBounded) {
    auto tagged = [](uint64_t n, const std::string& tag) {
        JobRecord r = make_job(n, 2);
        r.spec_json = R"({"scene":"builtin:cornell_box","requires":[")" + tag + R"(","avx512"]})";
        return r;
    };
    JobRecord a = tagged(1, "bigmem");
    store_->insert(a);
    const std::string lane = "2|avx512,bigmem";
    EXPECT_EQ(cmd({"ZSCORE", keys::priorities, lane}).as_int(), 2);
    ASSERT_EQ(tasks_in(keys::lane_tasks(lane)).size(), 1u);
    EXPECT_EQ(store_->lane(a.id), lane);
    EXPECT_EQ(store_->prune_lanes(), 0) << "in use";
    ASSERT_TRUE(store_->finish(a.id, JobState::canceled, 1, "", ""));
    EXPECT_EQ(store_->prune_lanes(), 0) << "its start task is still in the stream";
    cmd({"XTRIM", keys::lane_tasks(lane), "MAXLEN", "0"});
    EXPECT_EQ(store_->prune_lanes(), 1);
    EXPECT_TRUE(cmd({"ZSCORE", keys::priorities, lane}).is_nil());
    EXPECT_FALSE(exists(keys::lane_tasks(lane)));
    // A job of that lane again makes it again, stream and group included.
    JobRecord b = tagged(2, "bigmem");
    store_->insert(b);
    EXPECT_EQ(tasks_in(keys::lane_tasks(lane)).size(), 1u);
    // The bound: lanes up to keys::max_tag_lanes, then a new set of tags is refused as full.
    for (long long i = 1; i < keys::max_tag_lanes; ++i) {  // the lane above is one
        JobRecord r = tagged(uint64_t(100 + i), "t" + std::to_string(i));
        store_->insert(r);
    }
    JobRecord one_more = tagged(99999, "one-more");
    try {
        store_->insert(one_more);
        ADD_FAILURE() << "a lane past the bound was opened";
    } catch (const StoreError& e) {
        EXPECT_TRUE(e.full);
    }
    JobRecord same = tagged(100000, "bigmem");
    EXPECT_NO_THROW(store_->insert(same)) << "a lane that exists takes more jobs";
    JobRecord plain = make_job(100001, 7);
    EXPECT_NO_THROW(store_->insert(plain)) << "a job without tags is never refused for it";
}

TEST_F(RedisJobStoreFarmSide, RemovingAFinishedJobTakesItsFarmKeysButNotSharedSceneBytes) {
    const std::string bytes = "scene bytes", map = "map bytes";
    const SceneRef scene{"/scenes/a.gltf", content_hash(bytes), ".gltf", "a.gltf"};
    const SceneRef env{"/scenes/sky.exr", content_hash(map), ".exr", "sky.exr"};
    JobRecord gone = make_job(1), kept = make_job(2);
    for (JobRecord* r : {&gone, &kept}) {
        store_->put_scene(r->id, scene, &bytes);
        store_->put_environment(r->id, env, map);
        store_->insert(*r);
    }
    const std::string id = gone.id;
    ASSERT_TRUE(store_->mark_running(id, 1.0));
    // What a render leaves behind for the job.
    cmd({"HSET", keys::film(id), "t0", "film", "p0", "0"});
    cmd({"HSET", keys::deliveries(id), "0:0", "1"});
    cmd({"HSET", keys::sums(id), "t0", "sums"});
    cmd({"HSET", keys::node_tiles(id), "node-a", "1"});
    cmd({"HSET", keys::node_seconds(id), "node-a", "0.5"});
    cmd({"RPUSH", keys::curve(id), R"({"pass":0})"});

    ASSERT_TRUE(store_->finish(id, JobState::succeeded, 2.0, "", "{}"));
    // A final state drops what only a running render needs.
    EXPECT_FALSE(exists(keys::film(id)));
    EXPECT_FALSE(exists(keys::deliveries(id)));

    ASSERT_TRUE(store_->remove_final(id));
    for (const std::string& key : {keys::job(id), keys::film(id), keys::deliveries(id), keys::node_tiles(id), keys::node_seconds(id),
                                   keys::curve(id), keys::job_scene(id), keys::job_environment(id), keys::sums(id)})
        EXPECT_FALSE(exists(key)) << key << " outlived its job";

    // The other job still names the same bytes.
    EXPECT_EQ(cmd({"GET", keys::scene(scene.hash)}).text, bytes);
    EXPECT_EQ(cmd({"GET", keys::scene(env.hash)}).text, map);
    EXPECT_TRUE(exists(keys::job_scene(kept.id)));
    EXPECT_TRUE(exists(keys::job_environment(kept.id)));

    // A job that may still render keeps what the nodes load.
    EXPECT_FALSE(store_->remove_final(kept.id));
    EXPECT_TRUE(exists(keys::job_scene(kept.id)));
    EXPECT_TRUE(exists(keys::job_environment(kept.id)));
}

TEST_F(RedisJobStoreFarmSide, PastItsByteBoundInsertIsRefusedAsFull) {
    JobRecord a = make_job(1);
    store_->insert(a);

    store_->set_max_bytes(1);  // Redis always holds more than a byte
    JobRecord b = make_job(2);
    b.seq = -5;
    try {
        store_->insert(b);
        ADD_FAILURE() << "a job was stored past the byte bound";
    } catch (const StoreError& e) {
        EXPECT_TRUE(e.full) << e.what();
    }
    EXPECT_EQ(b.seq, -5);
    EXPECT_FALSE(store_->get(b.id).has_value()) << "a refused job leaves nothing";
    EXPECT_EQ(store_->count(std::nullopt), 1u);
    EXPECT_EQ(tasks_in(keys::tasks(0)).size(), 1u) << "nor a task";
    // Only new jobs are bounded: the jobs already accepted go on.
    EXPECT_TRUE(store_->get(a.id).has_value());
    EXPECT_TRUE(store_->mark_running(a.id, 1.0));

    store_->set_max_bytes(int64_t(1) << 40);
    ASSERT_NO_THROW(store_->insert(b)) << "under a bound Redis does not reach";
    EXPECT_GT(b.seq, a.seq);
    store_->set_max_bytes(0);
    JobRecord c = make_job(3);
    ASSERT_NO_THROW(store_->insert(c)) << "0: no bound";

    RedisJobStore bounded(redis_->url(), 1);
    JobRecord d = make_job(4);
    try {
        bounded.insert(d);
        ADD_FAILURE() << "the constructor's bound was not kept";
    } catch (const StoreError& e) {
        EXPECT_TRUE(e.full) << e.what();
    }
    EXPECT_FALSE(store_->get(d.id).has_value());
}

TEST_F(RedisJobStoreFarmSide, ARedisOutOfMemoryIsFull) {
    JobRecord a = make_job(1);
    store_->insert(a);
    limit_memory();

    JobRecord b = make_job(2);
    b.seq = -5;
    try {
        store_->insert(b);
        ADD_FAILURE() << "a job was stored while Redis refused writes";
    } catch (const StoreError& e) {
        EXPECT_TRUE(e.full) << "507, not 503: " << e.what();
    }
    EXPECT_EQ(b.seq, -5);
    // The store keeps answering what it has.
    EXPECT_TRUE(store_->get(a.id).has_value());
    EXPECT_FALSE(store_->get(b.id).has_value());
    EXPECT_EQ(store_->count(std::nullopt), 1u);
    EXPECT_EQ(store_->queue_position(a.id), 0);

    unlimit_memory();
    ASSERT_NO_THROW(store_->insert(b)) << "space came back";
    EXPECT_EQ(store_->count(std::nullopt), 2u);
    EXPECT_EQ(tasks_in(keys::tasks(0)).size(), 2u);
}

TEST_F(RedisJobStoreFarmSide, ConstructingWithoutRedisIsUnavailable) {
    RefusingPort closed;
    ASSERT_GT(closed.port(), 0);
    RedisUrl u = redis_->url();
    u.port = closed.port();
    expect_unavailable("the constructor", [&] { RedisJobStore s(u); });
}

TEST_F(RedisJobStoreFarmSide, RedisGoingAwayIsUnavailableAndTheStoreComesBackWithIt) {
    JobRecord a = make_job(1);
    store_->insert(a);
    const int port = redis_->port();
    stop_server();

    JobRecord b = make_job(2);
    const std::string bytes = "bytes";
    expect_unavailable("insert", [&] { store_->insert(b); });
    expect_unavailable("get", [&] { (void)store_->get(a.id); });
    expect_unavailable("count", [&] { (void)store_->count(std::nullopt); });
    expect_unavailable("mark_running", [&] { (void)store_->mark_running(a.id, 1.0); });
    expect_unavailable("queue_position", [&] { (void)store_->queue_position(a.id); });
    expect_unavailable("ids", [&] { (void)store_->ids(std::nullopt, 10); });
    expect_unavailable("live_progress", [&] { (void)store_->live_progress(a.id); });
    expect_unavailable("nodes", [&] { (void)store_->nodes(); });
    expect_unavailable("put_scene", [&] { store_->put_scene(b.id, SceneRef{"/s.gltf", content_hash(bytes), ".gltf", "s.gltf"}, &bytes); });

    ASSERT_TRUE(start_server());
    if (redis_->port() != port) GTEST_SKIP() << "redis-server came back on another port; the store's address is gone";
    // The failed calls dropped the connection, so the next call connects anew; the restarted
    // server has forgotten the insert script the store knows by its SHA.
    JobRecord c = make_job(3);
    ASSERT_NO_THROW(store_->insert(c));
    EXPECT_TRUE(store_->get(c.id).has_value());
    EXPECT_GE(store_->queue_position(c.id), 0);
}

}  // namespace
}  // namespace tessera::server
