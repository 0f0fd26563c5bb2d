// SPDX-License-Identifier: Apache-2.0
#include "local_server.hpp"

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <future>
#include <random>

extern char** environ;

namespace nearpoint::cli {

std::string find_nearpointd(const std::string& explicit_path) {
  if (!explicit_path.empty()) return explicit_path;
  if (const char* env = std::getenv("NEARPOINTD"); env != nullptr && *env != '\0') return env;
  std::error_code error;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) {
    for (const auto& candidate : {self.parent_path() / "nearpointd",
                                  self.parent_path().parent_path() / "server" / "nearpointd"})
      if (std::filesystem::exists(candidate, error)) return candidate.string();
  }
  return "nearpointd";  // posix_spawnp searches the PATH
}

LocalServer::~LocalServer() {
  if (pid_ > 0) stop(std::chrono::seconds(5));
  if (reader_.joinable()) reader_.join();
  if (!port_file_.empty()) std::filesystem::remove(port_file_);
}

std::string LocalServer::start(const std::string& binary, int port,
                               const std::vector<std::string>& extra,
                               std::chrono::milliseconds timeout) {
  if (reader_.joinable()) reader_.join();
  {
    std::lock_guard lock(mutex_);
    log_.clear();
    closed_ = false;
  }
  std::random_device random;
  port_file_ = (std::filesystem::temp_directory_path() / ("nearpointd-" + std::to_string(getpid()) +
                                                          "-" + std::to_string(random()) + ".port"))
                   .string();
  std::filesystem::remove(port_file_);
  std::vector<std::string> arguments = {
      binary,        "--listen", "127.0.0.1:" + std::to_string(port), "--port-file", port_file_,
      "--log-level", "info"};
  arguments.insert(arguments.end(), extra.begin(), extra.end());
  std::vector<char*> argv;
  for (std::string& a : arguments) argv.push_back(a.data());
  argv.push_back(nullptr);

  int fds[2];
  if (pipe(fds) != 0) return "cannot create a pipe";
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDERR_FILENO);
  posix_spawn_file_actions_addclose(&actions, fds[0]);
  const int spawned = posix_spawnp(&pid_, binary.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(fds[1]);
  if (spawned != 0) {
    close(fds[0]);
    pid_ = -1;
    return "cannot start " + binary + ": " + std::strerror(spawned) +
           " (build it, or give its path with --nearpointd or $NEARPOINTD)";
  }
  reader_ = std::thread([this, fd = fds[0]] { read_stderr(fd); });

  // The log line says when it listens (or why it could not start); no polling of the port file.
  std::unique_lock lock(mutex_);
  const bool listening = changed_.wait_for(
      lock, timeout, [&] { return log_.find("event=listening") != std::string::npos || closed_; });
  const bool up = listening && log_.find("event=listening") != std::string::npos;
  lock.unlock();
  if (!up) {
    const std::string why =
        listening ? "nearpointd exited during start-up" : "nearpointd did not start in time";
    stop(std::chrono::seconds(2));
    return why + ":\n" + log();
  }
  std::ifstream(port_file_) >> port_;
  if (port_ <= 0) {
    stop(std::chrono::seconds(2));
    return "nearpointd did not write its port file";
  }
  return {};
}

void LocalServer::read_stderr(int fd) {
  char buffer[4096];
  for (;;) {
    const ssize_t n = read(fd, buffer, sizeof buffer);
    if (n <= 0) break;
    std::lock_guard lock(mutex_);
    log_.append(buffer, std::size_t(n));
    changed_.notify_all();
  }
  close(fd);
  std::lock_guard lock(mutex_);
  closed_ = true;
  changed_.notify_all();
}

int LocalServer::stop(std::chrono::milliseconds timeout) {
  if (pid_ <= 0) return -1;
  const pid_t pid = pid_;
  pid_ = -1;
  kill(pid, SIGTERM);
  auto waiter = std::async(std::launch::async, [pid] {
    int status = 0;
    waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  });
  if (waiter.wait_for(timeout) != std::future_status::ready) kill(pid, SIGKILL);
  const int status = waiter.get();
  if (reader_.joinable()) reader_.join();
  return status;
}

void LocalServer::kill_hard() {
  if (pid_ <= 0) return;
  kill(pid_, SIGKILL);
  int status = 0;
  waitpid(pid_, &status, 0);
  pid_ = -1;
  if (reader_.joinable()) reader_.join();
}

std::string LocalServer::log() const {
  std::lock_guard lock(mutex_);
  return log_;
}

}  // namespace nearpoint::cli
