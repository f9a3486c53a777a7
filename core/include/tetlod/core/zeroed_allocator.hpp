#pragma once
// An allocator for large numeric arrays whose memory is committed only where it
// is written. Storage comes from std::calloc: the C library serves large blocks
// as fresh anonymous pages, which read as zero and cost no resident memory until
// touched. Default construction of an element does nothing (the bytes are
// already zero), so `resize` on fresh storage never walks the array.
//
// Why: a decoder allocates the grid a header claims before it can check the
// payload that fills it. With value-initialised storage, a small hostile file
// claiming a large grid would cost the whole grid's memory before the first
// chunk fails; with this allocator it costs only the pages the decoder reached.
//
// Contract: elements added by growing `resize` are zero only when the storage
// is fresh (a new allocation). After a shrink, growing again in place exposes
// the old values, as with any default-initialising allocator: code that needs
// zeros there must assign them.
#include <cstddef>
#include <cstdlib>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

namespace tetlod {

template <class T>
struct ZeroedAllocator {
    static_assert(std::is_trivially_copyable_v<T>, "for numeric arrays only");
    using value_type = T;

    ZeroedAllocator() noexcept = default;
    template <class U>
    ZeroedAllocator(const ZeroedAllocator<U>&) noexcept {}

    T* allocate(std::size_t n) {
        if (n == 0) n = 1;  // calloc(0) may return nullptr
        void* p = std::calloc(n, sizeof(T));  // checks n * sizeof(T) for overflow
        if (!p) throw std::bad_alloc();
        return static_cast<T*>(p);
    }
    void deallocate(T* p, std::size_t) noexcept { std::free(p); }

    // Default construction leaves the (already zero) bytes alone.
    template <class U>
    void construct(U*) noexcept {}
    template <class U, class... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }

    template <class U>
    bool operator==(const ZeroedAllocator<U>&) const noexcept { return true; }
};

/// A std::vector whose fresh storage is zero and committed lazily (see above).
template <class T>
using ZeroedVector = std::vector<T, ZeroedAllocator<T>>;

}  // namespace tetlod
