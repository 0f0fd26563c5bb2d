// SPDX-License-Identifier: Apache-2.0
// Holds every thread of a SceneService's worker pool until released, so that a test can make
// "the server is slower than its client" happen for certain instead of hoping the engine is slow
// enough. Each worker is taken by a query on `scene_id` whose completion waits; the constructor
// returns once all of them are waiting. Released on destruction at the latest (an early ASSERT
// return must not leave the pool's destructor waiting forever).
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <future>
#include <memory>
#include <mutex>
#include <string>
#include <utility>

#include "nearpoint/server/scene_service.hpp"

namespace nearpoint::testkit {

class HeldWorkers {
 public:
  HeldWorkers(server::SceneService& service, const std::string& scene_id)
      : state_(std::make_shared<State>()) {
    state_->released = state_->release.get_future().share();
    model::QueryInput hold;
    hold.scene_id = scene_id;
    const std::size_t workers = service.worker_count();
    for (std::size_t i = 0; i < workers; ++i) {
      // The callback owns the state: it may run after this object is gone.
      const server::Outcome queued =
          service.query(hold, server::Clock::now(), [state = state_](server::Report) {
            {
              std::lock_guard lock(state->mutex);
              ++state->waiting;
            }
            state->changed.notify_all();
            state->released.wait();
          });
      EXPECT_TRUE(queued.ok()) << queued.error().describe();
      if (!queued.ok()) return;
    }
    std::unique_lock lock(state_->mutex);
    held_ = state_->changed.wait_for(lock, std::chrono::seconds(20),
                                     [&] { return state_->waiting == workers; });
    EXPECT_TRUE(held_) << "only " << state_->waiting << " of " << workers << " workers were taken";
  }
  ~HeldWorkers() { release(); }
  HeldWorkers(const HeldWorkers&) = delete;
  HeldWorkers& operator=(const HeldWorkers&) = delete;

  /// True once every worker waits here.
  bool held() const { return held_; }
  void release() {
    if (!std::exchange(released_once_, true)) state_->release.set_value();
  }

 private:
  struct State {
    std::mutex mutex;
    std::condition_variable changed;
    std::size_t waiting = 0;
    std::promise<void> release;
    std::shared_future<void> released;
  };
  std::shared_ptr<State> state_;
  bool held_ = false;
  bool released_once_ = false;
};

}  // namespace nearpoint::testkit
