// The real nearpointd binary as a child process: it binds 127.0.0.1:0, writes the port file,
// serves a stream, and on SIGTERM drains the stream and exits 0. Its stderr (structured logs) is
// read through a pipe, which also tells when it is listening — no sleeping.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <future>
#include <mutex>
#include <thread>

#include "scene_fixture.hpp"

extern char** environ;

namespace nearpoint::server::testing {
namespace {

/// A child nearpointd whose stderr is collected line by line by a reader thread.
class Daemon {
 public:
  explicit Daemon(std::vector<std::string> arguments) {
    int pipe_fds[2];
    if (pipe(pipe_fds) != 0) return;
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDERR_FILENO);
    posix_spawn_file_actions_addclose(&actions, pipe_fds[0]);
    arguments.insert(arguments.begin(), NEARPOINTD_PATH);
    std::vector<char*> argv;
    for (std::string& a : arguments) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (posix_spawn(&pid_, NEARPOINTD_PATH, &actions, nullptr, argv.data(), environ) != 0)
      pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
    close(pipe_fds[1]);
    reader_ = std::thread([this, fd = pipe_fds[0]] { read_lines(fd); });
  }

  ~Daemon() {
    if (pid_ > 0 && !exited_) {
      kill(pid_, SIGKILL);
      int status = 0;
      waitpid(pid_, &status, 0);
    }
    if (reader_.joinable()) reader_.join();
  }

  bool started() const { return pid_ > 0; }

  /// Waits until a stderr line contains `needle`; returns that line, or "" after `timeout`.
  std::string wait_for_line(const std::string& needle, std::chrono::seconds timeout) {
    std::unique_lock lock(mutex_);
    std::string found;
    changed_.wait_for(lock, timeout, [&] {
      for (const std::string& line : lines_)
        if (line.find(needle) != std::string::npos) {
          found = line;
          return true;
        }
      return closed_;
    });
    return found;
  }

  void signal(int number) { kill(pid_, number); }

  /// Waits for the exit (bounded); returns the exit status, or -1 on timeout or a signal death.
  int wait_exit(std::chrono::seconds timeout) {
    auto waiter = std::async(std::launch::async, [pid = pid_] {
      int status = 0;
      waitpid(pid, &status, 0);
      return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    });
    if (waiter.wait_for(timeout) != std::future_status::ready) {
      kill(pid_, SIGKILL);
      waiter.wait();
      exited_ = true;
      return -1;
    }
    exited_ = true;
    return waiter.get();
  }

  std::string log() {
    std::lock_guard lock(mutex_);
    std::string out;
    for (const std::string& line : lines_) out += line + "\n";
    return out;
  }

 private:
  void read_lines(int fd) {
    std::string partial;
    char buffer[4096];
    for (;;) {
      const ssize_t n = read(fd, buffer, sizeof buffer);
      if (n <= 0) break;
      partial.append(buffer, std::size_t(n));
      std::size_t newline;
      while ((newline = partial.find('\n')) != std::string::npos) {
        std::lock_guard lock(mutex_);
        lines_.push_back(partial.substr(0, newline));
        partial.erase(0, newline + 1);
        changed_.notify_all();
      }
    }
    close(fd);
    std::lock_guard lock(mutex_);
    closed_ = true;
    changed_.notify_all();
  }

  pid_t pid_ = -1;
  bool exited_ = false;
  std::thread reader_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<std::string> lines_;
  bool closed_ = false;
};

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          (name + "." + std::to_string(getpid()) + "." +
           ::testing::UnitTest::GetInstance()->current_test_info()->name()))
      .string();
}

TEST(NearpointdProcess, ServesAStreamAndDrainsOnSigterm) {
  const std::string port_file = temp_path("nearpointd.port");
  std::filesystem::remove(port_file);
  Daemon daemon({"--listen", "127.0.0.1:0", "--port-file", port_file, "--workers", "2"});
  ASSERT_TRUE(daemon.started());
  const std::string listening = daemon.wait_for_line("event=listening", std::chrono::seconds(20));
  ASSERT_FALSE(listening.empty()) << daemon.log();
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
  EXPECT_EQ(daemon.wait_exit(std::chrono::seconds(15)), 0) << daemon.log();
  const std::string log = daemon.log();
  EXPECT_NE(log.find("event=stream_closed"), std::string::npos) << log;
  EXPECT_NE(log.find("status=drained"), std::string::npos) << log;
  EXPECT_NE(log.find("event=shutdown_complete"), std::string::npos) << log;
  std::filesystem::remove(port_file);
}

TEST(NearpointdProcess, SigintAlsoShutsDownCleanly) {
  Daemon daemon({"--listen", "127.0.0.1:0"});
  ASSERT_TRUE(daemon.started());
  ASSERT_FALSE(daemon.wait_for_line("event=listening", std::chrono::seconds(20)).empty())
      << daemon.log();
  daemon.signal(SIGINT);
  EXPECT_EQ(daemon.wait_exit(std::chrono::seconds(15)), 0) << daemon.log();
}

// gRPC sets SO_REUSEPORT by default, so a second server could silently share a port in use;
// nearpointd turns it off and must fail to start instead.
TEST(NearpointdProcess, PortInUseIsAnErrorNotASharedPort) {
  RunningServer first = start_server();
  ASSERT_TRUE(first.server);
  Daemon daemon({"--listen", first.address});
  ASSERT_TRUE(daemon.started());
  EXPECT_EQ(daemon.wait_exit(std::chrono::seconds(15)), 1) << daemon.log();
  EXPECT_NE(daemon.log().find("event=start_failed"), std::string::npos) << daemon.log();
}

TEST(NearpointdProcess, BadFlagsExitWithStatus2) {
  Daemon daemon({"--workers", "-3"});
  ASSERT_TRUE(daemon.started());
  EXPECT_EQ(daemon.wait_exit(std::chrono::seconds(15)), 2) << daemon.log();
}

}  // namespace
}  // namespace nearpoint::server::testing
