// SPDX-License-Identifier: Apache-2.0
// A stand-in for a ROS 2 node on rmw_cyclonedds, for tests/ros/test_ros_peer.cpp: a plain
// Cyclone DDS participant whose types come from rosidl's own IDL of the .msg files
// (tests/ros/peer/make_types.sh), not from nearpoint's generated IDL, and whose endpoints are
// what a ROS 2 node makes: the topics rt/<ROS name>, ROS 2's default QoS (reliable, keep last 10,
// volatile). It shares no code with nearpoint.
//
//   ros_peer DOMAIN SCENE X,Y,THETA...
// publishes one nearpoint_msgs/PoseUpdate per X,Y,THETA (the object "mover" at (X, Y, 0) turned
// by THETA about z) on rt/nearpoint/pose_updates, waits for each DistanceReport on
// rt/nearpoint/distance_reports, and prints one JSON line per report:
//   {"sequence": N, "status": S, "stamp_sec": N, "pairs": {"a/b": [distance, error_bound], ...}}
// then one line per endpoint of other participants seen by discovery:
//   {"endpoint": "publication"|"subscription", "topic": "...", "type": "..."}
//
//   ros_peer DOMAIN SCENE --batches K X,Y,THETA...
// the same updates, sequence numbers and output, but published K at a time as
// nearpoint_msgs/PoseUpdateBatch samples on rt/nearpoint/pose_update_batches, and the reports read
// from nearpoint_msgs/DistanceReportBatch samples on rt/nearpoint/distance_report_batches (then
// the discovery lines as above).
//
//   ros_peer DOMAIN SCENE --joint-states
// publishes three sensor_msgs/JointState samples on rt/joint_states (two well formed, then one
// with fewer positions than names) and prints, per DistanceReport addressed to that writer:
//   {"sequence": N, "status": S, "scene_id": "...", "client_id": "...", "error_field": "...",
//    "stamp_sec": N}
//
//   ros_peer DOMAIN SCENE --joint-steps NAME=V,NAME=V... ...
// publishes one JointState per step on rt/joint_states, waits for each report and prints it as
// the pose mode does ({"sequence", "status", "stamp_sec", "message", "pairs"}).
//
//   ros_peer DOMAIN SCENE --joint-pipeline STEP...
// as --joint-steps, but publishes every step at once (a step "BAD" is a JointState with two
// names and one position) and prints the reports addressed to it in the order they arrive:
//   {"sequence": N, "status": S, "error_field": "..."}
//
//   ros_peer DOMAIN SCENE --wrong-type
// publishes a sensor_msgs/JointState on rt/nearpoint/pose_updates (a peer built from other
// message definitions), waits 3 s and prints {"reports": N}: the reports addressed to it.
// Exit status 0, or 1 with the reason on stderr.
#include <dds/dds.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <set>
#include <string>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include "nearpoint_msgs/msg/DistanceReport.h"
#include "nearpoint_msgs/msg/DistanceReportBatch.h"
#include "nearpoint_msgs/msg/PoseUpdate.h"
#include "nearpoint_msgs/msg/PoseUpdateBatch.h"
#include "sensor_msgs/msg/JointState.h"

namespace {

int fail(const std::string& why) {
  std::fprintf(stderr, "ros_peer: %s\n", why.c_str());
  return 1;
}

dds_qos_t* ros_default_qos() {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 10);
  dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
  return qos;
}

std::string json_string(const char* s) {
  std::string out = "\"";
  for (const char* p = s ? s : ""; *p; ++p) {
    if (*p == '"' || *p == '\\') out += '\\';
    out += *p;
  }
  return out + "\"";
}

/// One report as the pose modes print it: {"sequence", "status", "stamp_sec", "message", "pairs"}.
std::string report_line(const nearpoint_msgs_msg_dds__DistanceReport_& report) {
  std::string line = "{\"sequence\": " + std::to_string(report.sequence_number) +
                     ", \"status\": " + std::to_string(report.status) +
                     ", \"stamp_sec\": " + std::to_string(report.header.stamp.sec) +
                     ", \"message\": " + json_string(report.message) + ", \"pairs\": {";
  for (uint32_t i = 0; i < report.pairs._length; ++i) {
    const auto& p = report.pairs._buffer[i];
    char numbers[80];
    std::snprintf(numbers, sizeof numbers, "[%.17g, %.17g]", p.distance, p.error_bound);
    line += (i ? ", " : "") + json_string((std::string(p.object_a) + "/" + p.object_b).c_str()) +
            ": " + numbers;
  }
  return line + "}}";
}

/// The PoseUpdate moving "mover" to (x, y, 0) turned by theta about z, stamped 1000 + k - 1 with
/// sequence number k; `pose` is the storage its poses sequence points to.
nearpoint_msgs_msg_dds__PoseUpdate_ mover_update(std::string& scene, std::size_t k, double x,
                                                 double y, double theta,
                                                 nearpoint_msgs_msg_dds__ObjectPose_& pose) {
  pose = {};
  pose.object_id = const_cast<char*>("mover");
  pose.pose.position = {x, y, 0};
  pose.pose.orientation = {0, 0, std::sin(theta / 2), std::cos(theta / 2)};
  nearpoint_msgs_msg_dds__PoseUpdate_ update{};
  update.header.stamp = {int32_t(999 + k), 0};
  update.header.frame_id = const_cast<char*>("world");
  update.scene_id = scene.data();
  update.client_id = const_cast<char*>("ros_peer");
  update.sequence_number = k;
  update.poses = {1, 1, &pose, false};
  update.thresholds = {0, 0, nullptr, false};
  return update;
}

/// Joint names and their positions, one JointState.
using JointStep = std::pair<std::vector<std::string>, std::vector<double>>;

/// Publishes `step` as a sensor_msgs/JointState stamped `stamp_sec` (its names and positions as
/// given, so that a step may carry fewer positions than names).
dds_return_t write_joint_state(dds_entity_t writer, JointStep& step, int32_t stamp_sec) {
  std::vector<char*> names;
  for (std::string& name : step.first) names.push_back(name.data());
  sensor_msgs_msg_dds__JointState_ state{};
  state.header.stamp = {stamp_sec, 0};
  state.header.frame_id = const_cast<char*>("");
  state.name = {uint32_t(names.size()), uint32_t(names.size()), names.data(), false};
  const auto values = uint32_t(step.second.size());
  state.position = {values, values, step.second.data(), false};
  return dds_write(writer, &state);
}

/// Takes DistanceReports addressed to the writer `own` until `count` have come or 20 s have
/// passed, calling `print` on each in arrival order; returns how many came.
template <class Print>
std::size_t take_reports(dds_entity_t reader, const dds_guid_t& own, std::size_t count,
                         Print print) {
  std::size_t answered = 0;
  const auto wait_until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (answered < count && std::chrono::steady_clock::now() < wait_until) {
    void* samples[1] = {nullptr};
    dds_sample_info_t info;
    if (dds_take(reader, samples, &info, 1, 1) != 1) {
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
      continue;
    }
    const auto& r = *static_cast<const nearpoint_msgs_msg_dds__DistanceReport_*>(samples[0]);
    if (info.valid_data && std::memcmp(r.writer_guid, own.v, 16) == 0) {
      ++answered;
      print(r);
    }
    dds_return_loan(reader, samples, 1);
  }
  return answered;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4)
    return fail("usage: ros_peer DOMAIN SCENE [--batches K] X,Y,THETA... | --joint-states");
  const auto domain = dds_domainid_t(std::atoi(argv[1]));
  std::string scene = argv[2];
  const bool joint_states = std::string(argv[3]) == "--joint-states";
  const bool wrong_type = std::string(argv[3]) == "--wrong-type";
  const bool joint_pipeline = std::string(argv[3]) == "--joint-pipeline";
  const bool joint_steps = std::string(argv[3]) == "--joint-steps" || joint_pipeline;
  const bool batches = std::string(argv[3]) == "--batches";
  const int batch_size = batches && argc > 4 ? std::atoi(argv[4]) : 0;
  if (batches && batch_size < 1) return fail("--batches needs a batch size of at least 1");
  std::vector<JointStep> steps;
  for (int i = 4; joint_steps && i < argc; ++i) {
    auto& [names, values] = steps.emplace_back();
    std::string step = argv[i];
    if (step == "BAD") {  // two names, one position
      names = {"shoulder", "elbow"};
      values = {0.5};
      continue;
    }
    for (std::size_t at = 0; at < step.size();) {
      std::size_t end = step.find(',', at);
      if (end == std::string::npos) end = step.size();
      const std::string item = step.substr(at, end - at);
      const std::size_t eq = item.find('=');
      if (eq == std::string::npos) return fail("not NAME=VALUE: " + item);
      names.push_back(item.substr(0, eq));
      values.push_back(std::atof(item.c_str() + eq + 1));
      at = end + 1;
    }
  }
  std::vector<std::tuple<double, double, double>> poses;
  for (int i = batches ? 5 : 3; i < argc && !joint_states && !wrong_type && !joint_steps; ++i) {
    double x, y, theta;
    if (std::sscanf(argv[i], "%lf,%lf,%lf", &x, &y, &theta) != 3)
      return fail(std::string("not X,Y,THETA: ") + argv[i]);
    poses.emplace_back(x, y, theta);
  }

  const dds_entity_t participant = dds_create_participant(domain, nullptr, nullptr);
  if (participant < 0) return fail(dds_strretcode(participant));
  dds_qos_t* qos = ros_default_qos();
  const dds_entity_t update_topic =
      dds_create_topic(participant,
                       wrong_type ? &sensor_msgs_msg_dds__JointState__desc
                                  : &nearpoint_msgs_msg_dds__PoseUpdate__desc,
                       "rt/nearpoint/pose_updates", qos, nullptr);
  const dds_entity_t report_topic =
      dds_create_topic(participant, &nearpoint_msgs_msg_dds__DistanceReport__desc,
                       "rt/nearpoint/distance_reports", qos, nullptr);
  const dds_entity_t joint_topic = dds_create_topic(
      participant, &sensor_msgs_msg_dds__JointState__desc, "rt/joint_states", qos, nullptr);
  const dds_entity_t update_batch_topic =
      dds_create_topic(participant, &nearpoint_msgs_msg_dds__PoseUpdateBatch__desc,
                       "rt/nearpoint/pose_update_batches", qos, nullptr);
  const dds_entity_t report_batch_topic =
      dds_create_topic(participant, &nearpoint_msgs_msg_dds__DistanceReportBatch__desc,
                       "rt/nearpoint/distance_report_batches", qos, nullptr);
  if (update_topic < 0 || report_topic < 0 || joint_topic < 0 || update_batch_topic < 0 ||
      report_batch_topic < 0)
    return fail("dds_create_topic failed");
  const dds_entity_t writer = dds_create_writer(participant,
                                                joint_states || joint_steps ? joint_topic
                                                : batches                   ? update_batch_topic
                                                                            : update_topic,
                                                qos, nullptr);
  const dds_entity_t reader =
      dds_create_reader(participant, batches ? report_batch_topic : report_topic, qos, nullptr);
  dds_delete_qos(qos);
  if (writer < 0 || reader < 0) return fail("dds_create_writer/reader failed");
  const dds_entity_t publications =
      dds_create_reader(participant, DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr);
  const dds_entity_t subscriptions =
      dds_create_reader(participant, DDS_BUILTIN_TOPIC_DCPSSUBSCRIPTION, nullptr, nullptr);
  dds_guid_t own;
  dds_get_guid(writer, &own);
  dds_guid_t own_participant;
  dds_get_guid(participant, &own_participant);

  if (wrong_type) {
    // Nothing matches: wait for discovery, publish, and count what comes back.
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));
    sensor_msgs_msg_dds__JointState_ state{};
    state.header.frame_id = const_cast<char*>("");
    if (const dds_return_t rc = dds_write(writer, &state); rc < 0)
      return fail(std::string("dds_write: ") + dds_strretcode(rc));
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));
    int reports = 0;
    void* samples[1] = {nullptr};
    dds_sample_info_t info;
    while (dds_take(reader, samples, &info, 1, 1) == 1) {
      const auto& r = *static_cast<const nearpoint_msgs_msg_dds__DistanceReport_*>(samples[0]);
      if (info.valid_data && std::memcmp(r.writer_guid, own.v, 16) == 0) ++reports;
      dds_return_loan(reader, samples, 1);
    }
    std::printf("{\"reports\": %d}\n", reports);
    dds_delete(participant);
    return 0;
  }

  // Wait for nearpointd on both topics, then a little for its writer to see our reader.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  for (;;) {
    dds_publication_matched_status_t pm{};
    dds_subscription_matched_status_t sm{};
    dds_get_publication_matched_status(writer, &pm);
    dds_get_subscription_matched_status(reader, &sm);
    if (pm.current_count > 0 && sm.current_count > 0) break;
    if (std::chrono::steady_clock::now() > deadline)
      return fail("nearpointd not matched in 20 s: our writer matched " +
                  std::to_string(pm.current_count) + " reader(s), our reader " +
                  std::to_string(sm.current_count) + " writer(s)");
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }

  if (joint_states) {
    char* names[] = {const_cast<char*>("shoulder"), const_cast<char*>("elbow")};
    double positions[] = {0.25, -0.5};
    for (std::uint32_t k = 0; k < 3; ++k) {
      sensor_msgs_msg_dds__JointState_ state{};
      state.header.stamp = {int32_t(2000 + k), 0};
      state.header.frame_id = const_cast<char*>("");
      state.name = {2, 2, names, false};
      state.position = {k < 2 ? 2u : 1u, k < 2 ? 2u : 1u, positions, false};
      if (const dds_return_t rc = dds_write(writer, &state); rc < 0)
        return fail(std::string("dds_write: ") + dds_strretcode(rc));
    }
    const std::size_t answered = take_reports(reader, own, 3, [](const auto& r) {
      std::printf(
          "{\"sequence\": %llu, \"status\": %u, \"scene_id\": %s, \"client_id\": %s, "
          "\"error_field\": %s, \"stamp_sec\": %d}\n",
          static_cast<unsigned long long>(r.sequence_number), r.status,
          json_string(r.scene_id).c_str(), json_string(r.client_id).c_str(),
          json_string(r.error_field).c_str(), r.header.stamp.sec);
    });
    dds_delete(participant);
    return answered == 3 ? 0 : fail("reports missing for the joint states");
  }

  if (joint_pipeline) {
    for (std::size_t k = 0; k < steps.size(); ++k)
      if (const dds_return_t rc = write_joint_state(writer, steps[k], int32_t(1000 + k)); rc < 0)
        return fail(std::string("dds_write: ") + dds_strretcode(rc));
    const std::size_t answered = take_reports(reader, own, steps.size(), [](const auto& r) {
      std::printf("{\"sequence\": %llu, \"status\": %u, \"error_field\": %s}\n",
                  static_cast<unsigned long long>(r.sequence_number), r.status,
                  json_string(r.error_field).c_str());
    });
    dds_delete(participant);
    return answered == steps.size() ? 0 : fail("reports missing for the pipelined steps");
  }

  if (batches) {
    // Every update first, batch_size per sample, then the reports as they come, in whichever
    // grouping nearpointd chose; each printed once, in sequence order.
    for (std::size_t first = 0; first < poses.size(); first += std::size_t(batch_size)) {
      const std::size_t end = std::min(poses.size(), first + std::size_t(batch_size));
      std::vector<nearpoint_msgs_msg_dds__ObjectPose_> storage(end - first);
      std::vector<nearpoint_msgs_msg_dds__PoseUpdate_> updates;
      for (std::size_t k = first; k < end; ++k) {
        const auto [x, y, theta] = poses[k];
        updates.push_back(mover_update(scene, k + 1, x, y, theta, storage[k - first]));
      }
      nearpoint_msgs_msg_dds__PoseUpdateBatch_ batch{};
      batch.updates = {uint32_t(updates.size()), uint32_t(updates.size()), updates.data(), false};
      if (const dds_return_t rc = dds_write(writer, &batch); rc < 0)
        return fail(std::string("dds_write: ") + dds_strretcode(rc));
    }
    std::vector<std::string> lines(poses.size());
    std::size_t answered = 0;
    const auto wait_until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (answered < poses.size() && std::chrono::steady_clock::now() < wait_until) {
      void* samples[1] = {nullptr};
      dds_sample_info_t info;
      if (dds_take(reader, samples, &info, 1, 1) != 1) {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        continue;
      }
      const auto& batch =
          *static_cast<const nearpoint_msgs_msg_dds__DistanceReportBatch_*>(samples[0]);
      for (uint32_t i = 0; info.valid_data && i < batch.reports._length; ++i) {
        const auto& report = batch.reports._buffer[i];
        const std::size_t k = report.sequence_number;
        if (std::memcmp(report.writer_guid, own.v, 16) != 0 || k < 1 || k > poses.size() ||
            !lines[k - 1].empty())
          continue;
        lines[k - 1] = report_line(report);
        ++answered;
      }
      dds_return_loan(reader, samples, 1);
    }
    for (std::size_t k = 0; k < lines.size(); ++k) {
      if (lines[k].empty()) return fail("no batched report for sequence " + std::to_string(k + 1));
      std::printf("%s\n", lines[k].c_str());
    }
  }

  const std::size_t count = batches ? 0 : joint_steps ? steps.size() : poses.size();
  for (std::size_t k = 0; k < count; ++k) {
    dds_return_t written = 0;
    if (joint_steps) {
      written = write_joint_state(writer, steps[k], int32_t(1000 + k));
    } else {
      const auto [x, y, theta] = poses[k];
      nearpoint_msgs_msg_dds__ObjectPose_ pose;
      const nearpoint_msgs_msg_dds__PoseUpdate_ update =
          mover_update(scene, k + 1, x, y, theta, pose);
      written = dds_write(writer, &update);
    }
    if (written < 0) return fail(std::string("dds_write: ") + dds_strretcode(written));
    bool answered = false;
    const auto wait_until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (!answered && std::chrono::steady_clock::now() < wait_until) {
      void* samples[1] = {nullptr};
      dds_sample_info_t info;
      if (dds_take(reader, samples, &info, 1, 1) != 1) {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        continue;
      }
      const auto& report = *static_cast<const nearpoint_msgs_msg_dds__DistanceReport_*>(samples[0]);
      if (info.valid_data && std::memcmp(report.writer_guid, own.v, 16) == 0 &&
          report.sequence_number == k + 1) {
        answered = true;
        std::printf("%s\n", report_line(report).c_str());
      }
      dds_return_loan(reader, samples, 1);
    }
    if (!answered) return fail("no report for sequence " + std::to_string(k + 1));
  }

  std::set<std::string> seen;
  for (const auto& [entity, kind] :
       {std::pair{publications, "publication"}, std::pair{subscriptions, "subscription"}}) {
    void* samples[64] = {nullptr};
    dds_sample_info_t infos[64];
    const dds_return_t n = dds_read(entity, samples, infos, 64, 64);
    for (dds_return_t i = 0; i < n; ++i) {
      const auto* e = static_cast<const dds_builtintopic_endpoint_t*>(samples[i]);
      if (!infos[i].valid_data || std::memcmp(e->participant_key.v, own_participant.v, 16) == 0)
        continue;
      seen.insert(std::string("{\"endpoint\": \"") + kind + "\", \"topic\": " +
                  json_string(e->topic_name) + ", \"type\": " + json_string(e->type_name) + "}");
    }
    if (n > 0) dds_return_loan(entity, samples, n);
  }
  for (const std::string& line : seen) std::printf("%s\n", line.c_str());
  dds_delete(participant);
  return 0;
}
