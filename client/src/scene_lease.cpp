// SPDX-License-Identifier: Apache-2.0
#include "scene_lease.hpp"

#include <atomic>
#include <csignal>
#include <cstring>
#include <ostream>
#include <utility>

namespace nearpoint::cli {
namespace {

// Written by the handler, read by the commands' loops: lock-free, so async-signal-safe.
std::atomic<int> g_interrupt{0};
static_assert(std::atomic<int>::is_always_lock_free);

extern "C" void on_interrupt(int signal_number) {
  g_interrupt.store(signal_number, std::memory_order_relaxed);
}

}  // namespace

void install_interrupt_handlers() {
  static const bool installed = [] {
    struct sigaction action;
    std::memset(&action, 0, sizeof action);
    action.sa_handler = on_interrupt;
    sigemptyset(&action.sa_mask);
    // One-shot: the default action comes back, so a second Ctrl-C ends a command that hangs.
    action.sa_flags = SA_RESETHAND | SA_RESTART;
    sigaction(SIGINT, &action, nullptr);
    sigaction(SIGTERM, &action, nullptr);
    return true;
  }();
  (void)installed;
}

int interrupt_signal() {
  return g_interrupt.load(std::memory_order_relaxed);
}

int interrupted_exit_code() {
  return 128 + interrupt_signal();
}

SceneLease::SceneLease(client::Client& client, std::string scene_id, bool owned, bool keep,
                       std::string command, std::ostream& err)
    : client_(client),
      scene_id_(std::move(scene_id)),
      owned_(owned),
      keep_(keep),
      command_(std::move(command)),
      err_(err) {}

SceneLease::~SceneLease() {
  release();
}

void SceneLease::release() {
  if (!owned_) return;
  owned_ = false;
  if (keep_) {
    err_ << command_ << ": kept scene " << scene_id_ << " (delete it with `nearpoint scene delete "
         << scene_id_ << "`)\n";
    return;
  }
  const client::Status deleted = client_.delete_scene(scene_id_);
  if (!deleted.ok())
    err_ << command_ << ": could not delete scene " << scene_id_ << ": " << deleted.describe()
         << "\n";
}

}  // namespace nearpoint::cli
