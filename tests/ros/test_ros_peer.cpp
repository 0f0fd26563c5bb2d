// SPDX-License-Identifier: Apache-2.0
// A ROS 2 node's view of nearpointd, without ROS 2: nearpointd --dds (default topic names) with
// the shipped scene preloaded, and tests/ros/peer/ros_peer, a separate process whose types come
// from rosidl's IDL of the .msg files (not from nearpoint's IDL), publishing PoseUpdates on
// rt/nearpoint/pose_updates with ROS 2's default QoS and reading the reports. Checked: every
// distance against its closed form, the header echoed, and the topic and type names that
// discovery shows for nearpointd's endpoints, exactly those ROS 2 expects.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/child_process.hpp"

namespace {

using nearpoint::testkit::ChildProcess;
using Json = nlohmann::json;

// 131-140: tests/ros (101-130: tests/dds); this file uses 132-138.
constexpr int kDomain = 132;

/// nearpointd with robot scene "arm7" (examples/robots/arm7.urdf, created over gRPC by `nearpoint
/// scene create`) bound to rt/joint_states on DDS domain `domain`; the gRPC port in `port`.
/// Null (with the test failed) when it does not start.
std::unique_ptr<ChildProcess> start_arm7_server(int domain, const std::string& name, int& port) {
  const std::string port_file = ::testing::TempDir() + name + ".port";
  std::remove(port_file.c_str());
  auto server = std::make_unique<ChildProcess>(std::vector<std::string>{
      NEARPOINTD_PATH, "--listen", "127.0.0.1:0", "--port-file", port_file, "--workers", "2",
      "--dds", "--dds-domain", std::to_string(domain), "--dds-joint-states", "arm7"});
  if (!server->started() ||
      server->wait_for_stderr("event=listening", std::chrono::seconds(30)).empty()) {
    ADD_FAILURE() << "nearpointd did not start: " << server->stderr_text();
    return nullptr;
  }
  port = 0;
  std::ifstream(port_file) >> port;
  ChildProcess create({NEARPOINT_CLI_PATH, "scene", "create",
                       NEARPOINT_SOURCE_DIR "/examples/robots/arm7.urdf", "--target",
                       "127.0.0.1:" + std::to_string(port)});
  if (port <= 0 || create.wait_exit(std::chrono::seconds(60)) != 0) {
    ADD_FAILURE() << "scene arm7 not created (port " << port << "): " << create.stderr_text();
    return nullptr;
  }
  return server;
}

/// Distance from the vertical axis through (ax, ay) to the unit cube at (cx, cy) turned by theta
/// about z, minus the round shape's radius (examples/dds_scene.json: both round shapes span the
/// cube's height).
double axis_to_cube(double ax, double ay, double cx, double cy, double theta, double r) {
  const double dx = ax - cx, dy = ay - cy;
  const double u = std::cos(theta) * dx + std::sin(theta) * dy;
  const double v = -std::sin(theta) * dx + std::cos(theta) * dy;
  const double gap = std::hypot(std::max(std::abs(u) - 0.5, 0.0), std::max(std::abs(v) - 0.5, 0.0));
  return std::max(gap - r, 0.0);
}

/// The mover's poses the demo-scene tests stream, as (x, y, theta).
const std::vector<std::array<double, 3>> kDemoPoses = {
    {0, -2, 0}, {0, -1.2, 0.3}, {0.6, -0.4, 0.8}, {1.5, 0, 0.2}, {2.2, 0.1, 1.0}, {3, 1.4, 0}};

/// ros_peer's first kDemoPoses.size() lines: one accepted report per pose, in order, with the
/// update's header echoed and every distance equal to its closed form within its error bound.
void expect_demo_reports(const std::vector<std::string>& lines) {
  ASSERT_GE(lines.size(), kDemoPoses.size());
  for (std::size_t k = 0; k < kDemoPoses.size(); ++k) {
    SCOPED_TRACE(lines[k]);
    const Json report = Json::parse(lines[k]);
    ASSERT_EQ(report.at("sequence"), k + 1);
    ASSERT_EQ(report.at("status"), 0);
    EXPECT_EQ(report.at("stamp_sec"), 1000 + int(k)) << "the update's header is echoed";
    const auto [x, y, theta] = kDemoPoses[k];
    const Json& pairs = report.at("pairs");
    ASSERT_EQ(pairs.size(), 3u);
    const double post = axis_to_cube(0, 0, x, y, theta, 0.2);
    const double drum = axis_to_cube(3, 0, x, y, theta, 0.3);
    EXPECT_NEAR(pairs.at("mover/post")[0].get<double>(), post,
                pairs.at("mover/post")[1].get<double>() + 1e-12);
    EXPECT_NEAR(pairs.at("mover/drum")[0].get<double>(), drum,
                pairs.at("mover/drum")[1].get<double>() + 1e-12);
    EXPECT_NEAR(pairs.at("post/drum")[0].get<double>(), 2.5, 1e-9);
  }
}

/// Runs ros_peer on `domain` for scene dds-demo with `options`, then every pose of kDemoPoses as
/// X,Y,THETA; its stdout lines, or none (the test failed with both processes' stderr) when it does
/// not exit 0.
std::vector<std::string> run_demo_peer(int domain, const std::vector<std::string>& options,
                                       ChildProcess& server) {
  std::vector<std::string> argv = {ROS_PEER_PATH, std::to_string(domain), "dds-demo"};
  argv.insert(argv.end(), options.begin(), options.end());
  for (const auto& [x, y, t] : kDemoPoses)
    argv.push_back(std::to_string(x) + "," + std::to_string(y) + "," + std::to_string(t));
  ChildProcess peer(argv);
  const int status = peer.started() ? peer.wait_exit(std::chrono::seconds(90)) : -1;
  if (status != 0) {
    ADD_FAILURE() << "ros_peer exited " << status << ": " << peer.stderr_text() << "\nserver:\n"
                  << server.stderr_text();
    return {};
  }
  return peer.stdout_lines();
}

TEST(RosPeer, RosidlTypedPeerStreamsToNearpointd) {
  ChildProcess server({NEARPOINTD_PATH, "--listen", "127.0.0.1:0", "--workers", "2", "--dds",
                       "--dds-domain", std::to_string(kDomain), "--scene",
                       NEARPOINT_SOURCE_DIR "/examples/dds_scene.json"});
  ASSERT_TRUE(server.started());
  ASSERT_NE(server.wait_for_stderr("event=dds_ready", std::chrono::seconds(20)), "")
      << server.stderr_text();

  // `nearpoint dds echo` (ros2 topic echo's counterpart) sees every report of the scene.
  ChildProcess echo({NEARPOINT_CLI_PATH, "dds", "echo", "--dds-domain", std::to_string(kDomain),
                     "--scene", "dds-demo", "--count", "6", "--timeout-ms", "30000"});
  ASSERT_TRUE(echo.started());
  ASSERT_NE(echo.wait_for_stderr("listening", std::chrono::seconds(20)), "") << echo.stderr_text();
  // Discovery runs in both directions: give nearpointd's writer a moment to see echo's reader.
  std::this_thread::sleep_for(std::chrono::milliseconds(500));

  const std::vector<std::array<double, 3>>& poses = kDemoPoses;
  const std::vector<std::string> lines = run_demo_peer(kDomain, {}, server);
  expect_demo_reports(lines);
  if (HasFatalFailure()) return;

  std::set<std::string> endpoints;
  for (std::size_t k = poses.size(); k < lines.size(); ++k) {
    const Json e = Json::parse(lines[k]);
    endpoints.insert(e.at("endpoint").get<std::string>() + " " + e.at("topic").get<std::string>() +
                     " " + e.at("type").get<std::string>());
  }
  // nearpointd's five endpoints (the batched pair included), and `nearpoint dds echo`'s two
  // (still running then).
  const std::set<std::string> expected = {
      "subscription rt/nearpoint/pose_updates nearpoint_msgs::msg::dds_::PoseUpdate_",
      "publication rt/nearpoint/distance_reports nearpoint_msgs::msg::dds_::DistanceReport_",
      "publication rt/nearpoint/threshold_events nearpoint_msgs::msg::dds_::ThresholdEvent_",
      "subscription rt/nearpoint/pose_update_batches nearpoint_msgs::msg::dds_::PoseUpdateBatch_",
      "publication rt/nearpoint/distance_report_batches "
      "nearpoint_msgs::msg::dds_::DistanceReportBatch_",
      "publication rt/nearpoint/pose_updates nearpoint_msgs::msg::dds_::PoseUpdate_",
      "subscription rt/nearpoint/distance_reports nearpoint_msgs::msg::dds_::DistanceReport_"};
  for (const std::string& name : expected) EXPECT_TRUE(endpoints.count(name)) << name;
  for (const std::string& name : endpoints)
    EXPECT_TRUE(expected.count(name)) << "unexpected: " << name;

  ASSERT_EQ(echo.wait_exit(std::chrono::seconds(60)), 0) << echo.stderr_text();
  const std::vector<std::string> echoed = echo.stdout_lines();
  ASSERT_EQ(echoed.size(), poses.size());
  for (std::size_t k = 0; k < echoed.size(); ++k) {
    const Json report = Json::parse(echoed[k]);
    EXPECT_EQ(report.at("scene_id"), "dds-demo");
    EXPECT_EQ(report.at("client_id"), "ros_peer");
    EXPECT_EQ(report.at("sequence"), k + 1);
    EXPECT_EQ(report.at("pairs").size(), 3u);
  }

  // `nearpoint dds topics` lists nearpointd's topics with the names ROS 2 tools show.
  ChildProcess topics({NEARPOINT_CLI_PATH, "dds", "topics", "--dds-domain", std::to_string(kDomain),
                       "--wait-ms", "1500"});
  ASSERT_TRUE(topics.started());
  ASSERT_EQ(topics.wait_exit(std::chrono::seconds(30)), 0) << topics.stderr_text();
  const std::vector<std::string> listed = topics.stdout_lines();
  std::string all;
  for (const std::string& line : listed) all += line + "\n";
  auto has = [&](const std::string& text) {
    for (const std::string& line : listed)
      if (line.starts_with(text)) return true;
    return false;
  };
  EXPECT_TRUE(
      has("/nearpoint/pose_updates [nearpoint_msgs/msg/PoseUpdate]  dds: "
          "rt/nearpoint/pose_updates nearpoint_msgs::msg::dds_::PoseUpdate_  "
          "publishers: 0  subscribers: 1"))
      << all;
  EXPECT_TRUE(has("/nearpoint/distance_reports [nearpoint_msgs/msg/DistanceReport]")) << all;
  EXPECT_TRUE(has("/nearpoint/threshold_events [nearpoint_msgs/msg/ThresholdEvent]")) << all;
  EXPECT_TRUE(has("/nearpoint/pose_update_batches [nearpoint_msgs/msg/PoseUpdateBatch]")) << all;
  EXPECT_TRUE(has("/nearpoint/distance_report_batches [nearpoint_msgs/msg/DistanceReportBatch]"))
      << all;

  server.signal(SIGTERM);
  EXPECT_EQ(server.wait_exit(std::chrono::seconds(30)), 0) << server.stderr_text();
}

// The batch topics with rosidl's types on both ends: the peer publishes the demo poses three to a
// nearpoint_msgs/PoseUpdateBatch and reads nearpointd's nearpoint_msgs/DistanceReportBatch
// samples. Guards the type information of the report batch: the peer's types are idlc's
// compilation of rosidl's IDL, whose XTypes type ids must equal those of nearpointd's writer or
// the peer's reader does not match it (it did not while nearpointd spelled DistanceReport's
// uint8[16] as a plain array where rosidl's IDL declares the typedef uint8__16).
TEST(RosPeer, RosidlTypedPeerStreamsBatchesToNearpointd) {
  ChildProcess server({NEARPOINTD_PATH, "--listen", "127.0.0.1:0", "--workers", "2", "--dds",
                       "--dds-domain", std::to_string(kDomain + 6), "--scene",
                       NEARPOINT_SOURCE_DIR "/examples/dds_scene.json"});
  ASSERT_TRUE(server.started());
  ASSERT_NE(server.wait_for_stderr("event=dds_ready", std::chrono::seconds(20)), "")
      << server.stderr_text();

  expect_demo_reports(run_demo_peer(kDomain + 6, {"--batches", "3"}, server));

  server.signal(SIGTERM);
  EXPECT_EQ(server.wait_exit(std::chrono::seconds(30)), 0) << server.stderr_text();
}

// sensor_msgs/JointState in: nearpointd --dds-joint-states binds the scene to rt/joint_states,
// a JointState from the ROS-typed peer is decoded and answered on the reports topic, addressed
// to the JointState's writer with its header. The shipped scene has no robot, so well-formed
// samples are refused FAILED_PRECONDITION (9) naming "joints"; fewer positions than names
// are INVALID_ARGUMENT (3) naming "joint_states.position".
TEST(RosPeer, JointStatesAreDecodedAndAnswered) {
  ChildProcess server({NEARPOINTD_PATH, "--listen", "127.0.0.1:0", "--workers", "2", "--dds",
                       "--dds-domain", std::to_string(kDomain + 1), "--dds-joint-states",
                       "dds-demo", "--scene", NEARPOINT_SOURCE_DIR "/examples/dds_scene.json"});
  ASSERT_TRUE(server.started());
  ASSERT_NE(server.wait_for_stderr("event=dds_ready", std::chrono::seconds(20)), "")
      << server.stderr_text();
  ASSERT_NE(
      server.stderr_text().find("event=dds_joint_states scene=dds-demo topic=rt/joint_states"),
      std::string::npos)
      << server.stderr_text();
  ChildProcess peer({ROS_PEER_PATH, std::to_string(kDomain + 1), "dds-demo", "--joint-states"});
  ASSERT_TRUE(peer.started());
  ASSERT_EQ(peer.wait_exit(std::chrono::seconds(60)), 0) << peer.stderr_text() << "\nserver:\n"
                                                         << server.stderr_text();
  const std::vector<std::string> lines = peer.stdout_lines();
  ASSERT_EQ(lines.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    SCOPED_TRACE(lines[k]);
    const Json report = Json::parse(lines[k]);
    EXPECT_EQ(report.at("sequence"), k + 1);
    EXPECT_EQ(report.at("scene_id"), "dds-demo");
    EXPECT_EQ(report.at("client_id"), "joint_states");
    EXPECT_EQ(report.at("stamp_sec"), 2000 + int(k));
    EXPECT_EQ(report.at("status"), k < 2 ? 9 : 3);
    EXPECT_EQ(report.at("error_field"), k < 2 ? "joints" : "joint_states.position");
  }
  server.signal(SIGTERM);
  EXPECT_EQ(server.wait_exit(std::chrono::seconds(30)), 0) << server.stderr_text();
}

// A robot scene driven by sensor_msgs/JointState: nearpointd binds scene "arm7" to
// rt/joint_states, `nearpoint scene create examples/robots/arm7.urdf` creates it over gRPC; the
// ROS-typed peer publishes the first steps of the shipped wave as JointStates, and every report's
// distances equal those of the same steps streamed over gRPC by `nearpoint stream --joints` (the
// robot path of issue 32).
TEST(RosPeer, JointStatesDriveARobotScene) {
  int port = 0;
  const std::unique_ptr<ChildProcess> server_process =
      start_arm7_server(kDomain + 3, "ros_peer_robot", port);
  ASSERT_TRUE(server_process);
  ChildProcess& server = *server_process;

  // The wave's first 6 steps, as a trajectory file and as the peer's JointState steps.
  const std::string trajectory = ::testing::TempDir() + "ros_peer_wave.jsonl";
  std::vector<std::string> argv = {ROS_PEER_PATH, std::to_string(kDomain + 3), "arm7",
                                   "--joint-steps"};
  {
    std::ifstream in(NEARPOINT_SOURCE_DIR "/examples/robots/arm7_wave.jsonl");
    std::ofstream out(trajectory);
    std::string line;
    for (int k = 0; k < 6 && std::getline(in, line); ++k) {
      out << line << "\n";
      std::string step;
      const Json parsed = Json::parse(line);  // outlives the loop over its items
      for (const auto& [name, value] : parsed.at("joints").items()) {
        char number[40];
        std::snprintf(number, sizeof number, "%.17g", value.get<double>());
        step += (step.empty() ? "" : ",") + name + "=" + number;
      }
      argv.push_back(step);
    }
  }
  ChildProcess peer(argv);
  ASSERT_TRUE(peer.started());
  ASSERT_EQ(peer.wait_exit(std::chrono::seconds(90)), 0) << peer.stderr_text() << "\nserver:\n"
                                                         << server.stderr_text();
  ChildProcess grpc({NEARPOINT_CLI_PATH, "stream", "arm7", "--joints", trajectory, "--json",
                     "--target", "127.0.0.1:" + std::to_string(port)});
  ASSERT_EQ(grpc.wait_exit(std::chrono::seconds(60)), 0) << grpc.stderr_text();

  const std::vector<std::string> dds_lines = peer.stdout_lines();
  std::vector<Json> grpc_reports;
  for (const std::string& line : grpc.stdout_lines())
    if (!line.empty()) grpc_reports.push_back(Json::parse(line));
  ASSERT_GE(dds_lines.size(), 6u);
  ASSERT_EQ(grpc_reports.size(), 6u);
  int compared = 0;
  for (std::size_t k = 0; k < 6; ++k) {
    SCOPED_TRACE(dds_lines[k]);
    const Json dds = Json::parse(dds_lines[k]);
    ASSERT_EQ(dds.at("sequence"), k + 1);
    ASSERT_EQ(dds.at("status"), 0) << dds.at("message");
    EXPECT_EQ(dds.at("stamp_sec"), 1000 + int(k));
    const Json& pairs = dds.at("pairs");
    ASSERT_EQ(pairs.size(), grpc_reports[k].at("pairs").size());
    for (const Json& pair : grpc_reports[k].at("pairs")) {
      const std::string key =
          pair.at("object_a").get<std::string>() + "/" + pair.at("object_b").get<std::string>();
      ASSERT_TRUE(pairs.contains(key)) << key;
      EXPECT_NEAR(pairs.at(key)[0].get<double>(), pair.at("distance").get<double>(),
                  pair.at("error_bound").get<double>() + pairs.at(key)[1].get<double>() + 1e-12)
          << key;
      ++compared;
    }
  }
  EXPECT_GT(compared, 6);
  server.signal(SIGTERM);
  EXPECT_EQ(server.wait_exit(std::chrono::seconds(30)), 0) << server.stderr_text();
}

// A JointState that cannot be decoded is answered in its turn: published right behind a
// well-formed one (whose evaluation is still running when it arrives) and before another, its
// error report comes between their reports, as on gRPC, never ahead of an earlier sample's.
TEST(RosPeer, UndecodableJointStateIsAnsweredInItsTurn) {
  int port = 0;
  const std::unique_ptr<ChildProcess> server_process =
      start_arm7_server(kDomain + 5, "ros_peer_order", port);
  ASSERT_TRUE(server_process);
  ChildProcess& server = *server_process;
  for (int round = 0; round < 5; ++round) {
    SCOPED_TRACE("round " + std::to_string(round));
    ChildProcess peer({ROS_PEER_PATH, std::to_string(kDomain + 5), "arm7", "--joint-pipeline",
                       "joint1=0.1,joint2=0.2", "BAD", "joint1=0.3,joint2=0.4"});
    ASSERT_TRUE(peer.started());
    ASSERT_EQ(peer.wait_exit(std::chrono::seconds(60)), 0) << peer.stderr_text();
    const std::vector<std::string> lines = peer.stdout_lines();
    ASSERT_EQ(lines.size(), 3u);
    for (std::size_t k = 0; k < 3; ++k) {
      SCOPED_TRACE(lines[k]);
      const Json report = Json::parse(lines[k]);
      EXPECT_EQ(report.at("sequence"), k + 1);
      EXPECT_EQ(report.at("status"), k == 1 ? 3 : 0);
      if (k == 1) {
        EXPECT_EQ(report.at("error_field"), "joint_states.position");
      }
    }
  }
  server.signal(SIGTERM);
  EXPECT_EQ(server.wait_exit(std::chrono::seconds(30)), 0) << server.stderr_text();
}

// A participant built from other message definitions, publishing on our topic: DDS matches ROS 2
// types by name, so it gets nothing, and nearpointd logs why (once), naming both types.
TEST(RosPeer, MismatchedTypeGetsNothingAndIsLogged) {
  ChildProcess server({NEARPOINTD_PATH, "--listen", "127.0.0.1:0", "--dds", "--dds-domain",
                       std::to_string(kDomain + 2), "--scene",
                       NEARPOINT_SOURCE_DIR "/examples/dds_scene.json"});
  ASSERT_TRUE(server.started());
  ASSERT_NE(server.wait_for_stderr("event=dds_ready", std::chrono::seconds(20)), "")
      << server.stderr_text();
  ChildProcess peer({ROS_PEER_PATH, std::to_string(kDomain + 2), "dds-demo", "--wrong-type"});
  ASSERT_TRUE(peer.started());
  ASSERT_EQ(peer.wait_exit(std::chrono::seconds(60)), 0) << peer.stderr_text();
  ASSERT_EQ(peer.stdout_lines(), std::vector<std::string>{"{\"reports\": 0}"});
  const std::string logged =
      server.wait_for_stderr("event=dds_type_mismatch", std::chrono::seconds(10));
  ASSERT_NE(logged, "") << server.stderr_text();
  EXPECT_NE(logged.find("endpoint=publication topic=rt/nearpoint/pose_updates "
                        "type=sensor_msgs::msg::dds_::JointState_ "
                        "expected=nearpoint_msgs::msg::dds_::PoseUpdate_"),
            std::string::npos)
      << logged;
  server.signal(SIGTERM);
  EXPECT_EQ(server.wait_exit(std::chrono::seconds(30)), 0) << server.stderr_text();
  EXPECT_NE(server.stderr_text().find("event=dds_shutdown updates=0"), std::string::npos)
      << server.stderr_text();
}

// A bad binding stops nearpointd before it serves, naming the flag.
TEST(RosPeer, BadJointStateBindingIsRefused) {
  ChildProcess server({NEARPOINTD_PATH, "--listen", "127.0.0.1:0", "--dds", "--dds-domain",
                       std::to_string(kDomain + 1), "--dds-joint-states", "dds-demo=/2bad"});
  ASSERT_TRUE(server.started());
  EXPECT_EQ(server.wait_exit(std::chrono::seconds(30)), 2) << server.stderr_text();
  EXPECT_NE(server.stderr_text().find("field=--dds-joint-states.topic"), std::string::npos)
      << server.stderr_text();
}

}  // namespace
