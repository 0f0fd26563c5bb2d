// SPDX-License-Identifier: Apache-2.0
// The server-facing verbs of `nearpoint`: register, scene create, query, stream, load. Each
// takes its options, writes results to `out` (human text, or JSON with --json) and problems to
// `err`, and returns the exit code (remote_common.hpp). main.cpp declares their command lines.
#pragma once

#include <iosfwd>
#include <limits>
#include <string>
#include <vector>

#include "remote_common.hpp"

namespace nearpoint::cli {

struct RegisterOptions {
  RemoteOptions remote;
  /// JSON geometry files (one geometry each) or mesh files (together: one compound geometry).
  std::vector<std::string> files;
  std::string name;
  /// Meshes: one convex hull per file instead of one per mesh part.
  bool merge = false;
  double scale = 1.0;
};
int run_register(const RegisterOptions& options, std::ostream& out, std::ostream& err);

/// `nearpoint health`: the gRPC health protocol; exit 0 when SERVING (a container HEALTHCHECK,
/// a probe), 1 when the server answers anything else, 3 when it cannot be reached.
struct HealthOptions {
  RemoteOptions remote;
  std::string service;  ///< "" = the server as a whole
};
int run_health(const HealthOptions& options, std::ostream& out, std::ostream& err);

/// `nearpoint info`: the server's version, build options, transports and limits (GetServerInfo),
/// as text or, with --json, one JSON object.
int run_info(const RemoteOptions& remote, std::ostream& out, std::ostream& err);

/// Robot descriptions given as scene files (URDF, MJCF): where package:// and relative mesh
/// paths resolve (--package-path), and a URDF's SRDF (--srdf; default FILE.srdf beside it).
struct RobotFileOptions {
  std::vector<std::string> package_path;
  std::string srdf;
};

struct SceneCreateOptions {
  RemoteOptions remote;
  /// A scene file (JSON, YAML) or a robot description (.urdf, MJCF .xml/.mjcf).
  std::string file;
  RobotFileOptions robot;
};
int run_scene_create(const SceneCreateOptions& options, std::ostream& out, std::ostream& err);

/// --mode, --cutoff and --change-tolerance of query and stream (NaN: not given, inherit).
struct ReportModeFlags {
  std::string mode;  // "", all, within-cutoff, nearest, global, changed
  double cutoff = std::numeric_limits<double>::quiet_NaN();
  double change_tolerance = std::numeric_limits<double>::quiet_NaN();
};

struct QueryCommandOptions {
  RemoteOptions remote;
  /// A scene id on the server, or a scene file (created first).
  std::string scene;
  std::vector<std::string> poses;  // OBJECT=tx,ty,tz[,qw,qx,qy,qz]
  bool near_points = false;
  std::string penetration;  // "", none, bound
  ReportModeFlags report;
  /// A scene created from a file is deleted at the end unless this is set (--keep-scene).
  bool keep_scene = false;
};
int run_query(const QueryCommandOptions& options, std::ostream& out, std::ostream& err);

struct StreamCommandOptions {
  RemoteOptions remote;
  std::string scene;  // id, scene file or robot description
  std::string trajectory;
  /// --joints FILE: a JSON Lines trajectory of joint positions (trajectory.hpp), instead of
  /// TRAJECTORY, for a robot scene.
  std::string joints;
  RobotFileOptions robot;
  /// --gradient: ask for gradients (a robot scene's pairs then carry ∂d/∂q, in --json output).
  bool gradient = false;
  std::size_t window = 32;
  bool near_points = false;
  std::string penetration;
  ReportModeFlags report;
  /// --threshold SPECs (see parse_threshold_argument).
  std::vector<std::string> thresholds;
  /// Seconds between progress lines on `err` (human mode); 0: none.
  double progress_every = 0.5;
  /// A scene created from a file is deleted at the end unless this is set (--keep-scene).
  bool keep_scene = false;
};
int run_stream(const StreamCommandOptions& options, std::ostream& out, std::ostream& err);

struct LoadCommandOptions {
  RemoteOptions remote;
  /// Empty: the demo scene and its path (registered here). Otherwise a scene (id or file) and a
  /// trajectory replayed in a loop.
  std::string scene, trajectory;
  std::string nearpointd;  // when target is "local": a nearpointd child
  int streams = 2;
  double duration_s = 3;
  std::size_t window = 1;  // 1: one update in flight per stream (latency); more: throughput
  /// Pose sets per message: 1 on StreamPoses; more on StreamPoseBatches (the window is then at
  /// least one batch).
  std::size_t batch = 1;
  double progress_every = 0.5;
  /// The scene created here (the demo scene, or from a file) is deleted at the end unless this
  /// is set (--keep-scene).
  bool keep_scene = false;
};
int run_load(const LoadCommandOptions& options, std::ostream& out, std::ostream& err);

}  // namespace nearpoint::cli
