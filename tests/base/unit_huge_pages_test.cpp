// Huge-page advice (base/huge_pages.h): the helpers behave as reserve/resize whatever the system
// does with the advice, for large and small buffers and for vectors that already hold storage.

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <vector>

#if defined(__GLIBC__)
#include <unistd.h>
#endif

#include "gonio/base/huge_pages.h"

namespace gonio {
namespace {

TEST(HugePages, ResizeOfALargeFreshVectorFillsEveryElement) {
    std::vector<double> v;
    const std::size_t n = (kHugePageMinBytes / sizeof(double)) * 3 + 12345;
    resize_huge(v, n, -1.0);
    ASSERT_EQ(v.size(), n);
    std::size_t wrong = 0;
    for (double x : v) {
        wrong += x != -1.0 ? 1 : 0;
    }
    EXPECT_EQ(wrong, 0u);
    v[n - 1] = 2.5;
    EXPECT_EQ(v[n - 1], 2.5);
}

TEST(HugePages, SmallAndAlreadyAllocatedVectorsKeepTheirContents) {
    std::vector<std::uint8_t> small;
    resize_huge(small, 100, std::uint8_t{7});
    ASSERT_EQ(small.size(), 100u);
    EXPECT_EQ(small[99], 7);
    std::vector<int> held = {1, 2, 3};
    reserve_huge(held, kHugePageMinBytes);
    ASSERT_EQ(held.size(), 3u);
    EXPECT_EQ(held[2], 3);
    EXPECT_GE(held.capacity(), kHugePageMinBytes);
    resize_huge(held, 5, 9);
    EXPECT_EQ(held[2], 3);
    EXPECT_EQ(held[4], 9);
}

TEST(HugePages, AdviceOnAnyRangeIsHarmless) {
    std::vector<char> buf(kHugePageMinBytes * 2 + 3, 'a');
    // Unaligned start and end, a range too small, a null pointer: advice only, contents kept.
    advise_huge_pages(buf.data() + 1, buf.size() - 2);
    advise_huge_pages(buf.data(), 10);
    advise_huge_pages(nullptr, kHugePageMinBytes * 4);
    EXPECT_EQ(buf[0], 'a');
    EXPECT_EQ(buf[buf.size() / 2], 'a');
    EXPECT_EQ(buf.back(), 'a');
}

#if defined(__SANITIZE_ADDRESS__)
#define GONIO_TEST_OWN_MALLOC 0  // the sanitizer's allocator ignores glibc's settings
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define GONIO_TEST_OWN_MALLOC 0
#endif
#endif
#ifndef GONIO_TEST_OWN_MALLOC
#define GONIO_TEST_OWN_MALLOC 1
#endif

TEST(HugePages, KeptHeapServesLargeBuffersFromTheHeapAndKeepsThemAfterFree) {
#if defined(__GLIBC__) && GONIO_TEST_OWN_MALLOC
    keep_heap_for_batch_work();
    // 100 MiB is above glibc's largest automatic mmap threshold (32 MiB), so without the setting
    // it would be a mapping of its own, far above the heap's top.
    const std::size_t bytes = std::size_t{100} << 20;
    char* const p = static_cast<char*>(std::malloc(bytes));
    ASSERT_NE(p, nullptr);
    char* const top = static_cast<char*>(sbrk(0));
    EXPECT_LE(p + bytes, top) << "a 100 MiB buffer was mapped apart from the heap";
    std::free(p);
    // Freed, it stays with the process: the heap's top does not come down (trim threshold).
    EXPECT_EQ(static_cast<char*>(sbrk(0)), top);
#else
    GTEST_SKIP()
        << "not glibc's own allocator (a sanitizer's or another libc's): the kept-heap settings "
           "are glibc's";
#endif
}

}  // namespace
}  // namespace gonio
