#pragma once

// Large buffers backed by transparent huge pages where the system offers them.
//
// Touching fresh memory costs one page fault per 4 KiB page; on a virtual machine a fault costs
// 10-20 us, so that filling a 35 MB MERL table took 140 ms of CPU in faults alone (3 ms with
// 2 MiB pages). Linux backs a range with huge pages on first touch once it is advised
// (madvise(MADV_HUGEPAGE); honoured when /sys/kernel/mm/transparent_hugepage/enabled is "always"
// or "madvise"). Elsewhere, and for small buffers, these are plain reserve/resize.

#include <cstddef>
#include <vector>

namespace gonio {

/// Buffers from this size on are advised (a few huge pages; below, the faults are few anyway).
constexpr std::size_t kHugePageMinBytes = std::size_t{4} << 20;

/// Advises the kernel to back the 2 MiB-aligned part of [p, p + bytes) with huge pages; to be
/// called before the memory is first touched. Does nothing below kHugePageMinBytes or where the
/// system has no such advice.
void advise_huge_pages(void* p, std::size_t bytes);

/// v.reserve(n) where v holds no storage yet: the storage is advised for huge pages. A plain
/// reserve when v already holds storage.
template <class T>
void reserve_huge(std::vector<T>& v, std::size_t n) {
    const bool fresh = v.capacity() == 0;
    v.reserve(n);
    if (fresh) {
        advise_huge_pages(v.data(), v.capacity() * sizeof(T));
    }
}

/// v.resize(n, value) where v is empty and unallocated: the storage is advised for huge pages
/// before it is filled. Falls back to the plain resize when v already holds storage.
template <class T>
void resize_huge(std::vector<T>& v, std::size_t n, const T& value = T()) {
    if (v.capacity() == 0) {
        reserve_huge(v, n);
    }
    v.resize(n, value);
}

}  // namespace gonio
