// SPDX-License-Identifier: Apache-2.0
// DDS across a process boundary: nearpointd --dds as one child process, `nearpoint stream --dds`
// as another. The test creates the scene over gRPC (both transports serve one scene store),
// writes a trajectory file, runs the client on it and checks every line the client printed:
// sequence numbers complete and in order, and each pair's distance equal to the engine's, computed
// here from the same geometry and poses. Then bad samples (an unknown scene, an unknown object)
// are answered with error reports, the server keeps serving, and SIGTERM ends
// it cleanly.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>

#include <nlohmann/json.hpp>

#include "common/child_process.hpp"
#include "dds_test_support.hpp"
#include "nearpoint/distance.hpp"
#include "server/server_test_support.hpp"

namespace nearpoint::dds_testing {

using testkit::ChildProcess;
namespace {

namespace v1 = ::nearpoint::v1;
using server::testing::TestGeometry;
using server::testing::TestPose;
using Json = nlohmann::json;

/// A scratch directory for the port file and the trajectories, removed afterwards.
struct ScratchDirectory {
  std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("nearpoint_dds_e2e_" + std::to_string(getpid()));
  ScratchDirectory() { std::filesystem::create_directories(path); }
  ~ScratchDirectory() {
    std::error_code ignored;
    std::filesystem::remove_all(path, ignored);
  }
};

struct Step {
  std::map<std::string, TestPose> poses;  // the objects that move at this step
};

void write_trajectory(const std::filesystem::path& file, const std::vector<Step>& steps) {
  std::ofstream out(file);
  for (std::size_t k = 0; k < steps.size(); ++k) {
    Json line;
    line["t"] = 0.01 * double(k);
    line["poses"] = Json::object();
    for (const auto& [id, pose] : steps[k].poses) {
      const Eigen::Quaterniond& q = pose.rotation;
      line["poses"][id] = {
          {"rotation", {q.w(), q.x(), q.y(), q.z()}},
          {"translation", {pose.translation.x(), pose.translation.y(), pose.translation.z()}}};
    }
    out << line.dump() << '\n';
  }
}

std::vector<std::string> client_command(const std::string& scene, const std::string& prefix,
                                        const std::filesystem::path& trajectory) {
  return {NEARPOINT_CLI_PATH,
          "stream",
          "--dds",
          "--dds-domain",
          std::to_string(kDomainEndToEnd),
          "--dds-prefix",
          prefix,
          "--window",
          "4",
          "--client-id",
          "e2e",
          "--report-timeout-ms",
          "20000",
          scene,
          trajectory.string()};
}

TEST(DdsEndToEnd, TwoProcessesStreamATrajectoryAndBadSamplesGetErrorReports) {
  ScratchDirectory scratch;
  const std::string prefix = unique_prefix("e2e");
  const std::filesystem::path port_file = scratch.path / "port";
  ChildProcess server({NEARPOINTD_PATH, "--listen", "127.0.0.1:0", "--port-file",
                       port_file.string(), "--workers", "2", "--dds", "--dds-domain",
                       std::to_string(kDomainEndToEnd), "--dds-prefix", prefix});
  ASSERT_TRUE(server.started());
  ASSERT_NE(server.wait_for_stderr("event=dds_ready", std::chrono::seconds(20)), "")
      << server.stderr_text();
  ASSERT_NE(server.wait_for_stderr("event=listening", std::chrono::seconds(20)), "")
      << server.stderr_text();
  int port = 0;
  std::ifstream(port_file) >> port;
  ASSERT_GT(port, 0);

  // The scene, over gRPC: an arm (capsule + rounded box), a random hull and a box.
  auto channel =
      grpc::CreateChannel("127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials());
  auto stub = v1::DistanceService::NewStub(channel);
  const std::vector<TestGeometry> geometries = {
      server::testing::arm_geometry(),
      server::testing::polytope_geometry("hull",
                                         server::testing::random_hull_vertices(11, 30, 0.6)),
      server::testing::polytope_geometry("box", server::testing::box_vertices({0.3, 0.4, 0.5}))};
  const std::vector<std::string> ids = {"arm", "hull", "box"};
  std::vector<TestPose> initial(3);
  initial[1].translation = {1.5, 0, 0};
  initial[2].translation = {0, 1.6, 0.2};
  v1::CreateSceneRequest create;
  create.set_name("dds-e2e");
  for (std::size_t i = 0; i < geometries.size(); ++i) {
    v1::SceneObject& object = *create.add_objects();
    object.set_id(ids[i]);
    object.set_geometry_id(server::testing::register_geometry(*stub, geometries[i]));
    initial[i].to_message(*object.mutable_pose());
  }
  v1::CreateSceneResponse scene;
  ASSERT_TRUE(stub->CreateScene(server::testing::make_context().get(), create, &scene).ok());

  // The trajectory: the arm turns and sweeps past the others every step; the hull moves every
  // other step (in between it keeps its pose, as the protocol says); the box never moves.
  constexpr int kSteps = 60;
  std::vector<Step> steps(kSteps);
  std::vector<std::vector<TestPose>> truth_poses;  // every object's pose after each step
  std::vector<TestPose> current = initial;
  for (int k = 0; k < kSteps; ++k) {
    const double s = double(k) / kSteps;
    TestPose arm;
    arm.rotation = server::testing::axis_angle(6.0 * s, {0.2, 0.3, 1});
    arm.translation = {0.4 + 0.6 * std::cos(5 * s), 0.8 * std::sin(5 * s), 0.1};
    steps[std::size_t(k)].poses["arm"] = arm;
    current[0] = arm;
    if (k % 2 == 0) {
      TestPose hull;
      hull.rotation = server::testing::axis_angle(3.0 * s, {1, 0, 0.5});
      hull.translation = {1.5 - 0.5 * s, 0.2 * s, 0};
      steps[std::size_t(k)].poses["hull"] = hull;
      current[1] = hull;
    }
    truth_poses.push_back(current);
  }
  const std::filesystem::path trajectory = scratch.path / "trajectory.jsonl";
  write_trajectory(trajectory, steps);

  {
    ChildProcess client(client_command(scene.scene_id(), prefix, trajectory));
    ASSERT_TRUE(client.started());
    const int exit_code = client.wait_exit(std::chrono::seconds(90));
    ASSERT_EQ(exit_code, 0) << client.stderr_text() << "\nserver:\n" << server.stderr_text();
    const std::vector<std::string> lines = client.stdout_lines();
    ASSERT_EQ(lines.size(), std::size_t(kSteps)) << client.stderr_text();
    int intersecting = 0, separated = 0, warm = 0;
    for (std::size_t k = 0; k < lines.size(); ++k) {
      SCOPED_TRACE("line " + std::to_string(k + 1));
      const Json report = Json::parse(lines[k]);
      ASSERT_EQ(report.at("sequence").get<std::uint64_t>(), k + 1) << "complete and in order";
      ASSERT_EQ(report.at("status"), "ok") << lines[k];
      EXPECT_EQ(report.at("coalesced_updates"), 0);
      ASSERT_EQ(report.at("pairs").size(), 3u);
      for (const Json& pair : report.at("pairs")) {
        const auto a =
            std::size_t(std::find(ids.begin(), ids.end(), pair.at("object_a")) - ids.begin());
        const auto b =
            std::size_t(std::find(ids.begin(), ids.end(), pair.at("object_b")) - ids.begin());
        ASSERT_LT(a, ids.size());
        ASSERT_LT(b, ids.size());
        const auto truth = distance(geometries[a].local, truth_poses[k][a].local(),
                                    geometries[b].local, truth_poses[k][b].local())
                               .nearest;
        const double reported = pair.at("distance");
        const double bound = pair.at("error_bound");
        EXPECT_NEAR(reported, truth.distance, bound + truth.error_bound + 1e-12)
            << ids[a] << "/" << ids[b];
        const bool says_intersecting = pair.at("status") == "intersecting";
        EXPECT_EQ(says_intersecting, truth.status == Status::intersecting)
            << ids[a] << "/" << ids[b];
        intersecting += says_intersecting;
        separated += pair.at("status") == "separated";
        warm += pair.at("warm_started").get<bool>();
      }
    }
    // The path is representative: it both touches and clears, and warm starts are used.
    EXPECT_GT(intersecting, 5);
    EXPECT_GT(separated, 60);
    EXPECT_GT(warm, kSteps);
  }

  // Bad samples over the process boundary: every update for an unknown scene is answered with an
  // error report naming the field. (The client refuses non-finite numbers in its own input, so
  // NaN poses are published directly by test_dds_bridge's client.)
  {
    ChildProcess client(client_command("scene-that-does-not-exist", prefix, trajectory));
    const int exit_code = client.wait_exit(std::chrono::seconds(90));
    EXPECT_EQ(exit_code, 1) << "rejected updates make the client exit 1\n" << client.stderr_text();
    const std::vector<std::string> lines = client.stdout_lines();
    ASSERT_EQ(lines.size(), std::size_t(kSteps)) << client.stderr_text();
    for (std::size_t k = 0; k < lines.size(); ++k) {
      const Json report = Json::parse(lines[k]);
      EXPECT_EQ(report.at("sequence").get<std::uint64_t>(), k + 1);
      EXPECT_EQ(report.at("status"), "error");
      EXPECT_EQ(report.at("error").at("code"), "not_found");
      EXPECT_EQ(report.at("error").at("field"), "scene_id");
    }
  }
  // An update the server must refuse though the client's reader accepts it: it names an object
  // the scene does not have. It is answered with an error naming the field; the stream goes on
  // and the updates around it are answered.
  {
    std::vector<Step> bad = {steps[0], steps[1], steps[2]};
    bad[1].poses["ghost"] = TestPose{};  // poses: [arm, ghost]
    const std::filesystem::path bad_file = scratch.path / "bad.jsonl";
    write_trajectory(bad_file, bad);
    ChildProcess client(client_command(scene.scene_id(), prefix, bad_file));
    EXPECT_EQ(client.wait_exit(std::chrono::seconds(90)), 1) << client.stderr_text();
    const std::vector<std::string> lines = client.stdout_lines();
    ASSERT_EQ(lines.size(), 3u) << client.stderr_text();
    std::map<std::uint64_t, Json> by_sequence;
    for (const std::string& line : lines) {
      const Json report = Json::parse(line);
      by_sequence[report.at("sequence").get<std::uint64_t>()] = report;
    }
    ASSERT_EQ(by_sequence.size(), 3u);
    EXPECT_EQ(by_sequence[1].at("status"), "ok");
    EXPECT_EQ(by_sequence[2].at("status"), "error");
    EXPECT_EQ(by_sequence[2].at("error").at("code"), "not_found");
    EXPECT_EQ(by_sequence[2].at("error").at("field"), "poses[1].object_id");
    EXPECT_EQ(by_sequence[3].at("status"), "ok");
  }

  server.signal(SIGTERM);
  EXPECT_EQ(server.wait_exit(std::chrono::seconds(30)), 0) << server.stderr_text();
  EXPECT_NE(server.stderr_text().find("event=dds_shutdown"), std::string::npos);
}

// The pure-DDS path a ROS 2 robot takes: no gRPC call at all. nearpointd preloads the shipped
// scene file (examples/dds_scene.json: a unit cube "mover", a capsule "post" on the z axis and a
// cylinder "drum" at x = 3) and the client streams the shipped trajectory (the cube slides and
// turns about z at z = 0). Every distance is checked against its closed form: both round shapes
// are vertical and span the cube's height, so each distance is the 2-D distance from the shape's
// axis to the turned square, minus the radius.
TEST(DdsEndToEnd, PureDdsClientStreamsToAPreloadedScene) {
  const std::string prefix = unique_prefix("preloaded");
  ChildProcess server({NEARPOINTD_PATH, "--listen", "127.0.0.1:0", "--workers", "2", "--dds",
                       "--dds-domain", std::to_string(kDomainPreloaded), "--dds-prefix", prefix,
                       "--scene", NEARPOINT_SOURCE_DIR "/examples/dds_scene.json"});
  ASSERT_TRUE(server.started());
  ASSERT_NE(server.wait_for_stderr("event=dds_ready", std::chrono::seconds(20)), "")
      << server.stderr_text();
  ASSERT_NE(server.stderr_text().find("scene_id=dds-demo"), std::string::npos)
      << server.stderr_text();

  const std::string trajectory = NEARPOINT_SOURCE_DIR "/examples/dds_trajectory.jsonl";
  ChildProcess client({NEARPOINT_CLI_PATH, "stream", "--dds", "--dds-domain",
                       std::to_string(kDomainPreloaded), "--dds-prefix", prefix, "dds-demo",
                       trajectory});
  ASSERT_TRUE(client.started());
  ASSERT_EQ(client.wait_exit(std::chrono::seconds(90)), 0) << client.stderr_text() << "\nserver:\n"
                                                           << server.stderr_text();

  std::vector<Json> steps;
  {
    std::ifstream in(trajectory);
    for (std::string line; std::getline(in, line);)
      if (!line.empty()) steps.push_back(Json::parse(line));
  }
  const std::vector<std::string> lines = client.stdout_lines();
  ASSERT_EQ(lines.size(), steps.size()) << client.stderr_text();
  // Distance from the vertical axis through (ax, ay) to the cube (half side 0.5) at (cx, cy)
  // turned by theta about z, minus the round shape's radius; 0 when they overlap.
  auto axis_to_cube = [](double ax, double ay, double cx, double cy, double theta, double r) {
    const double dx = ax - cx, dy = ay - cy;
    const double u = std::cos(theta) * dx + std::sin(theta) * dy;  // into the cube's frame
    const double v = -std::sin(theta) * dx + std::cos(theta) * dy;
    const double gap =
        std::hypot(std::max(std::abs(u) - 0.5, 0.0), std::max(std::abs(v) - 0.5, 0.0));
    return std::max(gap - r, 0.0);
  };
  int touching = 0;
  for (std::size_t k = 0; k < lines.size(); ++k) {
    SCOPED_TRACE("line " + std::to_string(k + 1));
    const Json report = Json::parse(lines[k]);
    ASSERT_EQ(report.at("sequence").get<std::uint64_t>(), k + 1);
    ASSERT_EQ(report.at("status"), "ok") << lines[k];
    const Json& mover = steps[k].at("poses").at("mover");
    const double w = mover.at("rotation")[0], qz = mover.at("rotation")[3];
    const double theta = 2 * std::atan2(qz, w);
    const double cx = mover.at("translation")[0], cy = mover.at("translation")[1];
    std::map<std::string, double> truth = {{"mover/post", axis_to_cube(0, 0, cx, cy, theta, 0.2)},
                                           {"mover/drum", axis_to_cube(3, 0, cx, cy, theta, 0.3)},
                                           {"post/drum", 3 - 0.2 - 0.3}};
    ASSERT_EQ(report.at("pairs").size(), 3u);
    for (const Json& pair : report.at("pairs")) {
      const std::string key =
          pair.at("object_a").get<std::string>() + "/" + pair.at("object_b").get<std::string>();
      ASSERT_TRUE(truth.count(key)) << key;
      EXPECT_NEAR(pair.at("distance").get<double>(), truth[key],
                  pair.at("error_bound").get<double>() + 1e-12)
          << key;
      touching += truth[key] == 0;
    }
  }
  EXPECT_GT(touching, 0) << "the shipped path reaches the post or the drum";

  // The same path with --mode global and a threshold on the mover's pairs, over DDS: each
  // report holds one pair and names mode 4, and the events are exactly the rule applied to the
  // closed-form distances (ENTER below 0.3, EXIT above 0.3 + 0.1), each with its sequence.
  ChildProcess watcher({NEARPOINT_CLI_PATH, "stream", "--dds", "--dds-domain",
                        std::to_string(kDomainPreloaded), "--dds-prefix", prefix, "dds-demo",
                        trajectory, "--mode", "global", "--threshold",
                        "0.3,hysteresis=0.1,object=mover,name=near"});
  ASSERT_TRUE(watcher.started());
  ASSERT_EQ(watcher.wait_exit(std::chrono::seconds(90)), 0) << watcher.stderr_text();
  const std::vector<std::string> watched = watcher.stdout_lines();
  ASSERT_EQ(watched.size(), steps.size()) << watcher.stderr_text();
  std::map<std::string, bool> inside;
  std::vector<std::string> expected, got;
  for (std::size_t k = 0; k < watched.size(); ++k) {
    const Json report = Json::parse(watched[k]);
    EXPECT_EQ(report.at("report_mode"), "global") << watched[k];
    EXPECT_EQ(report.at("pairs").size(), 1u) << watched[k];
    const Json& mover = steps[k].at("poses").at("mover");
    const double w = mover.at("rotation")[0], qz = mover.at("rotation")[3];
    const double theta = 2 * std::atan2(qz, w);
    const double cx = mover.at("translation")[0], cy = mover.at("translation")[1];
    const std::map<std::string, double> truth = {
        {"mover/post", axis_to_cube(0, 0, cx, cy, theta, 0.2)},
        {"mover/drum", axis_to_cube(3, 0, cx, cy, theta, 0.3)}};
    for (const auto& [key, d] : truth) {
      bool& in = inside[key];
      if (!in && d < 0.3) in = true, expected.push_back(std::to_string(k + 1) + " enter " + key);
      if (in && d > 0.4) in = false, expected.push_back(std::to_string(k + 1) + " exit " + key);
    }
    if (report.contains("events"))
      for (const Json& e : report.at("events")) {
        EXPECT_EQ(e.at("threshold"), "near");
        got.push_back(std::to_string(e.at("sequence").get<std::uint64_t>()) + " " +
                      e.at("crossing").get<std::string>() + " " +
                      e.at("object_a").get<std::string>() + "/" +
                      e.at("object_b").get<std::string>());
      }
  }
  EXPECT_GE(expected.size(), 2u);
  std::sort(expected.begin(), expected.end());
  std::sort(got.begin(), got.end());
  EXPECT_EQ(got, expected);
  server.signal(SIGTERM);
  EXPECT_EQ(server.wait_exit(std::chrono::seconds(30)), 0) << server.stderr_text();
}

}  // namespace
}  // namespace nearpoint::dds_testing
