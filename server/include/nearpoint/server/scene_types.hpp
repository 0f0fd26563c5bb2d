// SPDX-License-Identifier: Apache-2.0
// The server's view of the scene model: the plain structs of nearpoint/model/scene_types.hpp
// (shared with the client and the file formats) under the names the server has always used, plus
// what only the server has: the report of one evaluation, which points at the scene it belongs to.
#pragma once

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "nearpoint/model/scene_types.hpp"

namespace nearpoint::server {

using Clock = std::chrono::steady_clock;
using model::Crossing;
using model::FlowControl;
using model::GeometryInfo;
using model::GeometryInput;
using model::ObjectInput;
using model::ObjectPoseInput;
using model::PairReport;
using model::PairSelectionInput;
using model::PairStatus;
using model::PenetrationMode;
using model::PieceInput;
using model::PolytopeInput;
using model::PoseInput;
using model::PoseUpdateInput;
using model::QueryInput;
using model::QueryOptionsInput;
using model::ReportCounts;
using model::ReportMode;
using model::ReportTiming;
using model::SceneInfo;
using model::SceneInput;
using model::ThresholdEvent;
using model::ThresholdInput;
using model::Vec3d;

class SceneDefinition;

struct Report {
  std::uint64_t sequence = 0;
  /// The scene the pairs belong to (its objects name `PairReport::object_a/b`).
  std::shared_ptr<const SceneDefinition> scene;
  std::vector<PairReport> pairs;
  ReportTiming timing;
  ReportCounts counts;
  /// The mode that chose `pairs` (see nearpoint.v1.ReportMode; never unspecified/unknown).
  ReportMode mode = ReportMode::all_pairs;
  std::uint32_t coalesced_updates = 0;
  std::uint64_t coalesced_from_sequence = 0;
  /// Threshold crossings, oldest update first, then in the scene's pair order; and the names of
  /// the stream's thresholds (`ThresholdEvent::threshold` indexes them; null without thresholds).
  std::vector<ThresholdEvent> events;
  std::shared_ptr<const std::vector<std::string>> threshold_names;
};

}  // namespace nearpoint::server
