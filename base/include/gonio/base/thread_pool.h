#pragma once

// The project's one thread pool: started once (on first use) with one worker less than the
// machine's hardware threads, the calling thread being the last participant, and shared by every
// parallel pass (fits, table generation, resampling, CSV parsing).
//
// Work is split into chunks that depend only on the input size and the grain, never on the number
// of threads: a reduction that keeps one partial result per chunk and adds them in chunk order
// gives bit-identical results for 1, 2 or any number of threads. Inputs of at most one grain stay
// on the calling thread (no hand-off, no wake-up), which is faster for small work; so does
// everything when the pool has no worker or one thread is asked for.
//
// A parallel_for called from inside a chunk (a nested pass) runs its chunks on the calling thread;
// concurrent callers from different threads take turns. Chunk bodies must not throw.

#include <cstddef>
#include <functional>

namespace gonio {

/// How [0, n) is cut: `count` chunks of `size` elements (the last one shorter).
struct Chunking {
    std::size_t size = 0;
    std::size_t count = 0;
};

/// The chunks of [0, n) for a grain (the smallest chunk worth a hand-off, >= 1): at least one
/// grain per chunk and at most kMaxChunks chunks. Depends on n and grain only.
Chunking chunking(std::size_t n, std::size_t grain);

/// Most chunks one pass is cut into (enough to balance 2-64 threads).
constexpr std::size_t kMaxChunks = 64;

/// Threads the pool runs on, the calling thread included (>= 1).
int thread_pool_size();

/// The thread count a caller asked for: 0 means the whole pool, anything else is clamped to
/// [1, thread_pool_size()].
int resolve_threads(int requested);

/// Runs body(chunk, begin, end) for every chunk of chunking(n, grain), on up to `threads` threads
/// (0: all of the pool's). Returns when every chunk is done.
void parallel_for(
    std::size_t n,
    std::size_t grain,
    int threads,
    const std::function<void(std::size_t chunk, std::size_t begin, std::size_t end)>& body);

}  // namespace gonio
