// The contract every job store keeps, run against both: SQLite (one process) and Redis (a
// render farm; a real redis-server started by the test on a random loopback port).
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "server/store/redis_job_store.h"
#include "server/store/redis_process.h"
#include "server/store/sqlite_job_store.h"
#include "tests/server/job_records.h"
#include "tests/server/redis_suite.h"

namespace tessera::server {
namespace {

namespace fs = std::filesystem;

using test::hex_id;
using test::make_job;

class JobStoreContract : public test::WithSuiteRedis<::testing::TestWithParam<std::string>, true> {
protected:
    void SetUp() override {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        std::string name = info->name();
        for (char& c : name) if (c == '/') c = '_';
        dir_ = fs::temp_directory_path() / ("tessera_store_contract_" + name + "_" + std::to_string(::getpid()));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
        if (GetParam() == "redis") redis_ready("the Redis store is not tested");
    }
    void TearDown() override {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    // A new store on the same data: SQLite's file, or the same Redis.
    std::unique_ptr<JobStore> open() const {
        if (GetParam() == "redis") return std::make_unique<RedisJobStore>(redis_->url());
        return std::make_unique<SqliteJobStore>((dir_ / "tessera.db").string());
    }

    fs::path dir_;
};

TEST_P(JobStoreContract, InsertGetRoundTripsEveryField) {
    auto owned = open();
    JobStore& store = *owned;
    JobRecord r;
    r.id = "0123456789abcdef";
    r.state = JobState::queued;
    r.spec_json = std::string(R"({"scene":"x","quote":"it's ; DROP TABLE jobs; --"})") + '\0' + "tail";
    r.priority = -7;
    r.created_at = 1700000000.25;
    r.started_at = 1700000001.5;
    r.finished_at = 1700000002.75;
    r.error = "ünïcödé error\nline two";
    r.report_json = R"({"ms":12.5})";
    r.attempts = 3;
    store.insert(r);
    EXPECT_EQ(r.seq, 1);

    const auto got = store.get(r.id);
    ASSERT_TRUE(got.has_value());
    EXPECT_EQ(got->id, r.id);
    EXPECT_EQ(got->state, r.state);
    EXPECT_EQ(got->spec_json, r.spec_json) << "embedded NUL and quotes survive";
    EXPECT_EQ(got->priority, r.priority);
    EXPECT_EQ(got->seq, r.seq);
    EXPECT_DOUBLE_EQ(got->created_at, r.created_at);
    EXPECT_DOUBLE_EQ(got->started_at, r.started_at);
    EXPECT_DOUBLE_EQ(got->finished_at, r.finished_at);
    EXPECT_EQ(got->error, r.error);
    EXPECT_EQ(got->report_json, r.report_json);
    EXPECT_EQ(got->attempts, r.attempts);

    EXPECT_FALSE(store.get("ffffffffffffffff").has_value());
}

TEST_P(JobStoreContract, DuplicateIdThrowsAndLeavesSeqUntouched) {
    auto owned = open();
    JobStore& store = *owned;
    JobRecord a = make_job(1);
    store.insert(a);
    JobRecord b = make_job(1);
    b.seq = -5;
    try {
        store.insert(b);
        FAIL() << "duplicate id accepted";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("insert"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("UNIQUE"), std::string::npos) << e.what();
    }
    EXPECT_EQ(b.seq, -5);
    EXPECT_EQ(store.count(std::nullopt), 1u);
    JobRecord c = make_job(2);
    store.insert(c);  // the failed transaction was rolled back, the store is still usable
    EXPECT_EQ(c.seq, 2);
}

TEST_P(JobStoreContract, SeqIsMonotonicAndContinuesAfterReopen) {
    {
        auto owned = open();
    JobStore& store = *owned;
        for (uint64_t i = 1; i <= 5; ++i) {
            JobRecord r = make_job(i);
            store.insert(r);
            EXPECT_EQ(r.seq, static_cast<int64_t>(i));
        }
    }
    auto owned = open();
    JobStore& store = *owned;
    JobRecord r = make_job(6);
    store.insert(r);
    EXPECT_EQ(r.seq, 6);
    EXPECT_EQ(store.count(std::nullopt), 6u);
}

TEST_P(JobStoreContract, StateNamesRoundTrip) {
    for (JobState s : api::kJobStates) {
        JobState back = JobState::queued;
        ASSERT_TRUE(parse_job_state(to_string(s), back)) << to_string(s);
        EXPECT_EQ(back, s);
    }
    EXPECT_STREQ(to_string(JobState::canceled), "canceled");
    JobState out = JobState::failed;
    EXPECT_FALSE(parse_job_state("Queued", out));
    EXPECT_FALSE(parse_job_state("", out));
    EXPECT_EQ(out, JobState::failed) << "untouched on failure";
}

// paused: from queued or running only, out of the queue, kept across a restart's requeue; resumed,
// queued again in its place; canceled from paused; never counted as final.
TEST_P(JobStoreContract, PauseAndResume) {
    auto owned = open();
    JobStore& store = *owned;
    JobRecord a = make_job(1), b = make_job(2), c = make_job(3);
    store.insert(a);
    store.insert(b);
    store.insert(c);
    ASSERT_TRUE(store.mark_running(b.id, 5.0));
    EXPECT_TRUE(store.pause(a.id)) << "queued";
    EXPECT_TRUE(store.pause(b.id)) << "running";
    EXPECT_FALSE(store.pause(a.id)) << "already paused";
    EXPECT_EQ(store.get(a.id)->state, JobState::paused);
    EXPECT_EQ(store.count(JobState::paused), 2u);
    ASSERT_EQ(store.queued_in_order().size(), 1u);
    EXPECT_EQ(store.queued_in_order()[0].id, c.id);
    EXPECT_EQ(store.requeue_all_running(), 0) << "a paused job is not running";
    EXPECT_FALSE(store.mark_running(a.id, 6.0));
    EXPECT_FALSE(store.resume(c.id)) << "not paused";
    EXPECT_TRUE(store.resume(a.id));
    EXPECT_FALSE(store.resume(a.id));
    const auto order = store.queued_in_order();
    ASSERT_EQ(order.size(), 2u);
    EXPECT_EQ(order[0].id, a.id) << "back in its place";
    EXPECT_EQ(store.get(a.id)->finished_at, 0.0);
    EXPECT_TRUE(store.finish(b.id, JobState::canceled, 9.0, "", "")) << "a paused job can be canceled";
    EXPECT_FALSE(store.remove_final(a.id)) << "queued is not final";
    EXPECT_FALSE(store.pause(b.id)) << "final";
    EXPECT_FALSE(store.pause("0000000000000bad"));
}

TEST_P(JobStoreContract, MarkRunningOnlyFromQueued) {
    auto owned = open();
    JobStore& store = *owned;
    JobRecord r = make_job(1);
    store.insert(r);
    EXPECT_TRUE(store.mark_running(r.id, 100.0));
    EXPECT_FALSE(store.mark_running(r.id, 200.0));
    auto got = store.get(r.id);
    EXPECT_EQ(got->state, JobState::running);
    EXPECT_DOUBLE_EQ(got->started_at, 100.0);
    EXPECT_EQ(got->attempts, 1);
    EXPECT_FALSE(store.mark_running("0000000000000bad", 1.0)) << "missing job";
}

TEST_P(JobStoreContract, FinishOnlyFromNonFinal) {
    auto owned = open();
    JobStore& store = *owned;
    JobRecord a = make_job(1), b = make_job(2);
    store.insert(a);
    store.insert(b);
    ASSERT_TRUE(store.mark_running(a.id, 10.0));
    EXPECT_TRUE(store.finish(a.id, JobState::failed, 20.0, "out of memory", R"({"t":1})"));
    EXPECT_FALSE(store.finish(a.id, JobState::succeeded, 30.0, "", "{}")) << "already final";
    auto got = store.get(a.id);
    EXPECT_EQ(got->state, JobState::failed);
    EXPECT_DOUBLE_EQ(got->finished_at, 20.0);
    EXPECT_EQ(got->error, "out of memory");
    EXPECT_EQ(got->report_json, R"({"t":1})");

    EXPECT_TRUE(store.finish(b.id, JobState::canceled, 15.0, "", "")) << "a queued job can be canceled";
    EXPECT_EQ(store.get(b.id)->state, JobState::canceled);
    EXPECT_FALSE(store.mark_running(b.id, 16.0));
    EXPECT_FALSE(store.finish("0000000000000bad", JobState::succeeded, 1.0, "", ""));
    EXPECT_THROW(store.finish(b.id, JobState::running, 1.0, "", ""), std::invalid_argument);
}

TEST_P(JobStoreContract, RequeueOnlyFromRunningKeepsAttempts) {
    auto owned = open();
    JobStore& store = *owned;
    JobRecord r = make_job(1);
    store.insert(r);
    EXPECT_FALSE(store.requeue(r.id)) << "queued, not running";
    ASSERT_TRUE(store.mark_running(r.id, 10.0));
    EXPECT_TRUE(store.requeue(r.id));
    auto got = store.get(r.id);
    EXPECT_EQ(got->state, JobState::queued);
    EXPECT_DOUBLE_EQ(got->started_at, 0.0);
    EXPECT_EQ(got->attempts, 1);
    ASSERT_TRUE(store.mark_running(r.id, 11.0));
    EXPECT_EQ(store.get(r.id)->attempts, 2);
    ASSERT_TRUE(store.finish(r.id, JobState::succeeded, 12.0, "", "{}"));
    EXPECT_FALSE(store.requeue(r.id)) << "final";
}

TEST_P(JobStoreContract, RequeueAllRunningAfterCrash) {
    {
        auto owned = open();
    JobStore& store = *owned;
        for (uint64_t i = 1; i <= 4; ++i) {
            JobRecord r = make_job(i);
            store.insert(r);
        }
        ASSERT_TRUE(store.mark_running(hex_id(1), 5.0));
        ASSERT_TRUE(store.mark_running(hex_id(2), 5.0));
        ASSERT_TRUE(store.mark_running(hex_id(3), 5.0));
        ASSERT_TRUE(store.finish(hex_id(3), JobState::succeeded, 6.0, "", "{}"));
    }  // closed with two jobs still running, as if the process had died mid-render
    auto owned = open();
    JobStore& store = *owned;
    EXPECT_EQ(store.count(JobState::running), 2u);
    EXPECT_EQ(store.requeue_all_running(), 2);
    EXPECT_EQ(store.requeue_all_running(), 0);
    EXPECT_EQ(store.count(JobState::queued), 3u);
    EXPECT_EQ(store.get(hex_id(1))->attempts, 1);
    EXPECT_EQ(store.get(hex_id(3))->state, JobState::succeeded);
}

TEST_P(JobStoreContract, RemoveFinalOnlyForFinal) {
    auto owned = open();
    JobStore& store = *owned;
    for (uint64_t i = 1; i <= 3; ++i) {
        JobRecord r = make_job(i);
        store.insert(r);
    }
    ASSERT_TRUE(store.mark_running(hex_id(2), 1.0));
    ASSERT_TRUE(store.finish(hex_id(3), JobState::canceled, 2.0, "", ""));
    EXPECT_FALSE(store.remove_final(hex_id(1))) << "queued";
    EXPECT_FALSE(store.remove_final(hex_id(2))) << "running";
    EXPECT_TRUE(store.remove_final(hex_id(3)));
    EXPECT_FALSE(store.remove_final(hex_id(3))) << "already gone";
    EXPECT_FALSE(store.get(hex_id(3)).has_value());
    EXPECT_EQ(store.count(std::nullopt), 2u);
}

TEST_P(JobStoreContract, QueuedInOrderByPriorityThenSeq) {
    auto owned = open();
    JobStore& store = *owned;
    const int priorities[] = {0, 5, 0, 10, 5, -1, 10};
    for (uint64_t i = 0; i < 7; ++i) {
        JobRecord r = make_job(i + 1, priorities[i]);
        store.insert(r);
    }
    ASSERT_TRUE(store.mark_running(hex_id(4), 1.0));  // a running job is not in the queue
    std::vector<std::string> ids;
    for (const auto& r : store.queued_in_order()) ids.push_back(r.id);
    EXPECT_EQ(ids, (std::vector<std::string>{hex_id(7), hex_id(2), hex_id(5), hex_id(1), hex_id(3), hex_id(6)}));
}

TEST_P(JobStoreContract, ListFiltersPagesAndCounts) {
    auto owned = open();
    JobStore& store = *owned;
    for (uint64_t i = 1; i <= 10; ++i) {
        JobRecord r = make_job(i);
        store.insert(r);
        if (i % 2 == 0) {
            ASSERT_TRUE(store.finish(r.id, JobState::succeeded, 1.0, "", "{}"));
        }
    }
    const auto all = store.list(std::nullopt, 0, 100);
    ASSERT_EQ(all.size(), 10u);
    for (size_t i = 0; i < all.size(); ++i) EXPECT_EQ(all[i].seq, static_cast<int64_t>(10 - i)) << "newest first";

    const auto page = store.list(std::nullopt, 3, 4);
    ASSERT_EQ(page.size(), 4u);
    EXPECT_EQ(page.front().seq, 7);
    EXPECT_EQ(page.back().seq, 4);

    const auto done = store.list(JobState::succeeded, 1, 2);
    ASSERT_EQ(done.size(), 2u);
    EXPECT_EQ(done[0].id, hex_id(8));
    EXPECT_EQ(done[1].id, hex_id(6));
    EXPECT_TRUE(store.list(JobState::queued, 5, 10).empty());
    EXPECT_TRUE(store.list(JobState::failed, 0, 10).empty());
    EXPECT_TRUE(store.list(std::nullopt, 0, 0).empty());
    EXPECT_EQ(store.list(std::nullopt, 0, SIZE_MAX).size(), 10u);
    EXPECT_TRUE(store.list(std::nullopt, SIZE_MAX, SIZE_MAX).empty());

    EXPECT_EQ(store.count(std::nullopt), 10u);
    EXPECT_EQ(store.count(JobState::succeeded), 5u);
    EXPECT_EQ(store.count(JobState::queued), 5u);
    EXPECT_EQ(store.count(JobState::running), 0u);
}

TEST_P(JobStoreContract, ListClampsLimitTo1000) {
    auto owned = open();
    JobStore& store = *owned;
    for (uint64_t i = 1; i <= 1005; ++i) {
        JobRecord r = make_job(i);
        store.insert(r);
    }
    EXPECT_EQ(store.list(std::nullopt, 0, 5000).size(), 1000u);
    EXPECT_EQ(store.list(std::nullopt, 1000, 5000).size(), 5u);
}

TEST_P(JobStoreContract, ConcurrentInsertsAndTransitionsAreAllAccountedFor) {
    constexpr int kThreads = 8, kPerThread = 200;
    auto owned = open();
    JobStore& store = *owned;
    std::atomic<bool> stop{false};
    std::atomic<int> errors{0};
    std::thread reader([&] {
        while (!stop) {
            try {
                (void)store.count(std::nullopt);
                (void)store.list(JobState::running, 0, 50);
                (void)store.queued_in_order();
            } catch (...) {
                ++errors;
            }
        }
    });
    std::vector<std::thread> workers;
    for (int t = 0; t < kThreads; ++t) {
        workers.emplace_back([&, t] {
            try {
                for (int i = 0; i < kPerThread; ++i) {
                    JobRecord r = make_job(static_cast<uint64_t>(t) * 1000 + static_cast<uint64_t>(i), i % 3);
                    store.insert(r);
                    if (!store.mark_running(r.id, 1.0)) ++errors;
                    if (i % 4 == 0) {
                        if (!store.requeue(r.id)) ++errors;  // stays queued
                    } else if (!store.finish(r.id, i % 4 == 1 ? JobState::failed : JobState::succeeded, 2.0,
                                             i % 4 == 1 ? "boom" : "", "{}")) {
                        ++errors;
                    }
                }
            } catch (...) {
                ++errors;
            }
        });
    }
    for (auto& w : workers) w.join();
    stop = true;
    reader.join();
    EXPECT_EQ(errors.load(), 0);

    constexpr size_t kTotal = kThreads * kPerThread;
    EXPECT_EQ(store.count(std::nullopt), kTotal);
    EXPECT_EQ(store.count(JobState::queued), kTotal / 4);
    EXPECT_EQ(store.count(JobState::failed), kTotal / 4);
    EXPECT_EQ(store.count(JobState::succeeded), kTotal / 2);
    EXPECT_EQ(store.count(JobState::running), 0u);

    std::set<int64_t> seqs;
    std::set<std::string> ids;
    for (size_t off = 0; off < kTotal; off += 1000) {
        for (const auto& r : store.list(std::nullopt, off, 1000)) {
            seqs.insert(r.seq);
            ids.insert(r.id);
            EXPECT_EQ(r.attempts, 1);
        }
    }
    EXPECT_EQ(ids.size(), kTotal);
    ASSERT_EQ(seqs.size(), kTotal) << "no seq handed out twice";
    EXPECT_EQ(*seqs.begin(), 1);
    EXPECT_EQ(*seqs.rbegin(), static_cast<int64_t>(kTotal));
}

INSTANTIATE_TEST_SUITE_P(Stores, JobStoreContract, ::testing::Values("sqlite", "redis"),
                         [](const ::testing::TestParamInfo<std::string>& p) { return p.param; });

}  // namespace
}  // namespace tessera::server
