// SPDX-License-Identifier: Apache-2.0
#include "convert.hpp"

#include "nearpoint/model/vocabulary.hpp"

namespace nearpoint::client::detail {

void to_proto(const ObjectPose& pose, v1::ObjectPose& out) {
  out.set_object_id(pose.object_id);
  to_proto(to_pose_input(pose.rotation, pose.translation), *out.mutable_pose());
}

Status from_proto(const v1::UpdateError& error) {
  Status out = Status::error(int(error.code()), error.field().empty()
                                                    ? error.message()
                                                    : error.field() + ": " + error.message());
  if (out.code == 0) out.code = 2;  // UNKNOWN: an error report without a code
  return out;
}

Report from_proto(const v1::DistanceReport& report) {
  Report out;
  out.sequence = report.sequence();
  if (report.has_error()) {
    out.error = from_proto(report.error());
    out.error_field = report.error().field();
  }
  out.pairs.reserve(std::size_t(report.pairs_size()));
  for (const v1::PairDistance& p : report.pairs()) {
    PairDistance& pair = out.pairs.emplace_back();
    pair.object_a = p.object_a();
    pair.object_b = p.object_b();
    proto::from_proto(p, pair);
    pair.message = p.message();
    pair.joint_gradient.reserve(std::size_t(p.joint_gradient_size()));
    for (const v1::JointDerivative& d : p.joint_gradient())
      pair.joint_gradient.push_back({d.joint(), d.coordinate(), d.value()});
  }
  for (const v1::JointLimitViolation& v : report.joint_limit_violations())
    out.joint_limit_violations.push_back({v.joint(), v.position(), v.lower(), v.upper()});
  out.timing = from_proto(report.timing());
  out.coalesced_updates = report.coalesced_updates();
  out.coalesced_from_sequence = report.coalesced_from_sequence();
  out.counts = from_proto(report.counts());
  // An older server sends 0: its reports hold every pair.
  out.mode = model::from_wire<ReportMode>(report.report_mode());
  if (out.mode == ReportMode::unspecified || out.mode == ReportMode::unknown)
    out.mode = ReportMode::all_pairs;
  out.events.reserve(std::size_t(report.events_size()));
  for (const v1::ThresholdEvent& e : report.events())
    out.events.push_back(ThresholdEvent{e.threshold(), e.threshold_index(), e.object_a(),
                                        e.object_b(), model::from_wire<Crossing>(e.crossing()),
                                        e.distance(), e.sequence()});
  return out;
}

}  // namespace nearpoint::client::detail
