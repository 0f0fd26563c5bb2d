// SPDX-License-Identifier: Apache-2.0
// A child process whose stdout and stderr are collected line by line by reader threads, so a test
// can wait for a log line (no sleeping) and read a client's output. Waits are bounded; a child
// still running when the object goes away is killed. Used by the tests that run nearpointd or the
// nearpoint CLI as real processes, and by nearpoint_dds_bench.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <future>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace nearpoint::testkit {

class ChildProcess {
 public:
  explicit ChildProcess(std::vector<std::string> argv) {
    int out_fds[2], err_fds[2];
    if (pipe(out_fds) != 0) return;
    if (pipe(err_fds) != 0) {
      close(out_fds[0]);
      close(out_fds[1]);
      return;
    }
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, out_fds[1], STDOUT_FILENO);
    posix_spawn_file_actions_adddup2(&actions, err_fds[1], STDERR_FILENO);
    posix_spawn_file_actions_addclose(&actions, out_fds[0]);
    posix_spawn_file_actions_addclose(&actions, err_fds[0]);
    std::vector<char*> args;
    for (std::string& a : argv) args.push_back(a.data());
    args.push_back(nullptr);
    if (posix_spawn(&pid_, args[0], &actions, nullptr, args.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
    close(out_fds[1]);
    close(err_fds[1]);
    readers_.emplace_back([this, fd = out_fds[0]] { read_lines(fd, out_); });
    readers_.emplace_back([this, fd = err_fds[0]] { read_lines(fd, err_); });
  }

  ~ChildProcess() {
    if (pid_ > 0 && !exited_) {
      kill(pid_, SIGKILL);
      int status = 0;
      waitpid(pid_, &status, 0);
    }
    for (std::thread& reader : readers_)
      if (reader.joinable()) reader.join();
  }

  bool started() const { return pid_ > 0; }
  void signal(int number) {
    if (pid_ > 0 && !exited_) kill(pid_, number);
  }

  /// Waits until a stderr line contains `needle`; that line, or "" after `timeout` or at exit.
  std::string wait_for_stderr(const std::string& needle, std::chrono::seconds timeout) {
    std::unique_lock lock(mutex_);
    std::string found;
    changed_.wait_for(lock, timeout, [&] {
      for (const std::string& line : err_.lines)
        if (line.find(needle) != std::string::npos) {
          found = line;
          return true;
        }
      return err_.closed;
    });
    return found;
  }

  /// Waits for the exit (bounded) and for its output to be read; the exit status, or -1 on
  /// timeout (the child is then killed) or death by a signal.
  int wait_exit(std::chrono::seconds timeout) {
    auto waiter = std::async(std::launch::async, [pid = pid_] {
      int status = 0;
      waitpid(pid, &status, 0);
      return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    });
    int code = -1;
    if (waiter.wait_for(timeout) != std::future_status::ready) {
      kill(pid_, SIGKILL);
      waiter.wait();
    } else {
      code = waiter.get();
    }
    exited_ = true;
    for (std::thread& reader : readers_)
      if (reader.joinable()) reader.join();
    return code;
  }

  std::vector<std::string> stdout_lines() {
    std::lock_guard lock(mutex_);
    return out_.lines;
  }
  std::string stderr_text() {
    std::lock_guard lock(mutex_);
    std::string text;
    for (const std::string& line : err_.lines) text += line + "\n";
    return text;
  }

 private:
  struct Lines {
    std::vector<std::string> lines;
    bool closed = false;
  };

  void read_lines(int fd, Lines& into) {
    std::string partial;
    char buffer[4096];
    for (;;) {
      const ssize_t n = read(fd, buffer, sizeof buffer);
      if (n <= 0) break;
      partial.append(buffer, std::size_t(n));
      std::size_t newline;
      while ((newline = partial.find('\n')) != std::string::npos) {
        std::lock_guard lock(mutex_);
        into.lines.push_back(partial.substr(0, newline));
        partial.erase(0, newline + 1);
        changed_.notify_all();
      }
    }
    close(fd);
    std::lock_guard lock(mutex_);
    if (!partial.empty()) into.lines.push_back(partial);
    into.closed = true;
    changed_.notify_all();
  }

  pid_t pid_ = -1;
  bool exited_ = false;
  std::mutex mutex_;
  std::condition_variable changed_;
  Lines out_, err_;
  std::vector<std::thread> readers_;
};

}  // namespace nearpoint::testkit
