#pragma once

// Large buffers backed by transparent huge pages where the system offers them.
//
// Touching fresh memory costs one page fault per 4 KiB page; on a virtual machine a fault costs
// 10-20 us, so that filling a 35 MB MERL table took 140 ms of CPU in faults alone (3 ms with
// 2 MiB pages). Linux backs a range with huge pages on first touch once it is advised
// (madvise(MADV_HUGEPAGE); honoured when /sys/kernel/mm/transparent_hugepage/enabled is "always"
// or "madvise"). Elsewhere, and for small buffers, these are plain reserve/resize.

#include <cstddef>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

namespace gonio {

/// Buffers from this size on are advised (a few huge pages; below, the faults are few anyway).
constexpr std::size_t kHugePageMinBytes = std::size_t{4} << 20;

/// Advises the kernel to back the 2 MiB-aligned part of [p, p + bytes) with huge pages; to be
/// called before the memory is first touched. Does nothing below kHugePageMinBytes or where the
/// system has no such advice.
void advise_huge_pages(void* p, std::size_t bytes);

/// Heap settings for a process that allocates and frees the same large buffers many times over
/// (sample vectors, per-block partials of every pass). glibc maps buffers of 128 kB and more
/// afresh each time and hands freed heap back to the system, so every pass paid its page faults
/// again (a fifth of the CPU of a 6,000-point fit). After this call freed memory stays with the
/// process, and the heap's first 64 MiB are backed by huge pages: a 6,000-point fit touches about
/// 400 fresh 4 KiB pages (10-20 us a fault on a virtual machine) against one 2 MiB page per 2 MiB
/// touched. For short-lived commands and benchmarks; call once, first thing in main(). Does
/// nothing outside glibc.
void keep_heap_for_batch_work();

/// std::allocator, except that a value constructed without arguments is default-initialised: a
/// resize of numbers leaves them unwritten. For large buffers that a single pass fills (a table
/// written bin by bin, a file read into memory), so that each byte is written once, by the pass
/// that owns it, and not first by the resize.
template <class T>
class DefaultInitAllocator : public std::allocator<T> {
  public:
    template <class U>
    struct rebind {
        using other = DefaultInitAllocator<U>;
    };
    DefaultInitAllocator() noexcept = default;
    template <class U>
    DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}

    template <class U>
    void construct(U* p) noexcept(std::is_nothrow_default_constructible<U>::value) {
        ::new (static_cast<void*>(p)) U;
    }
    template <class U, class... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
};

/// A vector whose resize() leaves numbers unwritten (see DefaultInitAllocator).
template <class T>
using UninitVector = std::vector<T, DefaultInitAllocator<T>>;

/// v.reserve(n) where v holds no storage yet: the storage is advised for huge pages. A plain
/// reserve when v already holds storage.
template <class T, class A>
void reserve_huge(std::vector<T, A>& v, std::size_t n) {
    const bool fresh = v.capacity() == 0;
    v.reserve(n);
    if (fresh) {
        advise_huge_pages(v.data(), v.capacity() * sizeof(T));
    }
}

/// v.resize(n, value) where v is empty and unallocated: the storage is advised for huge pages
/// before it is filled. Falls back to the plain resize when v already holds storage.
template <class T, class A>
void resize_huge(std::vector<T, A>& v, std::size_t n, const T& value = T()) {
    if (v.capacity() == 0) {
        reserve_huge(v, n);
    }
    v.resize(n, value);
}

/// v.resize(n) without writing the values of an UninitVector: the storage is advised for huge
/// pages and its pages are first touched by whoever writes the values.
template <class T>
void resize_huge_unwritten(UninitVector<T>& v, std::size_t n) {
    if (v.capacity() == 0) {
        reserve_huge(v, n);
    }
    v.resize(n);
}

}  // namespace gonio
