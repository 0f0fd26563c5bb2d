// SPDX-License-Identifier: Apache-2.0
// A fixed pool of threads that runs the geometry. The transports' threads only read, validate,
// convert and write; everything that calls the distance engine is posted here.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace nearpoint::server {

class WorkerPool {
 public:
  /// `threads` = 0 means one per hardware thread (at least one).
  explicit WorkerPool(std::size_t threads);
  /// Runs every task already posted, then joins the threads.
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  /// Queues a task; it runs on one of the pool's threads. The queue is not bounded here: its
  /// length is bounded by the callers (one evaluation per stream at a time, at most
  /// `max_concurrent_queries` queries, and at most `size()` tasks per evaluation).
  void post(std::function<void()> task);
  std::size_t size() const { return threads_.size(); }

 private:
  void run();

  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::function<void()>> tasks_;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace nearpoint::server
