// SPDX-License-Identifier: Apache-2.0
// sensor_msgs/JointState decoding and the --dds-joint-states binding (server/src/dds_joint_states).
#include <gtest/gtest.h>

#include <cmath>

#include "dds_joint_states.hpp"

namespace nearpoint::server {
namespace {

char* text_of(const char* s) {
  return const_cast<char*>(s);
}

struct Sample {
  std::vector<char*> names;
  std::vector<double> positions;
  sensor_msgs_msg_dds__JointState_ sample{};
  const sensor_msgs_msg_dds__JointState_& get() {
    sample.header.frame_id = text_of("");
    sample.name = {std::uint32_t(names.size()), std::uint32_t(names.size()), names.data(), false};
    sample.position = {std::uint32_t(positions.size()), std::uint32_t(positions.size()),
                       positions.data(), false};
    return sample;
  }
};

TEST(JointStates, DecodesNamesAndPositions) {
  Sample s{{text_of("a"), text_of("b")}, {0.5, -1.0}};
  Expected<JointPositions> decoded = decode_joint_state(s.get());
  ASSERT_TRUE(decoded);
  EXPECT_EQ(decoded->names, (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(decoded->positions, (std::vector<double>{0.5, -1.0}));
}

TEST(JointStates, RefusesWhatCannotBeApplied) {
  struct Case {
    Sample sample;
    const char* field;
  };
  std::vector<Case> cases = {
      {{{text_of("a"), text_of("b")}, {0.5}}, "joint_states.position"},
      {{{text_of("a"), text_of("")}, {0.5, 1}}, "joint_states.name[1]"},
      {{{text_of("a"), text_of("a")}, {0.5, 1}}, "joint_states.name[1]"},
      {{{text_of("a"), text_of("b")}, {0.5, NAN}}, "joint_states.position[1]"},
      {{{text_of("a")}, {INFINITY}}, "joint_states.position[0]"},
  };
  for (Case& c : cases) {
    Expected<JointPositions> decoded = decode_joint_state(c.sample.get());
    ASSERT_FALSE(decoded) << c.field;
    EXPECT_EQ(decoded.error().code, ErrorCode::invalid_argument);
    EXPECT_EQ(decoded.error().field, c.field) << decoded.error().message;
  }
}

TEST(JointStates, BindingsNameASceneAndARosTopic) {
  Expected<JointStateBinding> plain = parse_joint_state_binding("cell", "flag");
  ASSERT_TRUE(plain);
  EXPECT_EQ(plain->scene_id, "cell");
  EXPECT_EQ(plain->topic, "rt/joint_states");
  Expected<JointStateBinding> ros = parse_joint_state_binding("cell=/arm/joint_states", "flag");
  ASSERT_TRUE(ros);
  EXPECT_EQ(ros->topic, "rt/arm/joint_states");
  Expected<JointStateBinding> dds = parse_joint_state_binding("cell=rt/js", "flag");
  ASSERT_TRUE(dds);
  EXPECT_EQ(dds->topic, "rt/js");
  EXPECT_EQ(parse_joint_state_binding("cell=/a//b", "flag").error().field, "flag.topic");
  EXPECT_EQ(parse_joint_state_binding("cell=joint_states", "flag").error().field, "flag.topic");
  EXPECT_EQ(parse_joint_state_binding("=/joint_states", "flag").error().field, "flag.scene");
}

}  // namespace
}  // namespace nearpoint::server
