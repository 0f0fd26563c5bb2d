// SPDX-License-Identifier: Apache-2.0
// The trajectory reader of `nearpoint stream`: both formats give the same steps, and every kind of
// malformed input is refused with a message naming its line.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "trajectory.hpp"

namespace nearpoint::cli {
namespace {

TEST(Trajectory, JsonLinesAndCsvGiveTheSameSteps) {
  const std::string jsonl =
      R"({"t": 0.0, "poses": {"arm": {"rotation": [1,0,0,0], "translation": [1,2,3]}, "cup": {}}})"
      "\n\n"
      R"({"t": 0.5, "poses": {"arm": {"rotation": [0,0,0,1], "translation": [4,5,6]}}})"
      "\n";
  const std::string csv =
      "t,object,tx,ty,tz,qw,qx,qy,qz\n"
      "0,arm,1,2,3,1,0,0,0\n"
      "0,cup,0,0,0,1,0,0,0\n"
      "# a comment\n"
      "0.5,arm,4,5,6,0,0,0,1\n";
  Trajectory a, b;
  std::string error;
  ASSERT_TRUE(parse_trajectory(jsonl, "a.jsonl", a, error)) << error;
  ASSERT_TRUE(parse_trajectory(csv, "b.csv", b, error)) << error;
  ASSERT_EQ(a.steps.size(), 2u);
  ASSERT_EQ(b.steps.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(a.steps[i].time, b.steps[i].time);
    ASSERT_EQ(a.steps[i].poses.size(), b.steps[i].poses.size());
    for (std::size_t k = 0; k < a.steps[i].poses.size(); ++k) {
      EXPECT_EQ(a.steps[i].poses[k].object_id, b.steps[i].poses[k].object_id);
      EXPECT_EQ(a.steps[i].poses[k].translation, b.steps[i].poses[k].translation);
      EXPECT_EQ(a.steps[i].poses[k].rotation_wxyz, b.steps[i].poses[k].rotation_wxyz);
    }
  }
  EXPECT_EQ(a.steps[0].poses.size(), 2u);
  EXPECT_EQ(a.steps[1].poses[0].translation, (std::array<double, 3>{4, 5, 6}));
}

TEST(Trajectory, MalformedInputNamesTheLine) {
  struct Case {
    std::string text, needle;
  };
  const Case cases[] = {
      {"{\"t\": 0, \"poses\": {}}\n{\"t\": \"x\", \"poses\": {}}\n", "f:2: \"t\" must be a number"},
      {"{\"t\": 0, \"poses\": {\"a\": {\"rotation\": [2,0,0,0]}}}\n", "f:1: rotation quaternion"},
      {"{\"t\": 1, \"poses\": {}}\n{\"t\": 0, \"poses\": {}}\n", "f:2: \"t\" decreases"},
      {"{\"t\": 0, \"poses\": {\"a\": {\"translate\": [0,0,0]}}}\n", "unknown key \"translate\""},
      {"{\"t\": 0}\n", "f:1: \"poses\" must be an object"},
      {"{not json\n", "f:1: not valid JSON"},
      {"t,object,x\n", "f:1: the header must be"},
      {"t,object,tx,ty,tz,qw,qx,qy,qz\n0,a,1,2,3,1,0,0\n", "f:2: expected 9 columns"},
      {"t,object,tx,ty,tz,qw,qx,qy,qz\n0,a,1,nan,3,1,0,0,0\n", "f:2: column \"ty\""},
      {"t,object,tx,ty,tz,qw,qx,qy,qz\n0,a,1,2,3,1,0,0,0\n0,a,1,2,3,1,0,0,0\n",
       "f:3: object \"a\" appears twice"},
      {"   \n", "empty"},
  };
  for (const Case& c : cases) {
    Trajectory out;
    std::string error;
    EXPECT_FALSE(parse_trajectory(c.text, "f", out, error)) << c.text;
    EXPECT_NE(error.find(c.needle), std::string::npos) << "got: " << error << "\nfor: " << c.text;
  }
}

TEST(Trajectory, LoadReportsAMissingFile) {
  Trajectory out;
  std::string error;
  EXPECT_FALSE(load_trajectory("/nonexistent/trajectory.csv", out, error));
  EXPECT_NE(error.find("cannot open /nonexistent/trajectory.csv"), std::string::npos) << error;
}

}  // namespace
// Robot steps (`nearpoint stream --joints`): joint positions by name, a number or an array, and
// an optional base pose; malformed joints are refused naming the line and the joint.
TEST(Trajectory, JointStepsCarryPositionsByNameAndABasePose) {
  const std::string jsonl =
      R"({"t": 0.0, "joints": {"joint1": 0.5, "ball": [1, 0, 0, 0]}})"
      "\n"
      R"({"t": 0.1, "joints": {"joint1": -0.5}, "base": {"translation": [1, 2, 3]}})"
      "\n";
  Trajectory trajectory;
  std::string error;
  ASSERT_TRUE(parse_trajectory(jsonl, "j.jsonl", trajectory, error)) << error;
  ASSERT_EQ(trajectory.steps.size(), 2u);
  const TrajectoryStep& first = trajectory.steps[0];
  EXPECT_TRUE(first.poses.empty());
  ASSERT_EQ(first.joints.size(), 2u);
  EXPECT_FALSE(first.has_base);
  const std::vector<double> one{0.5}, quaternion{1, 0, 0, 0};
  for (const auto& [name, values] : first.joints)
    EXPECT_EQ(values, name == "joint1" ? one : quaternion);
  const TrajectoryStep& second = trajectory.steps[1];
  EXPECT_EQ(second.time, 0.1);
  ASSERT_EQ(second.joints.size(), 1u);
  EXPECT_EQ(second.joints[0].second, (std::vector<double>{-0.5}));
  EXPECT_TRUE(second.has_base);
  EXPECT_EQ(second.base.translation, (std::array<double, 3>{1, 2, 3}));

  for (const auto& [text, says] :
       {std::pair{R"({"joints": {"joint1": "up"}})", "joints.joint1"},
        std::pair{R"({"joints": {"joint1": [0.1, "x"]}})", "joints.joint1"},
        std::pair{R"({"joints": [0.1]})", "\"joints\" must be an object"},
        std::pair{R"({"joints": {}, "base": {"rotation": [2, 0, 0, 0]}})", "unit length"},
        std::pair{R"({"joints": {}, "base": {"scale": 2}})", "unknown key \"scale\""},
        std::pair{R"({"t": 0})", "\"poses\" must be an object"}}) {
    Trajectory refused;
    EXPECT_FALSE(parse_trajectory(text, "bad.jsonl", refused, error)) << text;
    EXPECT_NE(error.find("bad.jsonl"), std::string::npos) << error;
    EXPECT_NE(error.find(says), std::string::npos) << error;
  }
}

}  // namespace nearpoint::cli
