// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the robot importers (robots/). The first byte picks the reader — 0: URDF,
// 1: MJCF, 2: SRDF applied to a small fixed URDF robot (mod 3) — and the rest is the file's text.
// Includes and meshes resolve against a directory that does not exist, and no mesh reader is
// given, so they are refusals. Invariants: no crash, hang or escaping exception; a refusal is a
// message naming the file (its label) of bounded length; an accepted robot is consistent — every
// object's geometry builds a valid compound, its pairs index its objects (i < j, sorted, no
// duplicates), forward kinematics at the neutral positions gives finite poses, and the
// joint-space gradient of a unit pose gradient is finite.
#include <cmath>
#include <cstdint>
#include <string>

#include "fuzz_support.hpp"
#include "nearpoint/robots/robot.hpp"

namespace {

using namespace nearpoint;

constexpr const char* kLabel = "fuzz-robot";

const robots::Robot& srdf_base() {
  static const robots::Robot robot = [] {
    robots::RobotImport imported = robots::parse_urdf(R"(<robot name="r">
      <link name="a"><collision><geometry><box size="1 1 1"/></geometry></collision></link>
      <link name="b"><collision><geometry><sphere radius="0.5"/></geometry></collision></link>
      <link name="c"><collision><geometry><cylinder radius="0.2" length="1"/></geometry></collision></link>
      <joint name="j1" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0 1"/>
        <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <joint name="j2" type="prismatic"><parent link="b"/><child link="c"/><origin xyz="0 0 1"/>
        <axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
    </robot>)",
                                                      "base.urdf", "/nonexistent-fuzz-dir");
    NEARPOINT_FUZZ_CHECK(imported.ok(), "the SRDF target's base robot: " + imported.error);
    return imported.robot;
  }();
  return robot;
}

void check_robot(const robots::Robot& robot) {
  const int n = static_cast<int>(robot.objects.size());
  for (const robots::RobotObject& object : robot.objects) {
    Compound<double> compound;
    const std::string why = robots::make_compound(object.geometry, compound);
    NEARPOINT_FUZZ_CHECK(why.empty(), "an accepted object has an unusable geometry: " + why);
    NEARPOINT_FUZZ_CHECK(
        object.link >= -1 && object.link < static_cast<int>(robot.tree.links.size()),
        "an object on no link");
    NEARPOINT_FUZZ_CHECK(std::isfinite(object.padding) && object.padding >= 0, "bad padding");
  }
  for (std::size_t k = 0; k < robot.pairs.size(); ++k) {
    const auto [a, b] = robot.pairs[k];
    NEARPOINT_FUZZ_CHECK(0 <= a && a < b && b < n, "a pair out of range or unordered");
    NEARPOINT_FUZZ_CHECK(k == 0 || robot.pairs[k - 1] < robot.pairs[k],
                         "pairs unsorted or repeated");
  }
  robots::KinematicState state;
  const std::string why = robot.tree.forward(robot.tree.neutral(), state);
  NEARPOINT_FUZZ_CHECK(why.empty(), "forward kinematics refused the neutral positions: " + why);
  for (const robots::Pose3d& pose : state.links)
    NEARPOINT_FUZZ_CHECK(pose.translation.allFinite() && pose.rotation.allFinite(),
                         "a non-finite link pose at the neutral positions");
  robots::Vec6d unit = robots::Vec6d::Ones();
  for (const auto& [a, b] : robot.pairs) {
    const Eigen::VectorXd g = robot.joint_gradient(state, a, unit, b, -unit);
    NEARPOINT_FUZZ_CHECK(g.size() == robot.tree.nv() && g.allFinite(), "a non-finite gradient");
    break;  // one pair is enough: the others take the same path
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const int kind = data[0] % 3;
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  robots::ImportOptions options;
  std::string error;
  robots::Robot robot;
  if (kind == 0 || kind == 1) {
    robots::RobotImport imported =
        kind == 0 ? robots::parse_urdf(text, kLabel, "/nonexistent-fuzz-dir", options)
                  : robots::parse_mjcf(text, kLabel, "/nonexistent-fuzz-dir", options);
    error = imported.error;
    robot = std::move(imported.robot);
  } else {
    robot = srdf_base();
    error = robots::apply_srdf(text, kLabel, robot);
  }
  if (!error.empty()) {
    NEARPOINT_FUZZ_CHECK(error.find(kLabel) != std::string::npos,
                         "a refusal that does not name the file: " + error);
    NEARPOINT_FUZZ_CHECK(error.size() <= 64 * 1024 + text.size(), "an unbounded message");
    return 0;
  }
  check_robot(robot);
  return 0;
}
