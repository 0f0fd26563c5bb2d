// SPDX-License-Identifier: Apache-2.0
// A nearpointd child process on 127.0.0.1:0, for `nearpoint demo` (and `load`) when no --target
// is given, and for tests: started, its port read back from --port-file once it logs that it is
// listening, stopped with SIGTERM (it drains and exits 0).
#pragma once

#include <sys/types.h>

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace nearpoint::cli {

/// Where nearpointd is: `explicit_path` if given, else $NEARPOINTD, else beside this executable
/// (installed) or in the build tree's server/ directory, else "nearpointd" on the PATH.
std::string find_nearpointd(const std::string& explicit_path);

class LocalServer {
 public:
  LocalServer() = default;
  ~LocalServer();
  LocalServer(const LocalServer&) = delete;
  LocalServer& operator=(const LocalServer&) = delete;

  /// Starts `binary` with --listen 127.0.0.1:PORT (0: any free port) and `extra` arguments, and
  /// waits (at most `timeout`) until it listens. Returns "" or why it could not.
  std::string start(const std::string& binary, int port, const std::vector<std::string>& extra,
                    std::chrono::milliseconds timeout = std::chrono::seconds(20));
  int port() const { return port_; }
  std::string target() const { return "127.0.0.1:" + std::to_string(port_); }
  /// SIGTERM and wait (bounded; then SIGKILL). Returns the exit status, or -1.
  int stop(std::chrono::milliseconds timeout = std::chrono::seconds(10));
  /// SIGKILL: the server dies without draining (tests of reconnection).
  void kill_hard();
  bool running() const { return pid_ > 0; }
  /// The child's stderr so far (its structured log).
  std::string log() const;

 private:
  void read_stderr(int fd);

  pid_t pid_ = -1;
  int port_ = 0;
  std::string port_file_;
  std::thread reader_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::string log_;
  bool closed_ = false;
};

}  // namespace nearpoint::cli
