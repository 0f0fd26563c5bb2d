// The real nearpointd binary as a child process: it binds 127.0.0.1:0, writes the port file,
// serves a stream, and on SIGTERM drains the stream and exits 0. Its stderr (structured logs) is
// read through a pipe, which also tells when it is listening — no sleeping.
#include <signal.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "common/child_process.hpp"
#include "scene_fixture.hpp"

namespace nearpoint::server::testing {
namespace {

using ::nearpoint::testkit::ChildProcess;

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          (name + "." + std::to_string(getpid()) + "." +
           ::testing::UnitTest::GetInstance()->current_test_info()->name()))
      .string();
}

TEST(NearpointdProcess, ServesAStreamAndDrainsOnSigterm) {
  const std::string port_file = temp_path("nearpointd.port");
  std::filesystem::remove(port_file);
  ChildProcess daemon(
      {NEARPOINTD_PATH, "--listen", "127.0.0.1:0", "--port-file", port_file, "--workers", "2"});
  ASSERT_TRUE(daemon.started());
  const std::string listening = daemon.wait_for_stderr("event=listening", std::chrono::seconds(20));
  ASSERT_FALSE(listening.empty()) << daemon.stderr_text();
  int port = 0;
  std::ifstream(port_file) >> port;
  ASSERT_GT(port, 0);
  EXPECT_NE(listening.find("port=" + std::to_string(port)), std::string::npos) << listening;

  auto channel =
      grpc::CreateChannel("127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials());
  auto stub = v1::DistanceService::NewStub(channel);
  const LocalScene scene = make_scene(*stub);
  StreamClient stream(*stub);
  for (int step = 0; step < 20; ++step) {
    const std::vector<TestPose> poses = trajectory(scene.size(), step);
    ASSERT_TRUE(stream.write(make_update(scene, std::uint64_t(step) + 1, poses)));
    v1::DistanceReport report;
    ASSERT_TRUE(stream.read(report));
    ASSERT_EQ(report.sequence(), std::uint64_t(step) + 1);
    expect_matches_local(scene, poses, report, false);
  }
  for (int step = 20; step < 40; ++step)  // in flight when SIGTERM arrives
    ASSERT_TRUE(
        stream.write(make_update(scene, std::uint64_t(step) + 1, trajectory(scene.size(), step))));

  daemon.signal(SIGTERM);
  std::vector<v1::DistanceReport> reports;
  const grpc::Status status = stream.read_to_end(reports);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << status.error_message();
  ::testing::Test::RecordProperty("drained_reports", int(reports.size()));
  for (std::size_t i = 0; i < reports.size(); ++i) {  // a gap-free prefix, each correct
    ASSERT_EQ(reports[i].sequence(), 21 + i);
    expect_matches_local(scene, trajectory(scene.size(), int(20 + i)), reports[i], false);
  }
  EXPECT_EQ(daemon.wait_exit(std::chrono::seconds(15)), 0) << daemon.stderr_text();
  const std::string log = daemon.stderr_text();
  EXPECT_NE(log.find("event=stream_closed"), std::string::npos) << log;
  EXPECT_NE(log.find("status=drained"), std::string::npos) << log;
  EXPECT_NE(log.find("event=shutdown_complete"), std::string::npos) << log;
  std::filesystem::remove(port_file);
}

TEST(NearpointdProcess, SigintAlsoShutsDownCleanly) {
  ChildProcess daemon({NEARPOINTD_PATH, "--listen", "127.0.0.1:0"});
  ASSERT_TRUE(daemon.started());
  ASSERT_FALSE(daemon.wait_for_stderr("event=listening", std::chrono::seconds(20)).empty())
      << daemon.stderr_text();
  daemon.signal(SIGINT);
  EXPECT_EQ(daemon.wait_exit(std::chrono::seconds(15)), 0) << daemon.stderr_text();
}

// gRPC sets SO_REUSEPORT by default, so a second server could silently share a port in use;
// nearpointd turns it off and must fail to start instead.
TEST(NearpointdProcess, PortInUseIsAnErrorNotASharedPort) {
  RunningServer first = start_server();
  ASSERT_TRUE(first.server);
  ChildProcess daemon({NEARPOINTD_PATH, "--listen", first.address});
  ASSERT_TRUE(daemon.started());
  EXPECT_EQ(daemon.wait_exit(std::chrono::seconds(15)), 1) << daemon.stderr_text();
  EXPECT_NE(daemon.stderr_text().find("event=start_failed"), std::string::npos)
      << daemon.stderr_text();
}

TEST(NearpointdProcess, BadFlagsExitWithStatus2) {
  ChildProcess daemon({NEARPOINTD_PATH, "--workers", "-3"});
  ASSERT_TRUE(daemon.started());
  EXPECT_EQ(daemon.wait_exit(std::chrono::seconds(15)), 2) << daemon.stderr_text();
}

}  // namespace
}  // namespace nearpoint::server::testing
