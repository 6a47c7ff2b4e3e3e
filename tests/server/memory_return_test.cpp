// MemoryReturn, release_free_memory and tune_allocator held to their header: the release runs
// by itself, one call at a time, none before its first interval and none once the object is
// gone; destruction ends even an hour-long wait at once and waits out a release in progress
// (whose captures die right after it); freed heap memory goes back to the system; blocks of
// 4 MiB and up are mappings of their own, unmapped when freed, even after a larger one was
// freed (glibc's dynamic threshold would then keep them in the heap), and smaller ones are not.
#include "server/memory_return.h"

#include <gtest/gtest.h>

#include <malloc.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace tessera::server {
namespace {

using Clock = std::chrono::steady_clock;

// Long enough for a loaded 2-core machine; a failing test costs this much, no more.
constexpr int kWaitMs = 10000;

// The sanitizers bring allocators of their own: glibc's malloc, which these tests observe, is
// then not the one in use.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kSanitizerAllocator = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
constexpr bool kSanitizerAllocator = true;
#else
constexpr bool kSanitizerAllocator = false;
#endif
#else
constexpr bool kSanitizerAllocator = false;
#endif

// Called through volatile pointers, so that the compiler cannot pair up and remove a malloc and
// its free: the tests are about what the allocator does with them.
void* (*volatile g_malloc)(size_t) = ::malloc;
void (*volatile g_free)(void*) = ::free;

bool eventually(const std::function<bool()>& done, int timeout_ms = kWaitMs) {
    const auto until = Clock::now() + std::chrono::milliseconds(timeout_ms);
    while (!done()) {
        if (Clock::now() >= until) return done();
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return true;
}

// Destroys `mr` on a thread of its own and says whether that ended within `timeout_ms`. A
// destructor that hangs leaves its thread behind instead of the test; the release functions
// used with it own what they touch (shared_ptr), so that is safe.
bool destroyed_within(std::unique_ptr<MemoryReturn> mr, int timeout_ms = kWaitMs) {
    auto done = std::make_shared<std::promise<void>>();
    std::future<void> finished = done->get_future();
    std::thread([mr = std::move(mr), done]() mutable {
        mr.reset();
        done->set_value();
    }).detach();
    return finished.wait_for(std::chrono::milliseconds(timeout_ms)) == std::future_status::ready;
}

int64_t resident_bytes() {
    FILE* f = std::fopen("/proc/self/statm", "r");
    if (!f) return -1;
    long size = 0, resident = -1;
    const int n = std::fscanf(f, "%ld %ld", &size, &resident);
    std::fclose(f);
    return n == 2 ? int64_t(resident) * int64_t(::sysconf(_SC_PAGESIZE)) : -1;
}

int64_t mapped_bytes() { return int64_t(::mallinfo2().hblkhd); }

TEST(MemoryReturn, ReleasesEveryIntervalOneAtATime) {
    auto calls = std::make_shared<std::atomic<int>>(0);
    auto in_flight = std::make_shared<std::atomic<int>>(0);
    auto overlaps = std::make_shared<std::atomic<int>>(0);
    auto mr = std::make_unique<MemoryReturn>(0.01, [calls, in_flight, overlaps] {
        if (in_flight->fetch_add(1) != 0) ++*overlaps;
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        in_flight->fetch_sub(1);
        ++*calls;
    });
    EXPECT_TRUE(eventually([&] { return calls->load() >= 5; })) << calls->load() << " calls";
    EXPECT_TRUE(destroyed_within(std::move(mr)));
    EXPECT_EQ(overlaps->load(), 0);
}

TEST(MemoryReturn, NoReleaseBeforeTheFirstInterval) {
    auto calls = std::make_shared<std::atomic<int>>(0);
    auto mr = std::make_unique<MemoryReturn>(600.0, [calls] { ++*calls; });
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    EXPECT_EQ(calls->load(), 0);
    EXPECT_TRUE(destroyed_within(std::move(mr)));
}

TEST(MemoryReturn, DestructionEndsALongWaitAtOnce) {
    // Destroyed at once (the stop may come before the thread first waits: a wake-up that
    // finds nobody waiting must not be lost) and after the thread is well inside its wait.
    for (int settle_ms : {0, 200}) {
        SCOPED_TRACE(settle_ms);
        auto calls = std::make_shared<std::atomic<int>>(0);
        auto mr = std::make_unique<MemoryReturn>(3600.0, [calls] { ++*calls; });
        if (settle_ms) std::this_thread::sleep_for(std::chrono::milliseconds(settle_ms));
        EXPECT_TRUE(destroyed_within(std::move(mr))) << "the destructor waited for the interval";
        EXPECT_EQ(calls->load(), 0);
    }
}

TEST(MemoryReturn, NoReleaseOnceDestroyed) {
    auto calls = std::make_shared<std::atomic<int>>(0);
    auto in_flight = std::make_shared<std::atomic<bool>>(false);
    auto mr = std::make_unique<MemoryReturn>(0.005, [calls, in_flight] {
        *in_flight = true;
        std::this_thread::sleep_for(std::chrono::milliseconds(3));
        ++*calls;
        *in_flight = false;
    });
    ASSERT_TRUE(eventually([&] { return calls->load() >= 2; }));
    ASSERT_TRUE(destroyed_within(std::move(mr)));
    EXPECT_FALSE(in_flight->load());
    const int after = calls->load();
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    EXPECT_EQ(calls->load(), after);
}

TEST(MemoryReturn, DestructionWaitsForARunningRelease) {
    // serve's release touches the service, which is destroyed right after the MemoryReturn: a
    // destructor that returned while a release still ran would leave it using a dead object.
    struct Gate {
        std::mutex mutex;
        std::condition_variable cv;
        bool open = false;
        std::atomic<bool> entered{false};
        std::atomic<bool> finished{false};
    };
    auto gate = std::make_shared<Gate>();
    auto mr = std::make_unique<MemoryReturn>(0.005, [gate] {
        gate->entered = true;
        std::unique_lock<std::mutex> lock(gate->mutex);
        gate->cv.wait(lock, [&] { return gate->open; });
        gate->finished = true;
    });
    ASSERT_TRUE(eventually([&] { return gate->entered.load(); }));

    auto destroyed = std::make_shared<std::atomic<bool>>(false);
    std::thread destroyer([mr = std::move(mr), destroyed]() mutable {
        mr.reset();
        *destroyed = true;
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    EXPECT_FALSE(destroyed->load()) << "the destructor returned while a release was still running";
    {
        std::lock_guard<std::mutex> lock(gate->mutex);
        gate->open = true;
    }
    gate->cv.notify_all();
    const bool ended = eventually([&] { return destroyed->load(); });
    EXPECT_TRUE(ended) << "the destructor did not end once the release had";
    EXPECT_TRUE(gate->finished.load());
    if (ended) destroyer.join();
    else destroyer.detach();
}

TEST(MemoryReturn, ReleaseFreeMemoryIsSafeBesideOtherThreadsAllocating) {
    std::atomic<bool> stop{false};
    std::vector<std::thread> threads;
    for (int t = 0; t < 2; ++t)
        threads.emplace_back([&stop] {
            while (!stop) {
                std::vector<void*> blocks;
                for (size_t size = 16; size <= (256u << 10); size *= 2) blocks.push_back(g_malloc(size));
                for (void* p : blocks) g_free(p);
            }
        });
    for (int i = 0; i < 200; ++i) release_free_memory();
    stop = true;
    for (auto& t : threads) t.join();
}

TEST(MemoryReturn, ReleaseFreeMemoryGivesFreedHeapPagesBack) {
    if (kSanitizerAllocator) GTEST_SKIP() << "the sanitizer's allocator is in use, not glibc's";
    tune_allocator();
    // 64 MiB in 16 KiB blocks: heap blocks (below the mapping threshold), each page touched.
    constexpr size_t kBlock = 16u << 10, kCount = 4096;
    std::vector<void*> blocks(kCount, nullptr);
    for (auto& p : blocks) {
        p = g_malloc(kBlock);
        ASSERT_NE(p, nullptr);
        std::memset(p, 0x5a, kBlock);
    }
    // Every sixteenth block stays, so that no freed run can join the heap's top, which free()
    // itself trims past the trim threshold: what goes back must be release_free_memory's doing.
    for (size_t i = 0; i < kCount; ++i)
        if (i % 16 != 15) {
            g_free(blocks[i]);
            blocks[i] = nullptr;
        }
    const int64_t before = resident_bytes();
    release_free_memory();
    const int64_t after = resident_bytes();
    for (void* p : blocks) g_free(p);
    ASSERT_GT(before, 0);
    ASSERT_GT(after, 0);
    // 60 MiB were freed; half of it is a margin for pages shared with other blocks.
    EXPECT_GT(before - after, int64_t(32) << 20) << "resident " << before << " bytes before, " << after << " after";
}

TEST(MemoryReturn, BlocksFromFourMebibytesAreMappingsOfTheirOwn) {
    if (kSanitizerAllocator) GTEST_SKIP() << "the sanitizer's allocator is in use, not glibc's";
    tune_allocator();
    tune_allocator();  // idempotent: a second call changes nothing below

    // Just under the threshold: the heap (glibc's default maps blocks from 128 KiB).
    int64_t m0 = mapped_bytes();
    void* small = g_malloc(3u << 20);
    ASSERT_NE(small, nullptr);
    EXPECT_LT(mapped_bytes() - m0, int64_t(1) << 20) << "a 3 MiB block was mapped on its own";
    g_free(small);

    // A large mapping freed: glibc's dynamic threshold would rise to its size and keep the
    // next large blocks in the heap, where they stay after being freed.
    void* large = g_malloc(16u << 20);
    ASSERT_NE(large, nullptr);
    g_free(large);

    // Just over the threshold: a mapping of its own, unmapped at once when freed.
    m0 = mapped_bytes();
    void* big = g_malloc(5u << 20);
    ASSERT_NE(big, nullptr);
    const int64_t m1 = mapped_bytes();
    EXPECT_GE(m1 - m0, int64_t(5) << 20) << "a 5 MiB block came from the heap";
    g_free(big);
    EXPECT_GE(m1 - mapped_bytes(), int64_t(5) << 20) << "a freed 5 MiB block stayed mapped";
}

}  // namespace
}  // namespace tessera::server
