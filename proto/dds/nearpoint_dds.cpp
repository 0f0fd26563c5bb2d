// SPDX-License-Identifier: Apache-2.0
#include "nearpoint_dds.hpp"

#include <cstdlib>

namespace nearpoint::dds {

QosPtr stream_qos() {
  QosPtr qos(dds_create_qos());
  dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, kMaxBlockingTime);
  dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, kHistoryDepth);
  dds_qset_durability(qos.get(), DDS_DURABILITY_VOLATILE);
  return qos;
}

std::string pose_updates_topic(const std::string& prefix) {
  return prefix + kPoseUpdatesSuffix;
}

std::string distance_reports_topic(const std::string& prefix) {
  return prefix + kDistanceReportsSuffix;
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
