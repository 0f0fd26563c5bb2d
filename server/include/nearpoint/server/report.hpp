// SPDX-License-Identifier: Apache-2.0
// What only the server has beside the scene model (nearpoint/model/scene_types.hpp, whose types
// it names as model::…): the report of one evaluation, which points at the scene it belongs to.
#pragma once

#include <chrono>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "nearpoint/model/scene_types.hpp"

namespace nearpoint::server {

using Clock = std::chrono::steady_clock;

class SceneDefinition;

struct Report {
  std::uint64_t sequence = 0;
  /// The scene the pairs belong to (its objects name `PairReport::object_a/b`).
  std::shared_ptr<const SceneDefinition> scene;
  std::vector<model::PairReport> pairs;
  model::ReportTiming timing;
  model::ReportCounts counts;
  /// The mode that chose `pairs` (see nearpoint.v1.ReportMode; never unspecified/unknown).
  model::ReportMode mode = model::ReportMode::all_pairs;
  std::uint32_t coalesced_updates = 0;
  std::uint64_t coalesced_from_sequence = 0;
  /// Threshold crossings, oldest update first, then in the scene's pair order; and the names of
  /// the stream's thresholds (`ThresholdEvent::threshold` indexes them; null without thresholds).
  std::vector<model::ThresholdEvent> events;
  std::shared_ptr<const std::vector<std::string>> threshold_names;
  /// Robot scenes with gradients: per entry of `pairs`, its ∂d/∂q as (velocity coordinate of the
  /// scene's robot, value) for the coordinates that move one of its objects; empty for others.
  std::vector<std::vector<std::pair<std::uint32_t, double>>> joint_gradients;
  /// Robot scenes: the joints outside their limits at this update's positions.
  std::vector<model::JointLimitViolation> joint_limit_violations;
};

}  // namespace nearpoint::server
