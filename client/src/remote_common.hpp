// SPDX-License-Identifier: Apache-2.0
// Shared by the server-facing verbs (register, scene, query, stream, load, demo): exit codes,
// reports as JSON, mesh loading for geometry and scene files.
#pragma once

#include <chrono>
#include <iosfwd>
#include <memory>
#include <optional>
#include <string>

#include "json_shapes.hpp"
#include "nearpoint/client/client.hpp"
#include "nearpoint/formats/scene_file.hpp"
#include "nearpoint/model/exit_codes.hpp"

namespace nearpoint::cli {

/// Exit codes of the server-facing verbs: the one table of both binaries
/// (nearpoint/model/exit_codes.hpp), under the names these verbs' code reads best with.
inline constexpr int kExitServerError = model::kExitFailure;      ///< the server answered an error
inline constexpr int kExitBadInput = model::kExitUsage;           ///< bad command line or file
inline constexpr int kExitUnreachable = model::kExitUnavailable;  ///< no server, or nearpointd
                                                                  ///< could not be started

/// The exit code for a failed call: 3 when the server could not be reached, else 1.
int exit_code_for(const client::Status& status);

/// The default --target: $NEARPOINT_TARGET, else 127.0.0.1:50051.
std::string default_target();

/// Options shared by the server-facing verbs.
struct RemoteOptions {
  std::string target = default_target();
  bool json = false;
  std::chrono::milliseconds timeout{10000};
  /// TLS and token files (--tls-ca, --tls-cert, --tls-key, --token-file; empty: not given).
  std::string tls_ca;
  std::string tls_server_name;
  std::string tls_cert;
  std::string tls_key;
  std::string token_file;
};

/// The client options of --timeout, --tls-* and --token-file (the files read), or nothing (the
/// reason printed to `err`) when one cannot be read.
std::optional<client::ClientOptions> client_options(const RemoteOptions& remote, std::ostream& err);
/// A client with those options, or nullptr (the reason printed to `err`).
std::unique_ptr<client::Client> connect(const RemoteOptions& remote, std::ostream& err);

/// Mesh files → convex pieces (nearpoint_mesh_import), or an error when built without it.
formats::MeshLoader mesh_loader();
/// True when this build can read mesh files.
bool have_mesh_import();

Json to_json(const client::Report& report);
Json to_json(const client::GeometryInfo& info);

/// "arm=1,2,3" or "arm=1,2,3,w,x,y,z" (translation, then an optional quaternion).
bool parse_pose_argument(const std::string& text, client::ObjectPose& out, std::string& error);

/// `nearpoint stream --threshold SPEC`: comma-separated, a bare number or `distance=D` first,
/// then any of `hysteresis=H`, `pair=A:B`, `object=A`, `groups=BITS`, `name=NAME`. Without
/// pair/object every selected pair is watched. The server checks the values (and names the
/// field); here only the syntax.
bool parse_threshold_argument(const std::string& text, client::Threshold& out, std::string& error);

}  // namespace nearpoint::cli
