// SPDX-License-Identifier: Apache-2.0
#include "dds_joint_states.hpp"

#include <cmath>
#include <set>
#include <string_view>

#include "nearpoint_dds.hpp"
#include "validation.hpp"

namespace nearpoint::server {

Expected<JointStateBinding> parse_joint_state_binding(const std::string& spec,
                                                      const std::string& field) {
  JointStateBinding binding;
  const std::size_t equals = spec.find('=');
  binding.scene_id = spec.substr(0, equals);
  if (std::optional<Error> bad = check_id(binding.scene_id, field + ".scene")) return *bad;
  if (equals != std::string::npos) {
    std::string topic = spec.substr(equals + 1);
    if (topic.starts_with('/')) topic = "rt" + topic;  // a ROS 2 name
    binding.topic = std::move(topic);
  }
  if (std::string problem = dds::check_ros_topic(binding.topic); !problem.empty())
    return invalid_argument(field + ".topic", "'" + binding.topic + "' " + problem);
  return binding;
}

Expected<JointPositions> decode_joint_state(const sensor_msgs_msg_dds__JointState_& sample) {
  JointPositions out;
  if (sample.position._length != sample.name._length)
    return invalid_argument("joint_states.position",
                            text("holds ", sample.position._length, " values for ",
                                 sample.name._length, " names; a position is needed per name"));
  std::set<std::string_view> seen;
  out.names.reserve(sample.name._length);
  for (std::uint32_t i = 0; i < sample.name._length; ++i) {
    const char* name = sample.name._buffer[i];
    const std::string field = text("joint_states.name[", i, "]");
    const std::string_view view = name ? std::string_view(name) : std::string_view();
    if (view.empty()) return invalid_argument(field, "is empty");
    if (std::optional<Error> bad = check_name(view, field)) return *bad;
    if (!seen.insert(view).second) return invalid_argument(field, text("repeats '", view, "'"));
    out.names.emplace_back(view);
  }
  out.positions.reserve(sample.position._length);
  for (std::uint32_t i = 0; i < sample.position._length; ++i) {
    const double value = sample.position._buffer[i];
    if (!std::isfinite(value))
      return invalid_argument(text("joint_states.position[", i, "]"), "is not finite");
    out.positions.push_back(value);
  }
  return out;
}

}  // namespace nearpoint::server
