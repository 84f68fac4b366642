#include "physics/thread_pool.h"

namespace crumple::detail {

ThreadPool::ThreadPool(int threads) {
  for (int w = 1; w < threads; ++w) workers_.emplace_back([this, w] { work(w); });
}

ThreadPool::~ThreadPool() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  for (std::thread& t : workers_) t.join();
}

// Takes items until none is left (`lock` holds mutex_ on entry and on return).
void ThreadPool::drain(std::unique_lock<std::mutex>& lock, int worker) {
  while (next_ < count_) {
    const size_t item = next_++;
    const std::function<void(size_t, int)>* fn = job_;
    lock.unlock();
    std::exception_ptr error;
    try {
      (*fn)(item, worker);
    } catch (...) {
      error = std::current_exception();
    }
    lock.lock();
    if (error) {
      if (!error_) error_ = error;
      next_ = count_;  // the rest is skipped
    }
  }
}

void ThreadPool::work(int worker) {
  unsigned long seen = 0;
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
    if (stop_) return;
    seen = generation_;
    ++busy_;
    drain(lock, worker);
    if (--busy_ == 0) done_.notify_all();
  }
}

void ThreadPool::run(size_t count, const std::function<void(size_t, int)>& fn) {
  if (count == 0) return;
  if (workers_.empty() || count == 1) {
    for (size_t i = 0; i < count; ++i) fn(i, 0);
    return;
  }
  std::unique_lock<std::mutex> lock(mutex_);
  job_ = &fn;
  count_ = count;
  next_ = 0;
  error_ = nullptr;
  ++generation_;
  wake_.notify_all();
  drain(lock, 0);
  done_.wait(lock, [&] { return busy_ == 0; });
  job_ = nullptr;
  count_ = next_ = 0;
  std::exception_ptr error = error_;
  error_ = nullptr;
  lock.unlock();
  if (error) std::rethrow_exception(error);
}

}  // namespace crumple::detail
