// The project's thread pool: every index visited once, chunks fixed by size and grain alone, small
// inputs on the calling thread, nested passes, and reductions identical for any thread count.

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <random>
#include <thread>
#include <vector>

#include "gonio/base/thread_pool.h"

namespace gonio {
namespace {

TEST(ThreadPool, ChunkingDependsOnSizeAndGrainOnly) {
    EXPECT_EQ(chunking(0, 100).count, 0u);
    const Chunking one = chunking(100, 100);
    EXPECT_EQ(one.count, 1u);
    EXPECT_EQ(one.size, 100u);
    const Chunking small_grain = chunking(1000, 1);
    EXPECT_EQ(small_grain.count, 63u);  // ceil(1000 / ceil(1000 / 64)) = ceil(1000 / 16)
    EXPECT_EQ(small_grain.size, 16u);
    const Chunking big = chunking(1000000, 4096);
    EXPECT_EQ(big.size, 15625u);  // 1e6 / 64 > grain
    EXPECT_EQ(big.count, 64u);
    // The grain of 0 is taken as 1.
    EXPECT_EQ(chunking(5, 0).count, 5u);
}

TEST(ThreadPool, EveryIndexOnceInItsChunk) {
    for (std::size_t n : {1u, 7u, 4096u, 100003u}) {
        for (int threads : {0, 1, 2}) {
            std::vector<std::atomic<int>> hits(n);
            const Chunking c = chunking(n, 64);
            std::atomic<std::size_t> chunks_seen{0};
            parallel_for(n, 64, threads, [&](std::size_t chunk, std::size_t b, std::size_t e) {
                EXPECT_EQ(b, chunk * c.size);
                EXPECT_EQ(e, std::min(n, b + c.size));
                for (std::size_t i = b; i < e; ++i) {
                    hits[i].fetch_add(1);
                }
                chunks_seen.fetch_add(1);
            });
            EXPECT_EQ(chunks_seen.load(), c.count) << "n " << n << " threads " << threads;
            for (std::size_t i = 0; i < n; ++i) {
                ASSERT_EQ(hits[i].load(), 1) << "index " << i << " n " << n;
            }
        }
    }
}

TEST(ThreadPool, InputOfOneGrainStaysOnTheCallingThread) {
    const std::thread::id caller = std::this_thread::get_id();
    std::thread::id ran_on;
    parallel_for(1000, 1000, 0, [&](std::size_t, std::size_t, std::size_t) {
        ran_on = std::this_thread::get_id();
    });
    EXPECT_EQ(ran_on, caller);
}

TEST(ThreadPool, NestedPassesComplete) {
    std::atomic<long> total{0};
    parallel_for(64, 1, 0, [&](std::size_t, std::size_t b, std::size_t e) {
        for (std::size_t i = b; i < e; ++i) {
            parallel_for(100, 10, 0, [&](std::size_t, std::size_t ib, std::size_t ie) {
                total.fetch_add(static_cast<long>(ie - ib));
            });
        }
    });
    EXPECT_EQ(total.load(), 6400);
}

TEST(ThreadPool, ChunkedReductionIsIdenticalForOneAndTwoThreads) {
    // Terms of very different magnitudes, so that the order of additions shows in the result.
    const std::uint32_t seed = 12345;
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-30, 30);
    std::vector<double> x(300001);
    for (double& v : x) {
        v = std::exp(u(rng)) * (u(rng) < 0 ? -1 : 1);
    }
    auto sum = [&](int threads) {
        const Chunking c = chunking(x.size(), 1024);
        std::vector<double> partial(c.count, 0.0);
        parallel_for(x.size(), 1024, threads, [&](std::size_t chunk, std::size_t b, std::size_t e) {
            double s = 0;
            for (std::size_t i = b; i < e; ++i) {
                s += x[i];
            }
            partial[chunk] = s;
        });
        double total = 0;
        for (double p : partial) {
            total += p;
        }
        return total;
    };
    const double one = sum(1);
    for (int rep = 0; rep < 20; ++rep) {
        EXPECT_EQ(sum(2), one) << "seed " << seed << " repetition " << rep;
        EXPECT_EQ(sum(0), one) << "seed " << seed << " repetition " << rep;
    }
}

TEST(ThreadPool, ResolveThreadsClampsToThePool) {
    EXPECT_GE(thread_pool_size(), 1);
    EXPECT_EQ(resolve_threads(0), thread_pool_size());
    EXPECT_EQ(resolve_threads(-3), thread_pool_size());
    EXPECT_EQ(resolve_threads(1), 1);
    EXPECT_EQ(resolve_threads(1000), thread_pool_size());
}

}  // namespace
}  // namespace gonio
