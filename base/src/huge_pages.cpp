// Huge-page advice for large buffers (huge_pages.h).

#include "gonio/base/huge_pages.h"

#include <cstdint>
#include <cstdlib>

#if defined(__linux__)
#include <sys/mman.h>
#endif
#if defined(__GLIBC__)
#include <malloc.h>
#include <unistd.h>
#endif

namespace gonio {

void advise_huge_pages(void* p, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    if (p == nullptr || bytes < kHugePageMinBytes) {
        return;
    }
    constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
    const std::uintptr_t begin = reinterpret_cast<std::uintptr_t>(p);
    const std::uintptr_t first = (begin + kHuge - 1) & ~(kHuge - 1);
    const std::uintptr_t last = (begin + bytes) & ~(kHuge - 1);
    if (last > first) {
        // Advice only: a refusal (no transparent huge pages) leaves ordinary pages.
        (void)madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);
    }
#else
    (void)p;
    (void)bytes;
#endif
}

void keep_heap_for_batch_work() {
#if defined(__GLIBC__)
    mallopt(M_MMAP_THRESHOLD, 256 << 20);
    mallopt(M_TRIM_THRESHOLD, 512 << 20);
    mallopt(M_TOP_PAD, 64 << 20);
    // Grow the heap by the pad once, advise it, and keep it (the trim threshold above).
    if (void* first = std::malloc(std::size_t{8} << 20)) {
        char* const top = static_cast<char*>(sbrk(0));
        if (top > static_cast<char*>(first)) {
            advise_huge_pages(first, static_cast<std::size_t>(top - static_cast<char*>(first)));
        }
        std::free(first);
    }
#endif
}

}  // namespace gonio
