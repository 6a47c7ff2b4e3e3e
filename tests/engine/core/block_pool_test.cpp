#include "engine/core/block_pool.h"

#include <cstdint>
#include <thread>

#include <gtest/gtest.h>

#include "engine/core/large_vector.h"

namespace tessera {
namespace {

// A block freed is the block the next vector of its size gets, and a pool trimmed after a call
// keeps only what that call used.
TEST(BlockPool, GivesBackTheBlockOfTheSizeAskedAndTrimsWhatSatIdle) {
    BlockPool pool;
    const float* first = nullptr;
    {
        const BlockPool::Use use(&pool);
        PoolVector<float> a(1000, 1.f), b(3'000'000, 2.f);
        first = b.data();
        EXPECT_EQ(reinterpret_cast<uintptr_t>(b.data()) % kHugePageBytes, 0u) << "large blocks start on a huge page";
    }
    EXPECT_EQ(pool.held_bytes(), (1000 + 3'000'000) * sizeof(float));
    pool.trim();  // both were used since the pool was made: kept
    EXPECT_EQ(pool.held_bytes(), (1000 + 3'000'000) * sizeof(float));
    {
        const BlockPool::Use use(&pool);
        PoolVector<float> again(3'000'000);
        EXPECT_EQ(again.data(), first);
        EXPECT_EQ(again[2'999'999], 0.f) << "a reused block is value-initialised as any vector's";
        EXPECT_EQ(pool.reused(), 1u);
        PoolVector<float> other(77);  // no block of this size: a new one
        EXPECT_EQ(pool.reused(), 1u);
    }
    pool.trim();  // the 1000-float block sat idle through that call
    EXPECT_EQ(pool.held_bytes(), (77 + 3'000'000) * sizeof(float));
    pool.trim();
    pool.trim();
    EXPECT_EQ(pool.held_bytes(), 0u) << "nothing taken for a whole call is given to the system";
    {
        const BlockPool::Use use(&pool);
        PoolVector<float> a(5000), b(6000);
    }
    EXPECT_EQ(pool.held_bytes(), 11000 * sizeof(float));
    pool.clear();
    EXPECT_EQ(pool.held_bytes(), 0u) << "cleared, it holds nothing, used or not";
}

// A vector remembers its pool: freed on another thread, or after the pool stopped being the
// thread's, its block still goes back there; made where no pool is in use, it never touches one.
TEST(BlockPool, AVectorGivesItsBlockToThePoolItTookFromWhereverItIsFreed) {
    BlockPool pool, inner;
    PoolVector<double> v;
    {
        const BlockPool::Use use(&pool);
        v = PoolVector<double>(4096, 1.0);
        {
            const BlockPool::Use nested(&inner);
            EXPECT_EQ(BlockPool::current(), &inner);
        }
        EXPECT_EQ(BlockPool::current(), &pool);
    }
    EXPECT_EQ(BlockPool::current(), nullptr);
    std::thread([&] { PoolVector<double>().swap(v); }).join();
    EXPECT_EQ(pool.held_bytes(), 4096 * sizeof(double));
    EXPECT_EQ(inner.held_bytes(), 0u);
    PoolVector<double> plain(4096, 3.0);  // no pool in use
    plain = PoolVector<double>();
    EXPECT_EQ(pool.held_bytes(), 4096 * sizeof(double));
}

// A first call's big blocks are faulted in by the call's threads (for speed alone): every byte of
// a block of any size, a page's multiple or not, huge pages or not, is the taker's to write, and
// a vector made on it reads as it always does. (Under ASan a write past the block is caught.)
TEST(BlockPool, BlocksFaultedInByManyThreadsAreWholeAndUsable) {
    for (int threads : {0, 1, 2, 3}) {
        BlockPool pool;
        pool.set_fault_threads(threads);
        const BlockPool::Use use(&pool);
        for (size_t bytes : {size_t(1) << 20, (size_t(1) << 20) + 5, kHugePageBytes * 3 + 4097}) {
            PoolVector<unsigned char> v(bytes, 7);
            EXPECT_EQ(v.front(), 7);
            EXPECT_EQ(v.back(), 7);
            v.assign(bytes, 9);
            EXPECT_EQ(v[bytes / 2], 9);
        }
        PoolVector<float> again(((size_t(1) << 20) + 5) / sizeof(float) + 1);  // a fresh size: a new block
        EXPECT_EQ(again.back(), 0.f);
    }
}

}  // namespace
}  // namespace tessera
