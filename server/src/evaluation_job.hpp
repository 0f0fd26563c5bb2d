// SPDX-License-Identifier: Apache-2.0
// One evaluation of a scene's pairs (a unary query's or a stream update's) as it travels through
// the worker pool: what SceneService::run plans, splits into tasks and completes.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "incremental.hpp"
#include "nearpoint/server/scene_service.hpp"

namespace nearpoint::server {

struct EvaluationJob {
  std::shared_ptr<const SceneDefinition> scene;
  std::vector<Pose<double>> poses;
  /// Robot scenes: the robot's state at `poses` (null otherwise).
  std::shared_ptr<const RobotUpdate> robot;
  ResolvedOptions options;
  /// The warm-start caches read and written (a stream's, or `own_caches`); empty: cold.
  std::span<SimplexCache> caches;
  std::vector<SimplexCache> own_caches;
  /// The stream's previous evaluation (a query's is fresh): results of unmoved pairs, boxes.
  std::shared_ptr<IncrementalState> state;
  /// The pairs (indices in scene->pairs) this evaluation hands to the engine.
  std::vector<std::uint32_t> evaluate;
  /// With thresholds: the absorbed updates' poses to replay, and the pairs the replay evaluated.
  std::vector<WatchStep> replay;
  std::vector<std::uint32_t> replayed_pairs;
  /// Whether `state` outlives the job (a stream's): then the report gets a copy of its results,
  /// else (a query's) they may be moved into the report.
  bool keep_state = true;
  Report report;
  Clock::time_point received;
  Clock::time_point started;
  std::atomic<std::size_t> next_pair{0};
  std::atomic<std::size_t> tasks_left{0};
  std::atomic<std::int64_t> geometry_ns{0};
  /// Runs once, on the pool thread that finishes the last pair.
  std::function<void(EvaluationJob&)> complete;
};

}  // namespace nearpoint::server
