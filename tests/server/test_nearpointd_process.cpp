// SPDX-License-Identifier: Apache-2.0
// The real nearpointd binary as a child process: it binds 127.0.0.1:0, writes the port file,
// serves a stream, and on SIGTERM drains the stream and exits 0. Its stderr (structured logs) is
// read through a pipe, which also tells when it is listening — no sleeping.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <thread>

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

// Issue 21 item 2 (reports lost at SIGTERM). Guards the drain's order: every stream answers the
// updates it has read, its reports and final status leave the process, and only then does the
// server close its connections and exit. The bug: OnWriteDone(ok) and OnDone only mean gRPC took
// the bytes, not that they were sent; closing the transport at once dropped reports still queued
// behind HTTP/2 flow control (clients saw `UNAVAILABLE: Broken pipe` and ~20 reports fewer).
// Several streams, each on its own connection, pipeline updates and do not read until SIGTERM
// (so reports queue in the transport); then each must receive a gap-free run of reports whose
// count is the count of updates the server says it read, and a status saying "draining".
// Repeated over rounds because the loss was intermittent; bounded in rounds and time.
TEST(NearpointdProcess, SigtermUnderLoadAnswersEveryUpdateReadOnEveryStream) {
  constexpr int kRounds = 10, kStreams = 6, kUpdates = 200;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  int rounds = 0;
  for (; rounds < kRounds && std::chrono::steady_clock::now() < give_up; ++rounds) {
    SCOPED_TRACE("round " + std::to_string(rounds));
    const std::string port_file = temp_path("nearpointd.port");
    std::filesystem::remove(port_file);
    ChildProcess daemon({NEARPOINTD_PATH, "--listen", "127.0.0.1:0", "--port-file", port_file,
                         "--workers", "2", "--max-in-flight", "256",
                         // room for slow (sanitizer) builds: a drain cut short loses reports
                         "--drain-timeout-ms", "10000"});
    ASSERT_TRUE(daemon.started());
    ASSERT_FALSE(daemon.wait_for_stderr("event=listening", std::chrono::seconds(20)).empty())
        << daemon.stderr_text();
    int port = 0;
    std::ifstream(port_file) >> port;
    std::filesystem::remove(port_file);
    ASSERT_GT(port, 0);
    const std::string address = "127.0.0.1:" + std::to_string(port);

    // One channel per stream (distinct argument, so gRPC does not share the connection).
    std::vector<std::shared_ptr<grpc::Channel>> channels;
    std::vector<std::unique_ptr<v1::DistanceService::Stub>> stubs;
    for (int s = 0; s < kStreams; ++s) {
      grpc::ChannelArguments arguments;
      arguments.SetInt("nearpoint.test.stream", s);
      channels.push_back(
          grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), arguments));
      stubs.push_back(v1::DistanceService::NewStub(channels.back()));
    }
    const LocalScene scene = make_scene(*stubs[0]);
    std::vector<std::unique_ptr<StreamClient>> streams;
    for (int s = 0; s < kStreams; ++s) {
      streams.push_back(std::make_unique<StreamClient>(*stubs[std::size_t(s)]));
      for (int step = 0; step < kUpdates; ++step)
        ASSERT_TRUE(streams.back()->write(
            make_update(scene, std::uint64_t(step) + 1, trajectory(scene.size(), step, s))));
    }
    // The first report of every stream: the server is busy with every stream now. (One stream's
    // report is not enough: a stream the server has not yet accepted when SIGTERM arrives is
    // refused "shutting down" with nothing read, and the streams are accepted in no set order.)
    std::vector<std::vector<v1::DistanceReport>> reports(kStreams);
    for (int s = 0; s < kStreams; ++s) {
      v1::DistanceReport first;
      ASSERT_TRUE(streams[std::size_t(s)]->read(first)) << "stream " << s;
      reports[std::size_t(s)].push_back(first);
    }
    daemon.signal(SIGTERM);

    std::vector<grpc::Status> statuses(kStreams);
    std::vector<std::thread> readers;
    for (int s = 0; s < kStreams; ++s)
      readers.emplace_back([&, s] {
        statuses[std::size_t(s)] = streams[std::size_t(s)]->read_to_end(reports[std::size_t(s)]);
      });
    for (std::thread& reader : readers) reader.join();
    EXPECT_EQ(daemon.wait_exit(std::chrono::seconds(30)), 0) << daemon.stderr_text();

    std::uint64_t received = 0;
    for (int s = 0; s < kStreams; ++s) {
      const grpc::Status& status = statuses[std::size_t(s)];
      const auto& got = reports[std::size_t(s)];
      received += got.size();
      EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE)
          << "stream " << s << ": " << status.error_message();
      EXPECT_NE(status.error_message().find("draining"), std::string::npos)
          << "stream " << s << ": " << status.error_message();
      // "… all N updates read on this stream were answered …": N must be what arrived.
      const std::string all = "all ";
      const std::size_t at = status.error_message().find(all);
      EXPECT_NE(at, std::string::npos) << status.error_message();
      if (at != std::string::npos) {
        EXPECT_EQ(std::stoull(status.error_message().substr(at + all.size())), got.size())
            << "stream " << s << ": " << status.error_message();
      }
      for (std::size_t i = 0; i < got.size(); ++i) {  // in order, to the right stream
        ASSERT_EQ(got[i].sequence(), i + 1) << "stream " << s;
        if (i % 10 == 0)
          expect_matches_local(scene, trajectory(scene.size(), int(i), s), got[i], false);
      }
    }
    // The server's own count of updates read over all streams is what the clients received.
    const std::string log = daemon.stderr_text();
    std::uint64_t logged = 0;
    int closed = 0;
    for (std::size_t at = log.find("event=stream_closed"); at != std::string::npos;
         at = log.find("event=stream_closed", at + 1)) {
      const std::size_t updates = log.find(" updates=", at);
      logged += std::stoull(log.substr(updates + 9));
      ++closed;
    }
    EXPECT_EQ(closed, kStreams) << log;
    EXPECT_EQ(logged, received) << log;
    ::testing::Test::RecordProperty("round_" + std::to_string(rounds) + "_reports", int(received));
    if (::testing::Test::HasFailure()) break;
  }
  if (!::testing::Test::HasFailure()) {
    EXPECT_GE(rounds, 3) << "too few rounds in the time given";
  }
}

// Issue 21 item 7 (first point): a client killed with SIGKILL was logged `status=ok`. A vanished
// client ends the server's reads exactly like a half-close (OnReadDone(false)); an idle stream
// then finished OK, and the log could not tell a crash from a clean end. Guards the check of
// the call's cancellation at OnDone. The client is a real process (forked before this process
// touches gRPC), idle on an open stream when it is killed; a half-closing client, for contrast,
// must still be logged ok.
TEST(NearpointdProcess, ClientKilledWithSigkillIsLoggedCancelled) {
#if defined(__SANITIZE_THREAD__)
  // The client is a fork of this (multi-threaded) test process that starts gRPC's threads: TSan
  // does not support threads started after such a fork and kills the child. The main and ASan
  // builds run this test.
  GTEST_SKIP() << "forks a gRPC client from a multi-threaded process, which TSan cannot follow";
#endif
  ChildProcess daemon({NEARPOINTD_PATH, "--listen", "127.0.0.1:0", "--workers", "1"});
  ASSERT_TRUE(daemon.started());
  const std::string listening = daemon.wait_for_stderr("event=listening", std::chrono::seconds(20));
  ASSERT_FALSE(listening.empty()) << daemon.stderr_text();
  const std::string address =
      "127.0.0.1:" + std::to_string(std::stoi(listening.substr(listening.find(" port=") + 6)));

  const pid_t client = fork();
  ASSERT_GE(client, 0);
  if (client == 0) {  // the client: one update (refused: no such scene), then idle until killed
    auto stub = v1::DistanceService::NewStub(
        grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
    auto stream = stub->StreamPoses(&context);
    v1::PoseUpdate update;
    update.set_scene_id("no-such-scene");
    update.set_sequence(1);
    v1::DistanceReport report;
    if (stream->Write(update) && stream->Read(&report)) stream->Read(&report);  // blocks
    _exit(0);
  }
  const bool answered =
      !daemon.wait_for_stderr("event=update_rejected", std::chrono::seconds(20)).empty();
  kill(client, SIGKILL);
  int wait_status = 0;
  waitpid(client, &wait_status, 0);
  ASSERT_TRUE(answered) << daemon.stderr_text();
  ASSERT_TRUE(WIFSIGNALED(wait_status));
  const std::string killed =
      daemon.wait_for_stderr("event=stream_closed", std::chrono::seconds(20));
  EXPECT_NE(killed.find("stream=1 "), std::string::npos) << killed;
  EXPECT_NE(killed.find("status=cancelled"), std::string::npos) << killed;

  // Contrast: a client that half-closes and reads the status is logged ok.
  auto stub = v1::DistanceService::NewStub(
      grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
  StreamClient stream(*stub);
  EXPECT_TRUE(stream.finish().ok());
  const std::string closed = daemon.wait_for_stderr("stream=2 updates", std::chrono::seconds(20));
  EXPECT_NE(closed.find("status=ok"), std::string::npos) << closed;
  daemon.signal(SIGTERM);
  EXPECT_EQ(daemon.wait_exit(std::chrono::seconds(15)), 0) << daemon.stderr_text();
}

// Faults against a real nearpointd, all at once, bounded: 12 well-behaved streams (on 3 shared
// connections, writer and reader threads each, sequence numbers and trajectories their own)
// next to clients that vanish mid-stream (cancel), half-close at once, send garbage, send a
// message over --max-message-bytes, and send 200 nested groups. Guards the per-stream isolation
// of the reactor: every update of a well-behaved stream is answered exactly once, in order, with
// its own stream's distances, and ends OK; each misbehaving stream gets its own status, and the
// server serves a new stream afterwards and drains on SIGTERM.
TEST(NearpointdProcess, EveryStreamAnswersItsOwnUpdatesOnceInOrderAmidMisbehavingClients) {
  ChildProcess daemon({NEARPOINTD_PATH, "--listen", "127.0.0.1:0", "--workers", "2",
                       "--max-message-bytes", "65536"});
  ASSERT_TRUE(daemon.started());
  const std::string listening = daemon.wait_for_stderr("event=listening", std::chrono::seconds(20));
  ASSERT_FALSE(listening.empty()) << daemon.stderr_text();
  const std::string address =
      "127.0.0.1:" + std::to_string(std::stoi(listening.substr(listening.find(" port=") + 6)));
  std::vector<std::shared_ptr<grpc::Channel>> channels;
  std::vector<std::unique_ptr<v1::DistanceService::Stub>> stubs;
  for (int c = 0; c < 3; ++c) {
    grpc::ChannelArguments arguments;
    arguments.SetInt("nearpoint.test.connection", c);  // distinct arguments: distinct connections
    channels.push_back(
        grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), arguments));
    stubs.push_back(v1::DistanceService::NewStub(channels.back()));
  }
  const LocalScene scene = make_scene(*stubs[0]);
  constexpr int kGood = 12, kUpdates = 100;

  std::vector<std::thread> threads;
  std::vector<grpc::Status> good_status(kGood);
  std::vector<std::string> good_failure(kGood);
  for (int s = 0; s < kGood; ++s)
    threads.emplace_back([&, s] {
      StreamClient stream(*stubs[std::size_t(s % 3)]);
      const std::uint64_t base = std::uint64_t(s + 1) * 100000;
      std::thread writer([&] {
        for (int i = 0; i < kUpdates; ++i)
          if (!stream.write(make_update(scene, base + std::uint64_t(i),
                                        trajectory(scene.size(), i, 0.37 * s))))
            return;
        stream.writes_done();
      });
      int i = 0;
      for (v1::DistanceReport report; stream.read(report); ++i) {
        if (i >= kUpdates || report.sequence() != base + std::uint64_t(i) || report.has_error()) {
          good_failure[std::size_t(s)] =
              "report " + std::to_string(i) + " has sequence " + std::to_string(report.sequence());
          break;
        }
        if (i % 25 == 0)  // its own stream's poses (each stream has its own trajectory)
          expect_matches_local(scene, trajectory(scene.size(), i, 0.37 * s), report, false);
      }
      writer.join();
      std::vector<v1::DistanceReport> rest;  // none unless the loop above stopped early
      good_status[std::size_t(s)] = stream.read_to_end(rest);  // half-closed by the writer
      if (good_failure[std::size_t(s)].empty() && i != kUpdates)
        good_failure[std::size_t(s)] = std::to_string(i) + " reports";
    });

  // Vanishes: 20 updates sent, 3 reports read, then the call is cancelled.
  grpc::Status vanished;
  threads.emplace_back([&] {
    StreamClient stream(*stubs[0]);
    for (int i = 0; i < 20; ++i)
      stream.write(make_update(scene, 1 + std::uint64_t(i), trajectory(scene.size(), i)));
    v1::DistanceReport report;
    for (int i = 0; i < 3; ++i) stream.read(report);
    stream.context().TryCancel();
    vanished = stream.finish();
  });
  // Half-closes at once.
  grpc::Status half_closed;
  threads.emplace_back([&] { half_closed = StreamClient(*stubs[1]).finish(); });
  // Over the receive limit: one update with a 100 kB scene id.
  grpc::Status oversized;
  threads.emplace_back([&] {
    StreamClient stream(*stubs[2]);
    v1::PoseUpdate update = make_update(scene, 1, trajectory(scene.size(), 0));
    update.set_scene_id(std::string(100000, 'x'));
    stream.write(update);
    oversized = stream.finish();
  });
  // Garbage, and 200 nested groups, each after a valid update.
  std::vector<grpc::Status> malformed(2);
  std::vector<std::size_t> malformed_reports(2);
  const std::string bad[2] = {std::string("\xFF\xFF\xFF\xFF\x0F", 5),
                              std::string(200, '\x7B') + std::string(200, '\x7C')};
  for (int m = 0; m < 2; ++m)
    threads.emplace_back([&, m] {
      RawStream stream(channels[std::size_t(m)], "/nearpoint.v1.DistanceService/StreamPoses");
      stream.write(make_update(scene, 1, trajectory(scene.size(), 1)).SerializeAsString());
      stream.write(bad[m]);
      stream.write(make_update(scene, 2, trajectory(scene.size(), 2)).SerializeAsString());
      for (std::string bytes; stream.read(bytes);) ++malformed_reports[std::size_t(m)];
      malformed[std::size_t(m)] = stream.finish();
    });
  for (std::thread& thread : threads) thread.join();

  for (int s = 0; s < kGood; ++s) {
    EXPECT_TRUE(good_status[std::size_t(s)].ok())
        << "stream " << s << ": " << good_status[std::size_t(s)].error_message();
    EXPECT_EQ(good_failure[std::size_t(s)], "") << "stream " << s;
  }
  EXPECT_EQ(vanished.error_code(), grpc::StatusCode::CANCELLED) << vanished.error_message();
  EXPECT_TRUE(half_closed.ok()) << half_closed.error_message();
  EXPECT_EQ(oversized.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED)
      << oversized.error_message();
  for (int m = 0; m < 2; ++m) {
    EXPECT_EQ(malformed[std::size_t(m)].error_code(), grpc::StatusCode::INVALID_ARGUMENT)
        << malformed[std::size_t(m)].error_message();
    EXPECT_EQ(malformed_reports[std::size_t(m)], 1u);  // the update before the bad message
  }
  EXPECT_NE(malformed[1].error_message().find("deeper than 100"), std::string::npos)
      << malformed[1].error_message();

  // Still serving: a new stream is answered.
  StreamClient after(*stubs[0]);
  ASSERT_TRUE(after.write(make_update(scene, 7, trajectory(scene.size(), 7))));
  v1::DistanceReport report;
  ASSERT_TRUE(after.read(report));
  EXPECT_EQ(report.sequence(), 7u);
  EXPECT_TRUE(after.finish().ok());
  daemon.signal(SIGTERM);
  EXPECT_EQ(daemon.wait_exit(std::chrono::seconds(20)), 0) << daemon.stderr_text();
  const std::string log = daemon.stderr_text();
  EXPECT_NE(log.find("status=cancelled"), std::string::npos) << log;
  EXPECT_NE(log.find("status=invalid_argument"), std::string::npos) << log;
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
// nearpointd turns it off and must fail to start instead, with the exit status of something
// unavailable (3: retrying later may succeed).
TEST(NearpointdProcess, PortInUseIsAnErrorNotASharedPort) {
  RunningServer first = start_server();
  ASSERT_TRUE(first.server);
  ChildProcess daemon({NEARPOINTD_PATH, "--listen", first.address});
  ASSERT_TRUE(daemon.started());
  EXPECT_EQ(daemon.wait_exit(std::chrono::seconds(15)), 3) << daemon.stderr_text();
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
