#pragma once
// Memory a computation repeated on same-sized data takes back instead of asking the system
// again: the denoiser after every pass of a render. Its maps are megabytes each, which glibc
// maps fresh from the kernel and unmaps when freed, so every pass paid a page fault per 4 KiB
// and zeroed every page twice (the kernel, then the vector): on this project's 2-core VM that
// was 29 % memset and 22 % page faults of a 1280×960 denoising render, and the last pass's
// denoising took 1.9 s where the same code on memory it had used before took 0.5 s.
//
// `PoolVector<T>` is a std::vector whose blocks come from the pool in use on the thread that
// made it (`BlockPool::Use`), or from the system where none is; each vector remembers the
// pool it took from, so it gives its block back there from whichever thread frees it.
// `trim()` frees the blocks that sat in the pool since the last trim, none of them taken and
// given back: a pool trimmed after every call holds at most one call's blocks between calls.
// `clear()` frees every block it holds (a farm node's, when a job's render is done).
#include <atomic>
#include <cstddef>
#include <type_traits>
#include <mutex>
#include <new>
#include <vector>

namespace tessera {

class BlockPool {
public:
    BlockPool() = default;
    BlockPool(const BlockPool&) = delete;
    BlockPool& operator=(const BlockPool&) = delete;
    ~BlockPool();

    // A block of `bytes`, aligned for any scalar type: a free one of that size if the pool holds
    // one (the sizes of a repeated computation repeat exactly), a new one otherwise.
    void* take(size_t bytes);
    void give(void* block, size_t bytes) noexcept;
    void trim();
    void clear();
    size_t held_bytes() const;   // free in the pool now
    size_t reused() const;       // takes served from the pool, since it was made
    // Threads that fault in a new block of a megabyte or more (1: the taking thread alone).
    // A first call's maps are fresh memory, which the kernel zeroes page by page as each is
    // first written; on a VM whose host backs the guest's memory lazily that is most of a first
    // denoising (4.7 s of it at 1920×1440 where the next pass's took 1.4), and split between
    // the call's threads it is done that many times as fast.
    void set_fault_threads(int threads) noexcept { fault_threads_.store(threads < 1 ? 1 : threads); }

    // Makes `pool` the current thread's for its lifetime (nullptr: none), restoring the one before.
    class Use {
    public:
        explicit Use(BlockPool* pool);
        ~Use();
        Use(const Use&) = delete;
        Use& operator=(const Use&) = delete;

    private:
        BlockPool* before_;
    };
    static BlockPool* current() noexcept;

    // What the pool asks the system for, and gives back: from the size of a huge page up, in
    // huge pages as LargeAllocator's (large_vector.h), so that even a first call faults in a
    // few hundred pages, not a hundred thousand.
    static void* allocate(size_t bytes);
    static void release(void* block, size_t bytes) noexcept;

private:
    struct Block {
        void* p;
        size_t bytes;
        bool used_since_trim;  // given back (so taken) since the last trim
    };
    mutable std::mutex mutex_;
    std::vector<Block> free_;
    size_t reused_ = 0;
    std::atomic<int> fault_threads_{1};
};

template <class T>
struct PoolAllocator {
    using value_type = T;
    using propagate_on_container_move_assignment = std::true_type;
    using propagate_on_container_swap = std::true_type;

    BlockPool* pool = BlockPool::current();

    PoolAllocator() noexcept = default;
    template <class U>
    PoolAllocator(const PoolAllocator<U>& o) noexcept : pool(o.pool) {}

    static_assert(alignof(T) <= __STDCPP_DEFAULT_NEW_ALIGNMENT__, "blocks are aligned as operator new's");

    T* allocate(size_t n) {
        if (n > size_t(-1) / sizeof(T)) throw std::bad_array_new_length();
        return static_cast<T*>(pool ? pool->take(n * sizeof(T)) : BlockPool::allocate(n * sizeof(T)));
    }
    void deallocate(T* p, size_t n) noexcept {
        if (pool) pool->give(p, n * sizeof(T));
        else BlockPool::release(p, n * sizeof(T));
    }
    template <class U>
    bool operator==(const PoolAllocator<U>& o) const noexcept { return pool == o.pool; }
    template <class U>
    bool operator!=(const PoolAllocator<U>& o) const noexcept { return pool != o.pool; }
};

template <class T>
using PoolVector = std::vector<T, PoolAllocator<T>>;

}  // namespace tessera
