// SPDX-License-Identifier: Apache-2.0
// Scenes a command creates for its own use (load, demo --target, query/stream on a scene file) are
// deleted when the command ends — also when it is interrupted — unless the user asks to keep
// them (--keep-scene). Otherwise every run would leave a scene behind until --max-scenes refuses
// new ones.
//
// Interrupts: install_interrupt_handlers() turns the first SIGINT or SIGTERM into a flag that the
// commands poll between updates; they stop pushing, let the stream close, delete their scene and
// exit 128 + the signal's number (130 for SIGINT, 143 for SIGTERM), as a shell reports a command
// killed by it. The handlers are one-shot: a second Ctrl-C terminates at once.
#pragma once

#include <iosfwd>
#include <string>

#include "nearpoint/client/client.hpp"

namespace nearpoint::cli {

/// Installs the one-shot SIGINT/SIGTERM handlers (idempotent).
void install_interrupt_handlers();
/// The signal that interrupted this process (SIGINT, SIGTERM), or 0.
int interrupt_signal();
/// 128 + interrupt_signal().
int interrupted_exit_code();

/// Owns a scene on the server for the lifetime of one command. When `owned` (the command created
/// it) the scene is deleted by release() or the destructor, unless `keep`: then its id is printed
/// to `err` instead, so that the user can find it again.
class SceneLease {
 public:
  SceneLease(client::Client& client, std::string scene_id, bool owned, bool keep,
             std::string command, std::ostream& err);
  ~SceneLease();
  SceneLease(const SceneLease&) = delete;
  SceneLease& operator=(const SceneLease&) = delete;

  /// Deletes (or reports as kept) the scene now; later calls do nothing. A failed delete is
  /// reported on `err` (naming the scene, so that it can be deleted by hand); it does not change
  /// the command's exit status, which is about the command's own work.
  void release();

 private:
  client::Client& client_;
  std::string scene_id_;
  bool owned_;
  bool keep_;
  std::string command_;
  std::ostream& err_;
};

}  // namespace nearpoint::cli
