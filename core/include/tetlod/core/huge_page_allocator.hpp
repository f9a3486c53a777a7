#pragma once
// An allocator for the large working arrays of the streaming converter (the
// plane window, the per-cycle value and error buffers) and of an MT brick (its
// tets, their back links, its points): blocks of 2 MiB or more
// are aligned to 2 MiB and advised for transparent huge pages; smaller ones keep
// the type's alignment (over-aligned records such as cache-line sized tets).
//
// Why: those arrays are read a few lines at a time in rows that lie a plane
// apart (4 MiB of floats at 1025²), so with 4 KiB pages nearly every row costs
// a TLB miss and a page walk, which the chunk coders cannot hide and which
// make the processor drop software prefetches. Debian's default THP mode is
// "madvise": huge pages are used only where asked for.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace tetlod {

template <class T>
struct HugePageAllocator {
    using value_type = T;
    static constexpr std::size_t kHugePage = std::size_t{2} << 20;

    HugePageAllocator() noexcept = default;
    template <class U>
    HugePageAllocator(const HugePageAllocator<U>&) noexcept {}

    T* allocate(std::size_t n) {
        if (n > std::size_t(-1) / sizeof(T) - kHugePage) throw std::bad_alloc();
        const std::size_t bytes = n * sizeof(T);
        if (bytes < kHugePage) {
            if constexpr (alignof(T) > __STDCPP_DEFAULT_NEW_ALIGNMENT__)
                return static_cast<T*>(::operator new(bytes == 0 ? 1 : bytes, std::align_val_t(alignof(T))));
            return static_cast<T*>(::operator new(bytes == 0 ? 1 : bytes));
        }
        const std::size_t rounded = (bytes + kHugePage - 1) / kHugePage * kHugePage;
#if defined(__linux__)
        // Straight from the kernel, not through malloc. glibc raises its mmap threshold
        // to the size of every mmapped block freed (up to 32 MiB), and its trim threshold
        // to twice that: after one 10 MB brick array, later blocks below 10 MB came from
        // the heaps, and the free top of a worker thread's heap stayed resident (malloc_trim
        // releases only the main heap's top). munmap returns the block at once.
        void* raw = ::mmap(nullptr, rounded + kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (raw == MAP_FAILED) throw std::bad_alloc();
        const std::uintptr_t at = reinterpret_cast<std::uintptr_t>(raw);
        const std::uintptr_t aligned = (at + kHugePage - 1) / kHugePage * kHugePage;
        // The slack before the aligned block, then after it (never empty: aligned < at + kHugePage).
        if (aligned != at) ::munmap(raw, aligned - at);
        ::munmap(reinterpret_cast<void*>(aligned + rounded), at + kHugePage - aligned);
        void* p = reinterpret_cast<void*>(aligned);
#else
        void* p = std::aligned_alloc(kHugePage, rounded);
        if (!p) throw std::bad_alloc();
#endif
#if defined(__linux__) && defined(MADV_HUGEPAGE)
        // Only the huge pages the block fills: a huge page is resident in full once any
        // byte of it is touched, so an advised tail would hold up to 2 MiB for a few
        // bytes (a 4.8 MiB array of small MT bricks took 6 MiB). The tail keeps 4 KiB pages.
        ::madvise(p, bytes / kHugePage * kHugePage, MADV_HUGEPAGE);  // advice only: a refusal changes nothing
#endif
        return static_cast<T*>(p);
    }
    void deallocate(T* p, std::size_t n) noexcept {
        if (n * sizeof(T) >= kHugePage) {
#if defined(__linux__)
            ::munmap(p, (n * sizeof(T) + kHugePage - 1) / kHugePage * kHugePage);
#else
            std::free(p);
#endif
        }
        else if constexpr (alignof(T) > __STDCPP_DEFAULT_NEW_ALIGNMENT__) ::operator delete(p, std::align_val_t(alignof(T)));
        else ::operator delete(p);
    }

    template <class U>
    bool operator==(const HugePageAllocator<U>&) const noexcept { return true; }
};

/// A std::vector whose large storage is advised for huge pages (see above).
template <class T>
using HugePageVector = std::vector<T, HugePageAllocator<T>>;

}  // namespace tetlod
