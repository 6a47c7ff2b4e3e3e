#include "server/memory_return.h"

#include <malloc.h>

#include <chrono>
#include <mutex>

namespace tessera::server {

void tune_allocator() {
    static std::once_flag once;
    std::call_once(once, [] {
        // Fixed thresholds also stop glibc from raising them after large frees (its default is
        // dynamic, up to 32 MiB, after which such blocks come from the heap and stay there).
        mallopt(M_MMAP_THRESHOLD, 4 << 20);
        mallopt(M_TRIM_THRESHOLD, 64 << 20);
    });
}

void release_free_memory() { malloc_trim(0); }

MemoryReturn::MemoryReturn(double interval_s, std::function<void()> release) {
    thread_ = std::thread([this, interval_s, release = std::move(release)] {
        std::unique_lock<std::mutex> lock(mutex_);
        while (!cv_.wait_for(lock, std::chrono::duration<double>(interval_s), [this] { return stop_; })) {
            lock.unlock();
            release();
            lock.lock();
        }
    });
}

MemoryReturn::~MemoryReturn() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
}

}  // namespace tessera::server
