#include "engine/core/block_pool.h"

#include <cstdlib>

#include "engine/core/large_vector.h"  // kHugePageBytes, allocate_huge_pages
#include "engine/core/parallel.h"

namespace tessera {

namespace {

thread_local BlockPool* t_current = nullptr;

constexpr size_t kPageBytes = 4096;
constexpr size_t kParallelFaultBytes = size_t(1) << 20;

// One byte written per page, the pages split between `threads`: each thread's first writes
// fault in (and the kernel zeroes) its share. The block's contents are undefined to its taker
// either way.
void fault_in(void* block, size_t bytes, int threads) {
    auto* bytes_of = static_cast<volatile unsigned char*>(block);
    const size_t pages = (bytes + kPageBytes - 1) / kPageBytes;
    parallel_ranges(pages, threads, [&](size_t begin, size_t end, int) {
        for (size_t i = begin; i < end; ++i) bytes_of[i * kPageBytes] = 0;
    });
}

}  // namespace

void* BlockPool::allocate(size_t bytes) {
    return bytes < kHugePageBytes ? ::operator new(bytes) : allocate_huge_pages(bytes);
}

void BlockPool::release(void* p, size_t bytes) noexcept {
    if (bytes < kHugePageBytes) ::operator delete(p);
    else std::free(p);
}

BlockPool::~BlockPool() {
    for (const Block& b : free_) release(b.p, b.bytes);
}

void* BlockPool::take(size_t bytes) {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        for (size_t i = free_.size(); i-- > 0;)
            if (free_[i].bytes == bytes) {
                void* p = free_[i].p;
                free_[i] = free_.back();
                free_.pop_back();
                ++reused_;
                return p;
            }
    }
    void* fresh = allocate(bytes);
    const int threads = fault_threads_.load();
    if (threads > 1 && bytes >= kParallelFaultBytes) fault_in(fresh, bytes, threads);
    return fresh;
}

void BlockPool::give(void* block, size_t bytes) noexcept {
    if (!block) return;
    std::lock_guard<std::mutex> lock(mutex_);
    try {
        free_.push_back({block, bytes, true});
    } catch (...) {
        release(block, bytes);  // no room to keep it: give it to the system instead
    }
}

void BlockPool::trim() {
    std::lock_guard<std::mutex> lock(mutex_);
    size_t kept = 0;
    for (Block& b : free_) {
        if (!b.used_since_trim) {
            release(b.p, b.bytes);
            continue;
        }
        b.used_since_trim = false;
        free_[kept++] = b;
    }
    free_.resize(kept);
}

void BlockPool::clear() {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const Block& b : free_) release(b.p, b.bytes);
    free_.clear();
}

size_t BlockPool::held_bytes() const {
    std::lock_guard<std::mutex> lock(mutex_);
    size_t sum = 0;
    for (const Block& b : free_) sum += b.bytes;
    return sum;
}

size_t BlockPool::reused() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return reused_;
}

BlockPool::Use::Use(BlockPool* pool) : before_(t_current) { t_current = pool; }
BlockPool::Use::~Use() { t_current = before_; }
BlockPool* BlockPool::current() noexcept { return t_current; }

}  // namespace tessera
