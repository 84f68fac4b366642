// A small fixed pool of worker threads for the step (internal to the physics
// library). run(count, fn) calls fn(item, worker) once for every item in
// [0, count), spread over the pool's threads (the calling thread is worker 0),
// and returns when all are done. Which thread runs an item varies from run to
// run, so a caller keeps results deterministic by having each item write only
// its own slots (and per-worker scratch that carries nothing from one item to
// the next), then merging the slots in a fixed order (step_context.h's islands).
//
// How items are dealt: in one contiguous block per worker (worker w starts at
// block w; run's `cuts` may place the boundaries, e.g. by the items' weights),
// and a worker done with its own block takes items, one at a time, from the
// fronts of the others'. Each run over the same items gives each worker the
// same block again, so a stage finds most of its data in the core's cache that
// the stage before it wrote (handing items out in index order to whichever
// thread was free put neighbouring islands on different cores: on 2 cores the
// step's parallel work cost 20-35% more CPU time than on one).
//
// Between runs a worker spins for a while (kSpin) before it sleeps: a step
// runs about a dozen parallel loops with short serial parts between them, and
// waking a sleeping thread takes tens of microseconds, which the caller would
// wait for at every loop.
//
// Why a pool of our own rather than libtbb: the stages need nothing but a
// parallel loop over independent items; a plain pool has no nested
// parallelism or arena-dependent partitioning to reason about, needs no extra
// package, and runs clean under ThreadSanitizer.
#pragma once
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <functional>
#include <memory>
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
  // fn(item, worker), worker in [0, size()); the first exception thrown is rethrown here (the items not yet
  // started are skipped). cuts, when given, holds size() + 1 ascending item indices from 0 to count: worker w's
  // block is [cuts[w], cuts[w + 1]); without it the blocks are equal.
  void run(size_t count, const std::function<void(size_t, int)>& fn, const size_t* cuts = nullptr);

  // How long a worker spins for the next run before it sleeps.
  static constexpr std::chrono::microseconds kSpin{200};

 private:
  struct alignas(64) Block {
    std::atomic<size_t> next{0};
    size_t end = 0;
  };
  void work(int worker);
  void drain(int worker);
  bool waitForRun(unsigned long seen);
  std::vector<std::thread> workers_;
  std::unique_ptr<Block[]> blocks_;
  // The run: set before generation_ is bumped (release), read after it is seen (acquire).
  const std::function<void(size_t, int)>* job_ = nullptr;
  alignas(64) std::atomic<unsigned long> generation_{0};
  alignas(64) std::atomic<int> pending_{0};  // workers yet to finish the current run
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  int sleepers_ = 0;         // workers asleep on wake_ (under mutex_)
  bool callerAsleep_ = false;  // the caller asleep on done_ (under mutex_)
  std::exception_ptr error_;  // under mutex_
};

}  // namespace crumple::detail
