// SPDX-License-Identifier: Apache-2.0
// ReportEncoder (server/src/report_wire.hpp) against protobuf: for random reports (every optional
// part of a pair on or off, −0.0, NaN, infinities, denormals, values at every varint length,
// empty, long and non-ASCII ids, threshold events, a robot's joint gradients and limit
// violations), the bytes the encoder writes must be the bytes protobuf's own serialiser writes
// of to_proto(report), the message the server built before. And protobuf parses them back.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "nearpoint/server/scene_service.hpp"
#include "nearpoint_distance.pb.h"
#include "proto_convert.hpp"
#include "report_wire.hpp"
#include "robot_scene.hpp"

namespace {

using nearpoint::server::Report;
using nearpoint::server::ReportEncoder;
using nearpoint::server::SceneDefinition;
using nearpoint::server::SceneObject;
using nearpoint::server::SceneRobot;
namespace model = nearpoint::model;
namespace v1 = nearpoint::v1;

class RandomReports {
 public:
  explicit RandomReports(std::uint32_t seed) : rng_(seed) {
    auto scene = std::make_shared<SceneDefinition>();
    const char* ids[] = {"a", "", "mover", "κύβος", "part_12345678901234567890"};
    for (const char* id : ids) scene->objects.push_back(SceneObject{id, nullptr, {}});
    scene->objects.push_back(SceneObject{std::string(300, 'o'), nullptr, {}});  // 2-byte length
    plain_ = scene;
    auto with_robot = std::make_shared<SceneDefinition>(*scene);
    auto robot = std::make_shared<SceneRobot>();
    for (const char* name : {"shoulder", "elbow", "wrist_ball", ""}) {
      robot->tree.joints.emplace_back();
      robot->tree.joints.back().name = name;
    }
    robot->coordinates = {{0, 0}, {1, 0}, {2, 0}, {2, 1}, {2, 2}, {3, 0}};
    with_robot->robot = robot;
    robot_scene_ = with_robot;
  }

  Report report() {
    Report r;
    r.scene = flag() ? robot_scene_ : plain_;
    r.sequence = integer();
    r.pairs.resize(count(50));
    for (model::PairReport& p : r.pairs) pair(p);
    r.timing = {number(), number(), number(), number()};
    r.counts = {std::uint32_t(integer()), std::uint32_t(integer()), std::uint32_t(integer())};
    const model::ReportMode modes[] = {
        model::ReportMode::unspecified,    model::ReportMode::all_pairs,
        model::ReportMode::within_cutoff,  model::ReportMode::nearest_per_object,
        model::ReportMode::global_minimum, model::ReportMode::changed,
        model::ReportMode::unknown};
    r.mode = modes[rng_() % std::size(modes)];
    r.coalesced_updates = std::uint32_t(integer());
    r.coalesced_from_sequence = integer();
    if (flag()) {
      auto names = std::make_shared<std::vector<std::string>>();
      for (int i = 0; i < 3; ++i) names->push_back(i == 1 ? "" : "near_" + std::to_string(i));
      r.threshold_names = names;
    }
    r.events.resize(count(4));
    for (model::ThresholdEvent& e : r.events) {
      e.threshold = std::uint32_t(rng_() % 3);
      e.object_a = object(r);
      e.object_b = object(r);
      e.crossing = flag() ? model::Crossing::enter : model::Crossing::exit;
      e.distance = number();
      e.sequence = integer();
    }
    if (r.scene->robot) {
      r.joint_gradients.resize(rng_() % (r.pairs.size() + 1));  // some pairs without one
      for (auto& gradient : r.joint_gradients)
        for (std::size_t i = count(4); i > 0; --i)
          gradient.emplace_back(std::uint32_t(rng_() % 6), number());
      r.joint_limit_violations.resize(count(2));
      for (model::JointLimitViolation& v : r.joint_limit_violations)
        v = {flag() ? "elbow" : "", number(), number(), number()};
    }
    return r;
  }

 private:
  std::size_t count(std::size_t most) { return rng_() % (most + 1); }
  bool flag() { return rng_() & 1; }
  std::uint32_t object(const Report& r) { return std::uint32_t(rng_() % r.scene->objects.size()); }

  /// Zero half the time (proto3 leaves it out), else any length of varint.
  std::uint64_t integer() {
    if (flag()) return 0;
    return rng_() >> (rng_() % 64);
  }

  double number() {
    switch (rng_() % 10) {
      case 0:
        return 0.0;
      case 1:
        return -0.0;  // not zero bits: protobuf writes it
      case 2:
        return std::numeric_limits<double>::quiet_NaN();
      case 3:
        return std::numeric_limits<double>::infinity();
      case 4:
        return std::numeric_limits<double>::denorm_min();
      default:
        return std::uniform_real_distribution<double>(-10, 10)(rng_);
    }
  }

  model::Vec3d vector() { return {number(), number(), number()}; }

  void pair(model::PairReport& p) {
    p = model::PairReport{};
    p.object_a = std::uint32_t(rng_() % plain_->objects.size());
    p.object_b = std::uint32_t(rng_() % plain_->objects.size());
    const model::PairStatus statuses[] = {
        model::PairStatus::separated,     model::PairStatus::intersecting,
        model::PairStatus::beyond_cutoff, model::PairStatus::iteration_limit,
        model::PairStatus::engine_error,  model::PairStatus::touching};
    p.status = statuses[rng_() % std::size(statuses)];
    p.distance = number();
    p.distance_lower_bound = number();
    p.error_bound = number();
    p.iterations = std::uint32_t(integer());
    p.piece_pairs_evaluated = std::uint32_t(integer());
    p.piece_a = std::uint32_t(integer());
    p.piece_b = std::uint32_t(integer());
    p.warm_started = flag();
    if ((p.has_near_points = flag())) {
      p.point_a = vector();
      p.point_b = vector();
      p.normal = vector();
    }
    if ((p.has_penetration_bound = flag())) p.penetration_bound = number();
    if ((p.has_gradient = flag())) {
      for (int i = 0; i < 6; ++i) p.gradient_a[i] = number(), p.gradient_b[i] = number();
    }
    if (rng_() % 4 == 0) p.engine_message = flag() ? "the engine failed" : "";
    if ((p.has_signed_distance = flag())) {
      p.signed_distance = number();
      p.signed_distance_lower = number();
      p.signed_distance_upper = number();
    }
    if ((p.has_penetration_depth = flag())) {
      p.depth = number();
      p.depth_lower = number();
      p.depth_upper = number();
      p.depth_point_a = vector();
      p.depth_point_b = vector();
      p.depth_direction = vector();
      const model::DepthTermination ends[] = {
          model::DepthTermination::unspecified, model::DepthTermination::closed_form,
          model::DepthTermination::tolerance,   model::DepthTermination::iteration_limit,
          model::DepthTermination::degenerate,  model::DepthTermination::unknown};
      p.depth_termination = ends[rng_() % std::size(ends)];
      p.depth_iterations = std::uint32_t(integer());
    }
  }

  std::mt19937_64 rng_;
  std::shared_ptr<const SceneDefinition> plain_, robot_scene_;
};

std::string encoded(ReportEncoder& encoder, const Report& report) {
  std::string bytes(encoder.measure(report), '\0');
  auto* begin = reinterpret_cast<std::uint8_t*>(bytes.data());
  const std::uint8_t* end = encoder.write(report, begin);
  EXPECT_EQ(std::size_t(end - begin), bytes.size()) << "write() and measure() disagree";
  return bytes;
}

std::string by_protobuf(const Report& report) {
  v1::DistanceReport message;
  nearpoint::server::to_proto(report, message);
  std::string bytes;
  EXPECT_TRUE(message.SerializeToString(&bytes));
  return bytes;
}

TEST(ReportWire, RandomReportsAreTheBytesProtobufWrites) {
  RandomReports random(20261205);
  ReportEncoder encoder;  // one for all, as a stream has: reuse must not leak between reports
  int with_robot = 0, with_events = 0;
  for (int i = 0; i < 2000; ++i) {
    const Report report = random.report();
    with_robot += !report.joint_gradients.empty();
    with_events += !report.events.empty();
    ASSERT_EQ(encoded(encoder, report), by_protobuf(report)) << "report " << i;
  }
  EXPECT_GT(with_robot, 100);  // the random mix reached every part
  EXPECT_GT(with_events, 100);
}

TEST(ReportWire, ProtobufParsesWhatTheEncoderWrote) {
  RandomReports random(7);
  ReportEncoder encoder;
  for (int i = 0; i < 200; ++i) {
    const Report report = random.report();
    v1::DistanceReport parsed;
    ASSERT_TRUE(parsed.ParseFromString(encoded(encoder, report))) << "report " << i;
    EXPECT_EQ(parsed.sequence(), report.sequence);
    ASSERT_EQ(parsed.pairs_size(), int(report.pairs.size()));
    for (int k = 0; k < parsed.pairs_size(); ++k) {
      EXPECT_EQ(parsed.pairs(k).object_a(), report.scene->objects[report.pairs[k].object_a].id);
      EXPECT_EQ(parsed.pairs(k).has_near_points(), report.pairs[k].has_near_points);
    }
    EXPECT_EQ(parsed.events_size(), int(report.events.size()));
  }
}

TEST(ReportWire, AnEmptyReportIsItsTimingCountsAndMode) {
  Report report;
  report.scene = std::make_shared<SceneDefinition>();
  ReportEncoder encoder;
  const std::string bytes = encoded(encoder, report);
  EXPECT_EQ(bytes, by_protobuf(report));
  // timing (field 4) and counts (7) present and empty, report_mode (8) = all pairs.
  EXPECT_EQ(bytes, std::string("\x22\x00\x3a\x00\x40\x01", 6));
}

}  // namespace
