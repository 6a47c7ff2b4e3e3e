#pragma once
// A std::vector for the scene's large arrays (triangles, blocks, nodes, build scratch), whose
// big allocations ask the kernel for transparent huge pages, and whose elements are
// default-initialised: `LargeVector<T> v(n)`, `resize(n)` and `emplace_back()` leave a
// trivial T unwritten, as `new T[n]` does (give a value to have one). The builders write
// every element from several threads; zeroing first would fault all of it in on one thread. A scene build writes hundreds of
// megabytes of fresh memory, and with 4 KiB pages the page faults cost more than the build:
// 1M triangles took 110k faults, 0.8 s of a 1.8 s preparation on a 2-core VM. In 2 MiB pages
// the same memory takes a few hundred, and traversal misses the TLB less. Embree allocates
// its BVH the same way (its os_malloc advises huge pages on Linux).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace tessera {

// Allocations from this size up are 2 MiB-aligned and advised MADV_HUGEPAGE; smaller ones
// come from operator new as usual.
inline constexpr size_t kHugePageBytes = size_t(2) << 20;

// A block of `bytes` (at least kHugePageBytes) 2 MiB-aligned and advised MADV_HUGEPAGE, for
// std::free: LargeAllocator's large arrays and BlockPool's large blocks.
inline void* allocate_huge_pages(size_t bytes) {
    const size_t rounded = (bytes + kHugePageBytes - 1) / kHugePageBytes * kHugePageBytes;
    void* p = std::aligned_alloc(kHugePageBytes, rounded);
    if (!p) throw std::bad_alloc();
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    ::madvise(p, rounded, MADV_HUGEPAGE);  // advice only: without THP it is refused, harmlessly
#endif
    return p;
}

template <class T>
struct LargeAllocator {
    using value_type = T;
    LargeAllocator() = default;
    template <class U>
    LargeAllocator(const LargeAllocator<U>&) noexcept {}

    T* allocate(size_t n) {
        if (n > size_t(-1) / sizeof(T)) throw std::bad_array_new_length();
        const size_t bytes = n * sizeof(T);
        if (bytes < kHugePageBytes) return static_cast<T*>(::operator new(bytes, std::align_val_t(alignof(T))));
        return static_cast<T*>(allocate_huge_pages(bytes));
    }
    void deallocate(T* p, size_t n) noexcept {
        if (n * sizeof(T) < kHugePageBytes) ::operator delete(p, std::align_val_t(alignof(T)));
        else std::free(p);
    }
    template <class U>
    void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
        ::new (static_cast<void*>(p)) U;
    }
    template <class U, class... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
    template <class U>
    bool operator==(const LargeAllocator<U>&) const noexcept { return true; }
};

template <class T>
using LargeVector = std::vector<T, LargeAllocator<T>>;

// A plain std::vector of n copies of `value` whose memory, when large, is advised
// MADV_HUGEPAGE before it is first written: the film's per-pixel arrays, which other code
// takes as std::vector. Reserved first (glibc maps a large block untouched), advised over the
// whole 2 MiB pages inside it, then filled, so the fill faults it in 2 MiB at a time.
template <class T>
void assign_huge(std::vector<T>& v, size_t n, const T& value) {
    v.clear();
    v.shrink_to_fit();
    v.reserve(n);
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    const size_t bytes = n * sizeof(T);
    if (bytes >= 2 * kHugePageBytes) {
        const uintptr_t begin = (reinterpret_cast<uintptr_t>(v.data()) + kHugePageBytes - 1) / kHugePageBytes * kHugePageBytes;
        const uintptr_t end = (reinterpret_cast<uintptr_t>(v.data()) + bytes) / kHugePageBytes * kHugePageBytes;
        if (end > begin) ::madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
    }
#endif
    v.assign(n, value);
}

}  // namespace tessera
