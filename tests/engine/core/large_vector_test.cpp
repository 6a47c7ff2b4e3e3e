#include "engine/core/large_vector.h"

#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

#include "engine/core/parallel.h"

namespace tessera {
namespace {

// Large arrays start on a huge-page boundary (where the kernel can back them with 2 MiB
// pages) and keep their contents through growth; small ones come from operator new.
TEST(LargeVector, BigArraysAreHugePageAlignedAndKeepTheirContents) {
    LargeVector<uint32_t> v;
    for (uint32_t i = 0; i < 3'000'000; ++i) v.push_back(i * 7u);
    EXPECT_EQ(reinterpret_cast<uintptr_t>(v.data()) % kHugePageBytes, 0u);
    for (uint32_t i = 0; i < v.size(); i += 9973) ASSERT_EQ(v[i], i * 7u);
    LargeVector<uint32_t> small(100, 5u);
    EXPECT_EQ(small[99], 5u);
    LargeVector<uint32_t> moved = std::move(v);
    EXPECT_EQ(moved[2'999'999], 2'999'999u * 7u);
}

// A value given is a value kept (only a bare resize leaves trivial elements unwritten).
TEST(LargeVector, ExplicitValuesAreWritten) {
    LargeVector<float> v(5'000'000, 0.f);
    for (size_t i = 0; i < v.size(); i += 4099) ASSERT_EQ(v[i], 0.f);
    v.resize(6'000'000, 2.f);
    EXPECT_EQ(v[5'999'999], 2.f);
    EXPECT_EQ(v[4'999'999], 0.f);
}

// A plain vector filled through assign_huge holds n copies of the value, whatever it held
// before, small or large; and its memory is its own (writing it leaves another intact).
TEST(LargeVector, AssignHugeFillsAPlainVector) {
    std::vector<double> v(10, 3.0);
    assign_huge(v, 3'000'000, 0.5);
    ASSERT_EQ(v.size(), 3'000'000u);
    for (size_t i = 0; i < v.size(); i += 7919) ASSERT_EQ(v[i], 0.5);
    EXPECT_EQ(v.back(), 0.5);
    std::vector<double> w;
    assign_huge(w, 3'000'000, 1.5);
    v[0] = 9.0;
    EXPECT_EQ(w[0], 1.5);
    assign_huge(v, 4, -1.0);
    EXPECT_EQ(v, std::vector<double>(4, -1.0));
}

// Every item is visited exactly once, in ranges that tile [0, n) in order.
TEST(Parallel, RangesTileTheItemsWhateverTheThreadCount) {
    for (int threads : {1, 2, 3, 7}) {
        for (size_t n : {size_t(0), size_t(1), size_t(5), size_t(100'003)}) {
            std::vector<int> seen(n, 0);
            std::vector<std::pair<size_t, size_t>> ranges(size_t(std::max(threads, 1)));
            parallel_ranges(n, threads, [&](size_t begin, size_t end, int part) {
                ranges[size_t(part)] = {begin, end};
                for (size_t i = begin; i < end; ++i) ++seen[i];
            });
            for (size_t i = 0; i < n; ++i) ASSERT_EQ(seen[i], 1) << "n " << n << " threads " << threads;
            if (threads > 1 && n >= 2) {
                for (int t = 1; t < threads; ++t) EXPECT_EQ(ranges[size_t(t - 1)].second, ranges[size_t(t)].first);
            }
        }
    }
    EXPECT_EQ(pass_threads(10, 8), 1);
    EXPECT_EQ(pass_threads(1'000'000, 2), 2);
}

}  // namespace
}  // namespace tessera
