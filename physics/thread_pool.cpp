#include <crumple/physics/thread_pool.h>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace crumple::detail {

namespace {
// A hint to the core that this thread is spinning (frees the pipeline for a sibling thread).
inline void relax() {
#if defined(__x86_64__) || defined(__i386__)
  _mm_pause();
#elif defined(__aarch64__)
  asm volatile("yield");
#else
  std::this_thread::yield();
#endif
}

// Spins until done() or kSpin has passed; true when done() came first.
template <class Done>
bool spinFor(Done&& done) {
  const auto until = std::chrono::steady_clock::now() + ThreadPool::kSpin;
  for (unsigned k = 1;; ++k) {
    if (done()) return true;
    // A short spin, then the core offered to any other thread ready to run (more threads than cores: a
    // spinning thread would hold up the one it waits for).
    if (k < 256) {
      relax();
    } else {
      std::this_thread::yield();
    }
    if (k % 64 == 0 && std::chrono::steady_clock::now() > until) return done();
  }
}
}  // namespace

ThreadPool::ThreadPool(int threads) : blocks_(new Block[static_cast<size_t>(threads > 1 ? threads : 1)]) {
  for (int w = 1; w < threads; ++w) workers_.emplace_back([this, w] { work(w); });
}

ThreadPool::~ThreadPool() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_.store(true, std::memory_order_release);
  }
  wake_.notify_all();
  for (std::thread& t : workers_) t.join();
}

bool ThreadPool::waitForRun(unsigned long seen) {
  auto ready = [&] {
    return generation_.load(std::memory_order_acquire) != seen || stop_.load(std::memory_order_acquire);
  };
  if (!spinFor(ready)) {
    std::unique_lock<std::mutex> lock(mutex_);
    ++sleepers_;
    wake_.wait(lock, ready);
    --sleepers_;
  }
  return !stop_.load(std::memory_order_acquire);
}

void ThreadPool::drain(int worker) {
  const size_t threads = static_cast<size_t>(size());
  for (size_t k = 0; k < threads; ++k) {
    Block& block = blocks_[(static_cast<size_t>(worker) + k) % threads];
    for (;;) {
      const size_t item = block.next.fetch_add(1, std::memory_order_relaxed);
      if (item >= block.end) break;
      try {
        (*job_)(item, worker);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!error_) error_ = std::current_exception();
        for (size_t b = 0; b < threads; ++b) blocks_[b].next.store(blocks_[b].end, std::memory_order_relaxed);
      }
    }
  }
}

void ThreadPool::work(int worker) {
  unsigned long seen = 0;
  while (waitForRun(seen)) {
    seen = generation_.load(std::memory_order_acquire);
    drain(worker);
    if (pending_.fetch_sub(1, std::memory_order_acq_rel) == 1) {
      std::lock_guard<std::mutex> lock(mutex_);
      if (callerAsleep_) done_.notify_one();
    }
  }
}

void ThreadPool::run(size_t count, const std::function<void(size_t, int)>& fn, const size_t* cuts) {
  if (count == 0) return;
  if (workers_.empty() || count == 1) {
    for (size_t i = 0; i < count; ++i) fn(i, 0);
    return;
  }
  const size_t threads = static_cast<size_t>(size());
  for (size_t w = 0; w < threads; ++w) {
    blocks_[w].next.store(cuts ? cuts[w] : w * count / threads, std::memory_order_relaxed);
    blocks_[w].end = cuts ? cuts[w + 1] : (w + 1) * count / threads;
  }
  job_ = &fn;
  pending_.store(static_cast<int>(workers_.size()), std::memory_order_relaxed);
  generation_.fetch_add(1, std::memory_order_release);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (sleepers_ > 0) wake_.notify_all();
  }
  drain(0);
  auto finished = [&] { return pending_.load(std::memory_order_acquire) == 0; };
  std::exception_ptr error;
  {
    const bool spun = spinFor(finished);
    std::unique_lock<std::mutex> lock(mutex_);
    if (!spun) {
      callerAsleep_ = true;
      done_.wait(lock, finished);
      callerAsleep_ = false;
    }
    error = error_;
    error_ = nullptr;
  }
  job_ = nullptr;
  if (error) std::rethrow_exception(error);
}

}  // namespace crumple::detail
