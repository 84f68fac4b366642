// A small fixed pool of worker threads for the step (internal to the physics
// library). run(count, fn) calls fn(item, worker) once for every item in
// [0, count), spread over the pool's threads (the calling thread is worker 0),
// and returns when all are done. Items are handed out in index order to
// whichever thread is free: which thread runs an item varies from run to run,
// so a caller keeps results deterministic by having each item write only its
// own slots (and per-worker scratch that carries nothing from one item to the
// next), then merging the slots in a fixed order (step_context.h's islands).
//
// Why a pool of our own rather than libtbb: the stages need nothing but a
// parallel loop over independent items; a plain pool has no work stealing,
// nested parallelism or arena-dependent partitioning to reason about, needs
// no extra package, and runs clean under ThreadSanitizer.
#pragma once
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace crumple::detail {

class ThreadPool {
 public:
  // threads >= 1 in all, the caller's included (threads - 1 are started).
  explicit ThreadPool(int threads);
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;
  int size() const { return static_cast<int>(workers_.size()) + 1; }
  // fn(item, worker), worker in [0, size()); the first exception thrown is rethrown here.
  void run(size_t count, const std::function<void(size_t, int)>& fn);

 private:
  void work(int worker);
  // Takes items (an atomic counter: no lock per item) until none is left.
  void drain(const std::function<void(size_t, int)>* fn, size_t count, int worker);
  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(size_t, int)>* job_ = nullptr;
  size_t count_ = 0;
  std::atomic<size_t> next_{0};
  unsigned long generation_ = 0;
  int busy_ = 0;
  bool stop_ = false;
  std::exception_ptr error_;
};

}  // namespace crumple::detail
