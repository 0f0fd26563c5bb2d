// SPDX-License-Identifier: Apache-2.0
#include "nearpoint_dds.hpp"

#include <algorithm>
#include <cstdlib>
#include <string_view>

namespace nearpoint::dds {

QosPtr stream_qos(std::int32_t depth, bool best_effort) {
  QosPtr qos(dds_create_qos());
  dds_qset_reliability(qos.get(),
                       best_effort ? DDS_RELIABILITY_BEST_EFFORT : DDS_RELIABILITY_RELIABLE,
                       kMaxBlockingTime);
  dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, depth);
  dds_qset_durability(qos.get(), DDS_DURABILITY_VOLATILE);
  return qos;
}

QosPtr reader_qos(std::int32_t depth, bool best_effort) {
  return stream_qos(std::max(depth, kMinReaderHistoryDepth), best_effort);
}

std::string pose_updates_topic(const std::string& prefix) {
  return prefix + kPoseUpdatesSuffix;
}

std::string distance_reports_topic(const std::string& prefix) {
  return prefix + kDistanceReportsSuffix;
}

std::string threshold_events_topic(const std::string& prefix) {
  return prefix + kThresholdEventsSuffix;
}

std::string pose_update_batches_topic(const std::string& prefix) {
  return prefix + kPoseUpdateBatchesSuffix;
}

std::string distance_report_batches_topic(const std::string& prefix) {
  return prefix + kDistanceReportBatchesSuffix;
}

std::string check_ros_topic(const std::string& name) {
  if (!name.starts_with("rt/"))
    return "does not start with 'rt/' (ROS 2 topic /a/b is the DDS topic rt/a/b)";
  if (name.size() > 200) return "is longer than 200 characters";
  const std::string ros = name.substr(3);
  std::size_t start = 0;
  for (;;) {
    const std::size_t end = std::min(ros.find('/', start), ros.size());
    const std::string token = ros.substr(start, end - start);
    if (token.empty()) return "has an empty name token (ROS 2 names have no '//' or trailing '/')";
    if (token[0] >= '0' && token[0] <= '9')
      return "has the token '" + token + "', which starts with a digit (not a ROS 2 name)";
    for (const char c : token)
      if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_'))
        return std::string("contains '") + c + "' (ROS 2 names use letters, digits, '_' and '/')";
    if (end == ros.size()) return {};
    start = end + 1;
  }
}

std::string ros_topic_name(const std::string& dds_topic) {
  return dds_topic.starts_with("rt/") ? dds_topic.substr(2) : dds_topic;
}

std::string ros_type_name(const std::string& dds_type) {
  // pkg::msg::dds_::Name_ -> pkg/msg/Name
  constexpr std::string_view kDds = "::dds_::";
  const std::size_t dds = dds_type.find(kDds);
  if (dds == std::string::npos || !dds_type.ends_with('_')) return dds_type;
  std::string out = dds_type.substr(0, dds);
  for (std::size_t at = out.find("::"); at != std::string::npos; at = out.find("::"))
    out.replace(at, 2, "/");
  const std::size_t name = dds + kDds.size();
  return out + "/" + dds_type.substr(name, dds_type.size() - name - 1);
}

std::string check_topic_prefix(const std::string& prefix) {
  if (prefix.size() > 200) return "is longer than 200 characters";
  for (const char c : prefix) {
    const bool legal = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                       c == '_' || c == '/';
    if (!legal)
      return std::string("contains '") + c +
             "'; topic names here use letters, digits, '_' and '/' (ROS 2 names)";
  }
  return {};
}

std::string check_configuration(bool allow_default) {
  const char* uri = std::getenv("CYCLONEDDS_URI");
  if ((uri != nullptr && *uri != '\0') || allow_default) return {};
  return "CYCLONEDDS_URI is not set: without a configuration Cyclone DDS joins the external "
         "network interface and multicasts discovery off this machine. Set "
         "CYCLONEDDS_URI=file://$PWD/deploy/cyclonedds-loopback.xml (loopback only) or your own "
         "configuration; --dds-allow-default-config accepts Cyclone's defaults";
}

std::string describe(const char* what, dds_return_t code) {
  return std::string(what) + ": " + dds_strretcode(code);
}

std::string guid_hex(const std::uint8_t* guid) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  out.reserve(32);
  for (int i = 0; i < 16; ++i) {
    const std::uint8_t byte = guid[i];
    out.push_back(kDigits[byte >> 4]);
    out.push_back(kDigits[byte & 15]);
  }
  return out;
}

}  // namespace nearpoint::dds
