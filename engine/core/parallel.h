#pragma once
// Splits [0, n) into one contiguous range per thread and runs fn(begin, end, part) on each, the
// first on the calling thread. For the scene build's passes whose items are independent: the
// result does not depend on the thread count.
#include <algorithm>
#include <cstddef>
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
    std::vector<std::thread> workers;
    workers.reserve(size_t(threads - 1));
    for (int t = 1; t < threads; ++t)
        workers.emplace_back([&fn, n, t, threads] { fn(n * size_t(t) / size_t(threads), n * size_t(t + 1) / size_t(threads), t); });
    fn(size_t(0), n / size_t(threads), 0);
    for (std::thread& w : workers) w.join();
}

}  // namespace tessera
