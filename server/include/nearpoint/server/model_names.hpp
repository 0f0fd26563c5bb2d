// SPDX-License-Identifier: Apache-2.0
// Transitional: the scene model's types under nearpoint::server:: (the same types, not copies),
// for the fuzz harnesses in tests/fuzz and the service benchmarks in bench/service, which still
// spell them server::…. The server, the other tests (both built with
// NEARPOINT_SERVER_NO_MODEL_NAMES) and every other layer name them model::…; remove this header
// once those two do too.
#pragma once

#include "nearpoint/model/scene_types.hpp"

namespace nearpoint::server {

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

}  // namespace nearpoint::server
