#pragma once
// Splits [0, n) into one contiguous range per thread and runs fn(begin, end, part) on each, the
// first on the calling thread. For the scene build's passes whose items are independent: the
// result does not depend on the thread count.
#include <algorithm>
#include <cstddef>
#include <system_error>
#include <thread>
#include <vector>

namespace tessera {

// Threads a pass over n items is worth: none below `grain` items each.
inline int pass_threads(size_t n, int threads, size_t grain = 16384) {
    if (threads <= 0) threads = int(std::max(1u, std::thread::hardware_concurrency()));
    return int(std::clamp<size_t>(n / grain, 1, size_t(threads)));
}

template <class Fn>
void parallel_ranges(size_t n, int threads, Fn&& fn) {
    if (threads <= 1 || n < 2) {
        fn(size_t(0), n, 0);
        return;
    }
    auto range = [&fn, n, threads](int t) { fn(n * size_t(t) / size_t(threads), n * size_t(t + 1) / size_t(threads), t); };
    std::vector<std::thread> workers;
    workers.reserve(size_t(threads - 1));
    int started = 1;
    try {
        for (; started < threads; ++started) workers.emplace_back(range, started);
    } catch (const std::system_error&) {
        // No more threads to be had (a busy server): the ranges left run here, same result.
    }
    range(0);
    for (int t = started; t < threads; ++t) range(t);
    for (std::thread& w : workers) w.join();
}

}  // namespace tessera
