// The project's thread pool (thread_pool.h): workers wait on a condition variable for a pass, take
// chunks from an atomic counter and report when the pass's last chunk is done.

#include "gonio/base/thread_pool.h"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

namespace gonio {

namespace {

/// Set on the pool's workers and on a caller while it runs a pass: a nested parallel_for runs
/// inline.
thread_local bool t_inside_pass = false;

class ThreadPool {
  public:
    explicit ThreadPool(int workers) {
        for (int w = 0; w < workers; ++w) {
            workers_.emplace_back([this] { work(); });
        }
    }

    ~ThreadPool() {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            stop_ = true;
        }
        wake_.notify_all();
        for (std::thread& t : workers_) {
            t.join();
        }
    }

    ThreadPool(const ThreadPool&) = delete;
    ThreadPool& operator=(const ThreadPool&) = delete;

    int size() const { return static_cast<int>(workers_.size()) + 1; }

    /// Runs the chunks on the caller and up to `helpers` workers.
    void run(const Chunking& c,
             std::size_t n,
             int helpers,
             const std::function<void(std::size_t, std::size_t, std::size_t)>& body) {
        std::lock_guard<std::mutex> turn(pass_mutex_);
        {
            std::lock_guard<std::mutex> lock(mutex_);
            body_ = &body;
            chunking_ = c;
            n_ = n;
            next_.store(0, std::memory_order_relaxed);
            pending_ = c.count;
            helpers_wanted_ = helpers;
            ++generation_;
        }
        wake_.notify_all();
        t_inside_pass = true;
        take_chunks();
        t_inside_pass = false;
        std::unique_lock<std::mutex> lock(mutex_);
        done_.wait(lock, [this] { return pending_ == 0 && active_ == 0; });
        // Workers that did not wake for this pass must not join a finished one.
        helpers_wanted_ = 0;
        body_ = nullptr;
    }

  private:
    void take_chunks() {
        std::size_t finished = 0;
        for (;;) {
            const std::size_t k = next_.fetch_add(1, std::memory_order_relaxed);
            if (k >= chunking_.count) {
                break;
            }
            const std::size_t b = k * chunking_.size;
            const std::size_t e = std::min(n_, b + chunking_.size);
            (*body_)(k, b, e);
            ++finished;
        }
        if (finished > 0) {
            std::lock_guard<std::mutex> lock(mutex_);
            pending_ -= finished;
            if (pending_ == 0) {
                done_.notify_all();
            }
        }
    }

    void work() {
        t_inside_pass = true;
        std::uint64_t seen = 0;
        std::unique_lock<std::mutex> lock(mutex_);
        for (;;) {
            wake_.wait(lock, [&] { return stop_ || (generation_ != seen && helpers_wanted_ > 0); });
            if (stop_) {
                return;
            }
            seen = generation_;
            --helpers_wanted_;
            ++active_;
            lock.unlock();
            take_chunks();
            lock.lock();
            --active_;
            if (pending_ == 0 && active_ == 0) {
                done_.notify_all();
            }
        }
    }

    std::vector<std::thread> workers_;
    std::mutex pass_mutex_;  // one pass at a time
    std::mutex mutex_;       // guards the fields below
    std::condition_variable wake_;
    std::condition_variable done_;
    bool stop_ = false;
    std::uint64_t generation_ = 0;
    int helpers_wanted_ = 0;
    int active_ = 0;
    std::size_t pending_ = 0;
    const std::function<void(std::size_t, std::size_t, std::size_t)>* body_ = nullptr;
    Chunking chunking_;
    std::size_t n_ = 0;
    std::atomic<std::size_t> next_{0};
};

ThreadPool& pool() {
    // Started once, on first use; hardware_concurrency() may not know (0): no worker then.
    static ThreadPool p(static_cast<int>(std::max(1u, std::thread::hardware_concurrency())) - 1);
    return p;
}

}  // namespace

Chunking chunking(std::size_t n, std::size_t grain) {
    Chunking c;
    if (n == 0) {
        return c;
    }
    grain = std::max<std::size_t>(grain, 1);
    c.size = std::max(grain, (n + kMaxChunks - 1) / kMaxChunks);
    c.count = (n + c.size - 1) / c.size;
    return c;
}

int thread_pool_size() {
    return pool().size();
}

int resolve_threads(int requested) {
    const int size = thread_pool_size();
    return requested <= 0 ? size : std::min(requested, size);
}

void parallel_for(std::size_t n,
                  std::size_t grain,
                  int threads,
                  const std::function<void(std::size_t, std::size_t, std::size_t)>& body) {
    const Chunking c = chunking(n, grain);
    if (c.count == 0) {
        return;
    }
    const int t = resolve_threads(threads);
    if (c.count == 1 || t == 1 || t_inside_pass) {
        // Small input, one thread asked for, or a nested pass: the chunks in order on this thread.
        for (std::size_t k = 0; k < c.count; ++k) {
            body(k, k * c.size, std::min(n, (k + 1) * c.size));
        }
        return;
    }
    const int helpers = static_cast<int>(std::min<std::size_t>(c.count, t) - 1);
    pool().run(c, n, helpers, body);
}

}  // namespace gonio
