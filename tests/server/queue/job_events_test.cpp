// The event history behind GET /v1/events: ids, resuming, filtering, losing, closing.
#include "server/queue/job_events.h"

#include <gtest/gtest.h>

#include <thread>

namespace tessera::server {
namespace {

using std::chrono::milliseconds;

TEST(JobEvents, ANewReaderSeesOnlyWhatComesNextInOrder) {
    JobEvents ev(16);
    ev.publish("created", "a", "{}");
    const uint64_t start = ev.last_id();
    ev.publish("state", "a", R"({"n":1})");
    ev.publish("state", "b", R"({"n":2})");
    const auto b = ev.wait_after(start, "", milliseconds(0));
    ASSERT_EQ(b.events.size(), 2u);
    EXPECT_FALSE(b.lost);
    EXPECT_EQ(b.events[0].data, R"({"n":1})");
    EXPECT_EQ(b.events[1].job_id, "b");
    EXPECT_EQ(b.events[1].id, b.events[0].id + 1);
    EXPECT_EQ(b.last, b.events[1].id);
    // Resuming from the last id seen gives nothing more until something happens.
    EXPECT_TRUE(ev.wait_after(b.last, "", milliseconds(0)).events.empty());
}

TEST(JobEvents, AJobFilterSkipsOtherJobsAndMovesOn) {
    JobEvents ev(16);
    const uint64_t start = ev.last_id();
    ev.publish("state", "a", "1");
    ev.publish("state", "b", "2");
    ev.publish("state", "a", "3");
    auto b = ev.wait_after(start, "a", milliseconds(0));
    ASSERT_EQ(b.events.size(), 2u);
    EXPECT_EQ(b.events[0].data, "1");
    EXPECT_EQ(b.events[1].data, "3");
    ev.publish("state", "b", "4");
    b = ev.wait_after(b.last, "a", milliseconds(0));
    EXPECT_TRUE(b.events.empty());
    EXPECT_EQ(b.last, ev.last_id()) << "the filtered reader moved past b's event";
}

TEST(JobEvents, ReadersThatFellBehindOrCameFromElsewhereAreTold) {
    JobEvents ev(4);
    const uint64_t start = ev.last_id();
    for (int i = 0; i < 10; ++i) ev.publish("progress", "a", std::to_string(i));
    auto b = ev.wait_after(start, "", milliseconds(0));
    EXPECT_TRUE(b.lost) << "six events were dropped";
    EXPECT_TRUE(b.events.empty());
    EXPECT_EQ(b.last, ev.last_id());
    // One before the oldest held is still complete.
    b = ev.wait_after(ev.last_id() - 4, "", milliseconds(0));
    EXPECT_FALSE(b.lost);
    EXPECT_EQ(b.events.size(), 4u);
    // An id from an earlier process (smaller than this one's first) or from nowhere.
    EXPECT_TRUE(ev.wait_after(1, "", milliseconds(0)).lost);
    EXPECT_TRUE(ev.wait_after(ev.last_id() + 1000, "", milliseconds(0)).lost);
}

TEST(JobEvents, TheHistoryIsBoundedInBytesToo) {
    JobEvents ev(100, 1000);
    const uint64_t start = ev.last_id();
    for (int i = 0; i < 10; ++i) ev.publish("progress", "a", std::string(300, 'x'));
    EXPECT_TRUE(ev.wait_after(start, "", milliseconds(0)).lost);
    const auto held = ev.wait_after(ev.last_id() - 3, "", milliseconds(0));
    EXPECT_FALSE(held.lost) << "three events of 300 bytes fit in 1000";
    EXPECT_EQ(held.events.size(), 3u);
    EXPECT_TRUE(ev.wait_after(ev.last_id() - 4, "", milliseconds(0)).lost);
    // One event larger than the bound is still held (the newest always is).
    ev.publish("state", "a", std::string(5000, 'y'));
    EXPECT_EQ(ev.wait_after(ev.last_id() - 1, "", milliseconds(0)).events.size(), 1u);
}

TEST(JobEvents, IdsKeepIncreasingOverARestart) {
    uint64_t before;
    {
        JobEvents first(4);
        first.publish("created", "a", "{}");
        before = first.last_id();
    }
    std::this_thread::sleep_for(milliseconds(2));
    JobEvents second(4);
    EXPECT_GT(second.last_id(), before);
    EXPECT_TRUE(second.wait_after(before, "", milliseconds(0)).lost);
}

TEST(JobEvents, AWaitingReaderWakesForAnEventAndForClose) {
    JobEvents ev(16);
    const uint64_t start = ev.last_id();
    std::thread t([&] {
        std::this_thread::sleep_for(milliseconds(50));
        ev.publish("created", "a", "{}");
    });
    const auto t0 = std::chrono::steady_clock::now();
    const auto b = ev.wait_after(start, "", milliseconds(10000));
    t.join();
    EXPECT_EQ(b.events.size(), 1u);
    EXPECT_LT(std::chrono::steady_clock::now() - t0, milliseconds(5000));

    std::thread closer([&] {
        std::this_thread::sleep_for(milliseconds(50));
        ev.close();
    });
    const auto c = ev.wait_after(b.last, "", milliseconds(10000));
    closer.join();
    EXPECT_TRUE(c.closed);
    EXPECT_TRUE(ev.wait_after(b.last, "", milliseconds(10000)).closed) << "after close, waits return at once";
}

TEST(JobEvents, SubscriptionsAreCounted) {
    JobEvents ev;
    EXPECT_EQ(ev.subscribers(), 0);
    {
        JobEvents::Subscription a(ev), b(ev);
        EXPECT_EQ(ev.subscribers(), 2);
    }
    EXPECT_EQ(ev.subscribers(), 0);
}

}  // namespace
}  // namespace tessera::server
