// SPDX-License-Identifier: Apache-2.0
// `nearpoint scene list|show|delete` and `nearpoint geometry list|show|remove`: what is stored on
// the server (ListScenes, DeleteScene, ListGeometries, RemoveGeometry). Human-readable tables by
// default, JSON with --json; an unknown id is a server error (NOT_FOUND, exit 1).
#pragma once

#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

#include "remote_common.hpp"

namespace CLI {
class App;
}

namespace nearpoint::cli {

struct ManageOptions {
  RemoteOptions remote;
  /// show: one id; delete/remove: one or more.
  std::vector<std::string> ids;
};

int run_scene_list(const ManageOptions& options, std::ostream& out, std::ostream& err);
int run_scene_show(const ManageOptions& options, std::ostream& out, std::ostream& err);
/// Deletes every id given; the exit code is the first failure's (the others are still tried).
int run_scene_delete(const ManageOptions& options, std::ostream& out, std::ostream& err);
int run_geometry_list(const ManageOptions& options, std::ostream& out, std::ostream& err);
int run_geometry_show(const ManageOptions& options, std::ostream& out, std::ostream& err);
int run_geometry_remove(const ManageOptions& options, std::ostream& out, std::ostream& err);

/// Declares --target, --json, TLS, … on a command (main.cpp's, shared by every remote verb).
using RemoteOptionAdder = std::function<void(CLI::App&, RemoteOptions&)>;

/// Adds list, show and delete under `scene` (which already has `create`).
void add_scene_management(CLI::App& scene, int& exit_code, const RemoteOptionAdder& add_remote,
                          const std::string& exit_codes_help);
/// Adds `geometry` with list, show and remove to `app`.
void add_geometry_subcommand(CLI::App& app, int& exit_code, const RemoteOptionAdder& add_remote,
                             const std::string& exit_codes_help);

}  // namespace nearpoint::cli
