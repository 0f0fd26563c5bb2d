// SPDX-License-Identifier: Apache-2.0
// The `nearpoint` command-line tool. One CLI11 subcommand per verb; each `add_*_subcommand`
// function declares its arguments and help and runs its command from the callback, setting the
// process's exit code. `distance` is local; register, scene, query, stream, load and demo talk to
// nearpointd through nearpoint::client (remote_commands.cpp, demo.cpp).
#include <algorithm>
#include <cerrno>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>

#include <unistd.h>
#include <CLI/CLI.hpp>

#include "distance_command.hpp"
#ifdef NEARPOINT_WITH_REMOTE
#include "demo.hpp"
#include "manage_commands.hpp"
#include "remote_commands.hpp"
#endif
#include "nearpoint/model/exit_codes.hpp"
#include "nearpoint/model/vocabulary.hpp"
#include "nearpoint/options.hpp"
#include "nearpoint/version.hpp"
#if NEARPOINT_HAVE_DDS
#include "dds_load.hpp"
#include "dds_stream.hpp"
#include "dds_topics.hpp"
#endif

namespace {

using nearpoint::cli::kExitIoError;
using nearpoint::cli::kExitOk;

using nearpoint::model::kExitUsage;

// Progress lines rewrite themselves with '\r': on a terminal only, never into a log or a pipe.
bool stderr_is_terminal() {
  return isatty(STDERR_FILENO) == 1;
}

// Pads an option's name and default to the column where the help text describes it.
std::string pad(std::string text) {
  constexpr std::size_t kColumn = 34;
  text.resize(std::max(text.size() + 1, kColumn), ' ');
  return text;
}

// The defaults quoted in the help are read from the engine's options, so they cannot drift.
std::string distance_footer() {
  const nearpoint::DistanceOptions<double> defaults;
  nearpoint::cli::Json epsilon = defaults.epsilon;
  const char* near_points = defaults.near_points ? "true" : "false";
  std::ostringstream text;
  text << R"(
Reads one JSON object per line from FILE (or standard input) and writes one result per line to
standard output, in the same order. Blank lines are skipped.

Input line ("id" and "options" are optional):
  {"id": ANY, "a": SHAPE, "b": SHAPE, "options": OPTIONS}

SHAPE: exactly one kind, plus optional "radius" and "pose":
  {"polytope": [[x,y,z], ...]}                   convex hull of the points
  {"sphere": {}}                                 a point; with "radius": r a sphere
  {"segment": [[x,y,z], [x,y,z]]}                with "radius": r a capsule
  {"box": [hx,hy,hz]}                            half extents, centred on the origin
  {"ellipsoid": [rx,ry,rz]}                      semi-axes along x, y, z
  {"cylinder": {"radius": r, "half_height": h}}  axis z, from z = -h to z = +h
  {"cone": {"radius": r, "half_height": h}}      base disc at z = -h, apex at z = +h
  "radius": r        spherical extension (r >= 0): all points within r of the shape
  "pose": {"rotation": [w,x,y,z], "translation": [x,y,z]}
                     local -> world; a unit quaternion (|q| within 1e-4 of 1); each part
                     optional (identity rotation, zero translation)

OPTIONS (defaults are the engine's):
  )" << pad(R"("epsilon": )" + epsilon.dump())
       << R"(stopping tolerance of eq. (35) in the paper: stop when
                                    the duality gap g <= epsilon * D(K)^2; a number in
                                    [0, 1), as for nearpointd
  )" << pad(std::string(R"("near_points": )") + near_points)
       << R"(add point_a, point_b (world frame) and the unit
                                    normal from A towards B
  "penetration": "none"             "bound": when in contact, add penetration_bound, a
                                    certified lower bound on the penetration depth (eq.
                                    32-33); "depth": add the signed distance and the
                                    penetration depth, each with a certified interval,
                                    the depth's witness points, direction and termination
  "warm": false                     warm-start from the line before (see below)

Output line:
  {"id": as given (null if absent),
   "status": "separated" | "intersecting" | "touching" | "iteration_limit" | "error",
   "distance": d, "point_a": [x,y,z], "point_b": [x,y,z], "normal": [x,y,z],
   "error_bound": e, "iterations": k, "warm_started": bool, "penetration_bound": p,
   with "penetration": "depth" (separated, intersecting or touching):
   "signed_distance": s, "signed_distance_lower": s-, "signed_distance_upper": s+,
   "penetration_depth": h, "penetration_depth_lower": h-, "penetration_depth_upper": h+,
   "depth_point_a": [x,y,z], "depth_point_b": [x,y,z], "depth_direction": [x,y,z],
   "depth_termination": "closed_form" | "tolerance" | "iteration_limit" | "degenerate",
   "depth_iterations": k,
   "message": "line N: what is wrong"}
  intersecting: overlap proven; touching: contact within the bound (the signed distance's
  interval contains 0); distance is 0 for both; |distance - true distance| <= error_bound.
  signed_distance is the distance when apart, -depth when overlapping; the true values lie in
  [signed_distance_lower, signed_distance_upper] and [penetration_depth_lower, _upper].
  depth_point_a - depth_point_b = penetration_depth * depth_direction (A -> B); the three are
  left out for a separated pair without near_points. normal is left out when it is undefined
  (the shapes' cores overlap). An error line has only id, status and message, and the next line
  is processed as usual. Numbers are printed with full round-trip precision; NaN and Infinity
  never appear.

Warm start (Section VIII of the paper): a line with "warm": true starts from the simplex that the
line just before it left, when that line was also "warm": true and had the same two shapes (same
kinds, parameters, vertices and radii; only the poses may differ). Otherwise it starts cold. So a
trajectory of one pair is a run of consecutive warm lines; warm_started says which lines reused
the cache. Any other line in between (not warm, another pair, an error) ends the run.

Exit status: 0 when the whole input was read, error lines included; 2 when FILE cannot be opened
or read, or the command line is wrong.

Example:
  echo '{"id": 1, "a": {"sphere": {}, "radius": 1}, "b": {"box": [1,1,1], "pose": {"translation": [4,0,0]}}, "options": {"near_points": true}}' | nearpoint distance
  {"id":1,"status":"separated","distance":2.0,"point_a":[1.0,0.0,0.0],"point_b":[3.0,0.0,0.0],"normal":[1.0,0.0,0.0],"error_bound":1.0182167655814703e-14,"iterations":1,"warm_started":false}
)";
  return text.str();
}

int distance_main(const std::string& file) {
  nearpoint::cli::DistanceCommandOptions options;
  options.diagnostics = &std::cerr;
  if (file == "-") return nearpoint::cli::run_distance(std::cin, std::cout, options);

  std::error_code ignored;
  if (std::filesystem::is_directory(file, ignored)) {
    std::cerr << "nearpoint distance: cannot read " << file << ": it is a directory\n";
    return kExitIoError;
  }
  std::ifstream input(file);
  if (!input) {
    std::cerr << "nearpoint distance: cannot open " << file << ": " << std::strerror(errno) << '\n';
    return kExitIoError;
  }
  options.input_name = file;
  return nearpoint::cli::run_distance(input, std::cout, options);
}

void add_distance_subcommand(CLI::App& app, int& exit_code) {
  CLI::App* command = app.add_subcommand(
      "distance", "Distances between pairs of shapes: JSON Lines in, JSON Lines out (local)");
  auto file = std::make_shared<std::string>("-");
  command->add_option("FILE", *file, "JSON Lines input; - or nothing reads standard input");
  command->footer(distance_footer());
  command->callback([file, &exit_code] { exit_code = distance_main(*file); });
}

#if NEARPOINT_HAVE_DDS
// The DDS transport's options of `nearpoint stream --dds` (nearpointd --dds on the other side).
struct DdsStreamArguments {
  nearpoint::cli::DdsStreamOptions options;
  std::string flow_control = "block";
  long long match_timeout_ms = 10000;
  long long report_timeout_ms = 10000;
};

void add_dds_stream_options(CLI::App& command, DdsStreamArguments& args) {
  nearpoint::cli::DdsStreamOptions& options = args.options;
  // The same names as nearpointd's; --domain and --prefix, this command's spellings before 1.0,
  // are still accepted.
  command
      .add_option("--dds-domain,--domain", options.dds.domain_id,
                  "--dds: DDS domain id, as nearpointd --dds-domain (--domain: deprecated)")
      ->capture_default_str()
      ->check(CLI::Range(0, 230));
  command
      .add_option("--dds-prefix,--prefix", options.dds.topic_prefix,
                  "--dds: topic prefix, as nearpointd --dds-prefix (--prefix: deprecated)")
      ->capture_default_str();
  command.add_option("--client-id", options.client_id,
                     "--dds: echoed in this client's reports (default nearpoint-cli-PID)");
  command
      .add_option("--flow-control", args.flow_control,
                  "--dds: block (every update its own report) or coalesce (merge updates that "
                  "arrive while the server is busy)")
      ->capture_default_str()
      ->check(CLI::IsMember(nearpoint::model::spelling_list<nearpoint::model::FlowControl>()));
  command
      .add_option("--match-timeout-ms", args.match_timeout_ms,
                  "--dds: how long to wait for the server to be matched on the topics")
      ->capture_default_str();
  command
      .add_option("--report-timeout-ms", args.report_timeout_ms,
                  "--dds: how long to wait for the next report")
      ->capture_default_str();
  command.add_flag("--dds-allow-default-config", options.dds.allow_default_config,
                   "--dds: run without CYCLONEDDS_URI (Cyclone's defaults: external interface, "
                   "multicast)");
  command
      .add_option("--batch", options.batch,
                  "--dds: consecutive updates per sample (more than 1: the batch topics "
                  "pose_update_batches and distance_report_batches; the window is then at "
                  "least one batch)")
      ->capture_default_str()
      ->check(CLI::Range(1u, nearpoint::dds::kMaxUpdatesPerBatch));
}

int run_dds_stream_command(DdsStreamArguments& args, const std::string& scene,
                           const std::string& trajectory_path, std::size_t window,
                           bool near_points) {
  nearpoint::cli::Trajectory trajectory;
  std::string error;
  if (!nearpoint::cli::load_trajectory(trajectory_path, trajectory, error)) {
    std::cerr << "nearpoint stream: " << error << '\n';
    return kExitUsage;
  }
  args.options.scene_id = scene;
  args.options.window = window;
  args.options.near_points = near_points;
  args.options.flow_control =
      nearpoint::model::from_spelling<nearpoint::model::FlowControl>(args.flow_control);
  args.options.match_timeout = std::chrono::milliseconds(args.match_timeout_ms);
  args.options.report_timeout = std::chrono::milliseconds(args.report_timeout_ms);
  return nearpoint::cli::run_dds_stream(trajectory, args.options, std::cout, std::cerr);
}

constexpr const char* kDdsStreamHelp = R"(
With --dds the updates go over DDS to `nearpointd --dds` (SCENE must be a scene id on the server,
e.g. one preloaded with `nearpointd --scene FILE`): one JSON line per report, a check that every
update is answered once and in order, and a summary on stderr. DDS needs CYCLONEDDS_URI, e.g.
file://$PWD/deploy/cyclonedds-loopback.xml (loopback only). Exit status with --dds: 0 all
answered; 1 rejected updates or missing / out-of-order reports; 2 no scene id or no DDS
configuration; 3 no server matched, or DDS failed.
  nearpoint stream --dds scene-1 examples/dds_trajectory.jsonl
)";
#endif

#ifdef NEARPOINT_WITH_REMOTE

using nearpoint::cli::RemoteOptions;

// The exit-status table both binaries share (model/exit_codes.hpp), after each verb's help.
const std::string kRemoteExitCodes = std::string("\n") + nearpoint::model::kExitStatusHelp;

// --target, --json and --timeout-ms, shared by the server-facing verbs.
void add_remote_options(CLI::App& command, RemoteOptions& remote) {
  command
      .add_option("--target", remote.target,
                  "nearpointd address host:port (default $NEARPOINT_TARGET or "
                  "127.0.0.1:50051)")
      ->capture_default_str();
  command.add_flag("--json", remote.json, "Machine-readable output (JSON)");
  command
      .add_option_function<long long>(
          "--timeout-ms",
          [&remote](long long ms) { remote.timeout = std::chrono::milliseconds(ms); },
          "Deadline of each call, milliseconds (default 10000)")
      ->check(CLI::Range(1LL, 3'600'000LL));
  command.add_option("--tls-ca", remote.tls_ca,
                     "Connect with TLS; PEM CA certificates that signed the server's certificate");
  command.add_option("--tls-server-name", remote.tls_server_name,
                     "Name the server's certificate must carry (default: the --target host)");
  command.add_option("--tls-cert", remote.tls_cert,
                     "PEM client certificate for mutual TLS (with --tls-key)");
  command.add_option("--tls-key", remote.tls_key, "PEM private key of --tls-cert");
  command
      .add_option("--token-file", remote.token_file,
                  "File holding the server's bearer token (default $NEARPOINT_TOKEN_FILE); "
                  "implies TLS")
      ->envname("NEARPOINT_TOKEN_FILE");
}

void add_health_subcommand(CLI::App& app, int& exit_code) {
  auto options = std::make_shared<nearpoint::cli::HealthOptions>();
  CLI::App* command = app.add_subcommand(
      "health", "gRPC health check of nearpointd: exit 0 when SERVING (for probes)");
  add_remote_options(*command, options->remote);
  command->add_option("--service", options->service,
                      "Service to ask about (default: the server as a whole)");
  command->footer(R"(
Prints SERVING, NOT_SERVING, UNKNOWN or SERVICE_UNKNOWN; exit 0 only for SERVING, 3 when no
server answers. nearpointd answers without a token; TLS flags apply as for the other verbs.
  nearpoint health --target 127.0.0.1:50051
  nearpoint health --target nearpoint:50051 --tls-ca ca.pem)");
  command->callback([options, &exit_code] {
    exit_code = nearpoint::cli::run_health(*options, std::cout, std::cerr);
  });
}

void add_info_subcommand(CLI::App& app, int& exit_code) {
  auto remote = std::make_shared<RemoteOptions>();
  CLI::App* command = app.add_subcommand(
      "info", "What a nearpointd is: version, build options, transports and limits");
  add_remote_options(*command, *remote);
  command->footer(std::string(R"(
Prints the server's version (as `nearpointd --version`), what its build compiled in (gRPC, DDS,
metrics), the transports this process serves (gRPC address and TLS, DDS domain and prefix,
metrics port) and the limits it enforces (nearpointd's --max-* flags).
  nearpoint info --target 127.0.0.1:50051
  nearpoint info --json
)") + kRemoteExitCodes);
  command->callback([remote, &exit_code] {
    exit_code = nearpoint::cli::run_info(*remote, std::cout, std::cerr);
  });
}

void add_register_subcommand(CLI::App& app, int& exit_code) {
  auto options = std::make_shared<nearpoint::cli::RegisterOptions>();
  CLI::App* command = app.add_subcommand(
      "register", "Register a geometry: a mesh's convex hull(s) or a JSON geometry file");
  command
      ->add_option("FILE", options->files,
                   "OBJ, STL, OFF or PLY meshes (several: one compound geometry, a convex "
                   "piece per mesh part), or JSON/YAML geometry files")
      ->required();
  command->add_option("--name", options->name, "The geometry's label");
  command->add_flag("--merge", options->merge,
                    "Meshes: one hull per file rather than one per mesh part");
  command->add_option("--scale", options->scale, "Meshes: multiply coordinates (e.g. 0.001 for mm)")
      ->check(CLI::PositiveNumber);
  add_remote_options(*command, options->remote);
  command->footer(std::string(R"(
A mesh is replaced by the convex hull of its vertices (one convex piece per mesh part; a convex
decomposition given as several files or parts becomes one compound geometry). A JSON geometry is
a SHAPE, an array of SHAPEs, or {"name": "...", "pieces": [SHAPE, ...]} (SHAPE as for
`nearpoint distance --help`). Prints the geometry id the server assigned.

Examples:
  nearpoint register examples/cube.obj
  nearpoint register --json gripper.json
  nearpoint register part-1.stl part-2.stl --name bracket
)") + kRemoteExitCodes);
  command->callback([options, &exit_code] {
    exit_code = nearpoint::cli::run_register(*options, std::cout, std::cerr);
  });
}

void add_robot_file_options(CLI::App& command, nearpoint::cli::RobotFileOptions& robot) {
  command.add_option("--package-path", robot.package_path,
                     "Robot descriptions: where package://NAME/... and relative mesh paths are "
                     "looked up (repeatable)");
  command.add_option("--srdf", robot.srdf,
                     "URDF: the SRDF whose <disable_collisions> leave pairs out (default: "
                     "FILE.srdf beside it when it exists)");
}

void add_scene_subcommand(CLI::App& app, int& exit_code) {
  CLI::App* scene = app.add_subcommand("scene", "Scenes on the server");
  scene->require_subcommand(1);
  auto options = std::make_shared<nearpoint::cli::SceneCreateOptions>();
  CLI::App* create =
      scene->add_subcommand("create", "Register a scene file's geometries and create its scene");
  create
      ->add_option("FILE", options->file,
                   "Scene file (JSON, YAML) or robot description (URDF .urdf, MJCF .xml/.mjcf)")
      ->required();
  add_robot_file_options(*create, options->robot);
  add_remote_options(*create, options->remote);
  create->footer(std::string(R"(
Scene file (JSON; YAML with the same structure):
  {"id": "cell-1",                      optional: the scene id to ask for
   "geometries": {"NAME": GEOMETRY, ...},
   "objects": [{"id": "arm", "geometry": "NAME", "pose": {"rotation": [w,x,y,z],
                "translation": [x,y,z]}, "group": 1, "mask": 4294967295}, ...],
   "pairs": "all" | {"listed": [["a","b"], ...]} | {"excluded": [["a","b"], ...]},
   "options": {"near_points": true, "penetration": "bound", "distance_cutoff": 2.0, ...}}
GEOMETRY: a SHAPE, [SHAPE, ...], {"pieces": [SHAPE, ...]}, or {"mesh": "part.obj" | [files],
"scale": 1.0, "merge": false} with paths relative to the scene file. An object may name a
geometry already on the server with "geometry_id" instead of "geometry".

A robot description becomes an articulated scene: one object per link (URDF; per geom for MJCF)
moved by joint positions (`nearpoint stream --joints`); parent-child links and an SRDF's
<disable_collisions> (FILE.srdf beside the URDF, or --srdf), MJCF contype/conaffinity/exclude
leave pairs out.

Examples:
  nearpoint scene create examples/scene.json
  nearpoint scene create examples/robots/arm7.urdf --package-path /opt/ros/share
)") + kRemoteExitCodes);
  create->callback([options, &exit_code] {
    exit_code = nearpoint::cli::run_scene_create(*options, std::cout, std::cerr);
  });
  nearpoint::cli::add_scene_management(*scene, exit_code, add_remote_options, kRemoteExitCodes);
}

void add_keep_scene_flag(CLI::App& command, bool& keep_scene) {
  command.add_flag("--keep-scene", keep_scene,
                   "Keep the scene this command creates (printed on stderr) instead of deleting "
                   "it when the command ends");
}

void add_report_mode_options(CLI::App& command, nearpoint::cli::ReportModeFlags& flags) {
  command
      .add_option("--mode", flags.mode,
                  "Which pairs each report holds: all | within-cutoff | nearest (each object's "
                  "nearest pair) | global (the one nearest pair) | changed (pairs whose status or "
                  "distance changed since the previous report); default: the scene's")
      ->check(CLI::IsMember(nearpoint::model::spelling_list<nearpoint::model::ReportMode>()));
  command.add_option("--cutoff", flags.cutoff,
                     "distance_cutoff, metres: pairs proven farther are BEYOND_CUTOFF (and left "
                     "out by within-cutoff, nearest and global)");
  command.add_option("--change-tolerance", flags.change_tolerance,
                     "--mode changed: metres a pair's distance may move before it is reported "
                     "again (default 0: any change)");
}

void add_query_subcommand(CLI::App& app, int& exit_code) {
  auto options = std::make_shared<nearpoint::cli::QueryCommandOptions>();
  CLI::App* command = app.add_subcommand("query", "One-shot distances for a scene");
  command
      ->add_option("SCENE", options->scene,
                   "A scene id on the server, or a scene file (created first)")
      ->required();
  command->add_option("--pose", options->poses,
                      "OBJECT=tx,ty,tz[,qw,qx,qy,qz]: an object's pose (repeatable; others stay "
                      "at their initial pose)");
  command->add_flag("--near-points", options->near_points, "Report near points and normals");
  command->add_option("--penetration", options->penetration,
                      "none | bound (d⁻, a certified lower bound on the penetration depth) | "
                      "depth (the signed distance and the penetration depth, each with a "
                      "certified interval, witness points and direction)");
  add_report_mode_options(*command, options->report);
  add_remote_options(*command, options->remote);
  add_keep_scene_flag(*command, options->keep_scene);
  command->footer(std::string(R"(
A scene file is created on the server for this query and deleted afterwards (--keep-scene keeps
it). Output with --json: one report (client/schema/report.schema.json) with "scene_id".

Examples:
  nearpoint query examples/scene.json --pose gripper=0.2,0,0.5
  nearpoint query cell-1 --pose gripper=0,0,0.3,0.7071,0,0,0.7071 --near-points --json
)") + kRemoteExitCodes);
  command->callback([options, &exit_code] {
    exit_code = nearpoint::cli::run_query(*options, std::cout, std::cerr);
  });
}

void add_stream_subcommand(CLI::App& app, int& exit_code) {
  auto options = std::make_shared<nearpoint::cli::StreamCommandOptions>();
#if NEARPOINT_HAVE_DDS
  auto dds = std::make_shared<DdsStreamArguments>();
  auto use_dds = std::make_shared<bool>(false);
#endif
  CLI::App* command = app.add_subcommand(
      "stream", "Replay a trajectory as a pose stream; print reports or a summary");
  command
      ->add_option("SCENE", options->scene,
                   "A scene id on the server, or a scene file or robot description (created "
                   "first)")
      ->required();
  command->add_option("TRAJECTORY", options->trajectory, "Poses over time: CSV or JSON Lines");
  command->add_option("--joints", options->joints,
                      "Robot scenes: joint positions over time (JSON Lines, see below) instead "
                      "of TRAJECTORY");
  command->add_flag("--gradient", options->gradient,
                    "Ask for gradients (robot scenes: each pair's dd/dq by joint, in --json)");
  add_robot_file_options(*command, options->robot);
  command
      ->add_option("--window", options->window,
                   "Updates in flight before pushing waits (back-pressure; with --dds default 1)")
      ->capture_default_str()
      ->check(CLI::Range(1, 4096));
  command->add_flag("--near-points", options->near_points, "Report near points and normals");
  command->add_option("--penetration", options->penetration,
                      "none | bound (d⁻, a lower bound on the depth) | depth (signed distance and "
                      "penetration depth with certified intervals; thresholds may then be <= 0)");
  add_report_mode_options(*command, options->report);
  command->add_option(
      "--threshold", options->thresholds,
      "Watch a distance (repeatable): D[,hysteresis=H][,pair=A:B|object=A][,groups=BITS]"
      "[,name=N]; reports carry ENTER when a pair comes closer than D, EXIT when it gets "
      "farther than D + H (--cutoff must be at least D + H); with --penetration depth the "
      "signed distance is compared and D may be negative (a depth of -D)");
  add_remote_options(*command, options->remote);
  add_keep_scene_flag(*command, options->keep_scene);
#if NEARPOINT_HAVE_DDS
  command->add_flag("--dds", *use_dds, "Stream over DDS (nearpointd --dds) instead of gRPC");
  add_dds_stream_options(*command, *dds);
#endif
  command->footer(std::string(R"(
TRAJECTORY, one of:
  CSV with the header t,object,tx,ty,tz,qw,qx,qy,qz; rows with equal t form one update
  JSON Lines: {"t": 0.0, "poses": {"OBJ": {"rotation": [w,x,y,z], "translation": [x,y,z]}}}
Objects not listed at a step keep their previous pose.
--joints FILE (robot scenes), JSON Lines: {"t": 0.0, "joints": {"joint1": 0.3, "joint2": -1.2}}
with optionally "base": {"rotation": [w,x,y,z], "translation": [x,y,z]} (the robot's base pose);
a ball joint's value is [w,x,y,z], a free joint's [x,y,z,w,x,y,z]. Joints not named keep theirs.

A scene file is created on the server for this stream and deleted when it ends, also on Ctrl-C
(SIGINT/SIGTERM: exit 130/143 once the updates in flight are answered); --keep-scene keeps it.
Output: with --json one JSON object per report (JSON Lines, in order, with the step's "t"; the
schema is client/schema/report.schema.json, the same over --dds);
otherwise a progress line on stderr (a terminal) and a summary per pair (minimum distance and when, steps in
contact) with the round-trip latency, and with --threshold every ENTER/EXIT event (in JSON:
"events" of each report, each with the sequence of the update that crossed). A dropped
connection is retried (the scene is replayed on the restarted server); updates in flight at the
drop are reported as errors, never dropped silently.

Examples:
  nearpoint stream examples/scene.json examples/trajectory.csv
  nearpoint stream cell-1 examples/trajectory.csv --threshold 0.05,hysteresis=0.01,object=gripper,name=near
  nearpoint stream arm --joints examples/robots/arm7_wave.jsonl --gradient --json
)") + kRemoteExitCodes
#if NEARPOINT_HAVE_DDS
                  + kDdsStreamHelp
#endif
  );
#if NEARPOINT_HAVE_DDS
  command->callback([command, options, dds, use_dds, &exit_code] {
    if (*use_dds && !options->joints.empty()) {
      std::cerr << "nearpoint stream: --joints streams over gRPC only (no --dds)\n";
      exit_code = 2;
      return;
    }
    if (*use_dds) {
      // The same --mode, --cutoff, --change-tolerance and --threshold as over gRPC.
      const std::string& mode = options->report.mode;
      dds->options.report_mode =
          mode.empty() ? nearpoint::model::ReportMode::unspecified
                       : nearpoint::model::from_spelling<nearpoint::model::ReportMode>(mode);
      dds->options.cutoff = options->report.cutoff;
      dds->options.change_tolerance = options->report.change_tolerance;
      if (!options->penetration.empty()) {  // and the same --penetration
        dds->options.penetration =
            nearpoint::model::from_spelling<nearpoint::model::PenetrationMode>(
                options->penetration);
        if (dds->options.penetration == nearpoint::model::PenetrationMode::unknown) {
          std::cerr << "nearpoint stream: --penetration must be "
                    << nearpoint::model::spellings<nearpoint::model::PenetrationMode>() << " (got "
                    << options->penetration << ")\n";
          exit_code = 2;
          return;
        }
      }
      for (const std::string& spec : options->thresholds) {
        std::string error;
        if (!nearpoint::cli::parse_threshold_argument(spec, dds->options.thresholds.emplace_back(),
                                                      error)) {
          std::cerr << "nearpoint stream: " << error << "\n";
          exit_code = 2;
          return;
        }
      }
      // DDS has no back-pressure: updates published beyond the server's in-flight limit are
      // merged (and reported so). Without an explicit --window, step in lock with the reports
      // (batched: a batch at a time).
      const std::size_t window = command->count("--window") > 0
                                     ? options->window
                                     : std::max<std::size_t>(1, dds->options.batch);
      exit_code = run_dds_stream_command(*dds, options->scene, options->trajectory, window,
                                         options->near_points);
      return;
    }
    if (!stderr_is_terminal()) options->progress_every = 0;
    exit_code = nearpoint::cli::run_stream(*options, std::cout, std::cerr);
  });
#else
  command->callback([options, &exit_code] {
    if (!stderr_is_terminal()) options->progress_every = 0;
    exit_code = nearpoint::cli::run_stream(*options, std::cout, std::cerr);
  });
#endif
}

void add_load_subcommand(CLI::App& app, int& exit_code) {
  auto options = std::make_shared<nearpoint::cli::LoadCommandOptions>();
  CLI::App* command = app.add_subcommand(
      "load", "Concurrent pose streams for a bounded time: latency percentiles and throughput");
  command->add_option("SCENE", options->scene, "Scene id or file (default: the demo scene)");
  command->add_option("TRAJECTORY", options->trajectory,
                      "Poses replayed in a loop (default: the demo path, T = 1000)");
  command->add_option("--streams", options->streams, "Concurrent streams")
      ->capture_default_str()
      ->check(CLI::Range(1, 256));
  command->add_option("--duration", options->duration_s, "Seconds")
      ->capture_default_str()
      ->check(CLI::Range(0.01, 600.0));
  command
      ->add_option("--window", options->window,
                   "Updates in flight per stream (1: latency; more: throughput)")
      ->capture_default_str()
      ->check(CLI::Range(1, 4096));
  command
      ->add_option("--batch", options->batch,
                   "Pose sets per message (more than 1: StreamPoseBatches, at least one batch "
                   "in flight)")
      ->capture_default_str()
      ->check(CLI::Range(1, 4096));
  add_remote_options(*command, options->remote);
  add_keep_scene_flag(*command, options->keep_scene);
  command->footer(std::string(R"(
The scene it creates (the demo scene, or SCENE when it is a file) is deleted at the end, also on
Ctrl-C (exit 130/143); --keep-scene keeps it.
Prints a progress line on stderr while it runs (when stderr is a terminal), then the number of reports, updates/s and the
push-to-report latency p50/p90/p99/max over all streams.

Example:
  nearpoint load --streams 4 --duration 5
)") + kRemoteExitCodes);
  command->callback([options, &exit_code] {
    if (!stderr_is_terminal()) options->progress_every = 0;
    exit_code = nearpoint::cli::run_load(*options, std::cout, std::cerr);
  });
}

void add_demo_subcommand(CLI::App& app, int& exit_code) {
  auto options = std::make_shared<nearpoint::cli::DemoOptions>();
  CLI::App* command = app.add_subcommand(
      "demo", "The paper's Section VIII experiment (Fig. 5, Table I, Fig. 6) against a server");
  command->add_option("--target", options->target,
                      "Use this nearpointd (host:port) instead of starting one on 127.0.0.1:0");
  command->add_option("--nearpointd", options->nearpointd,
                      "The nearpointd binary to start (default: $NEARPOINTD, beside nearpoint, "
                      "the build tree, or the PATH)");
  command->add_option("--steps", options->steps, "T: the path is sampled at s = t/T, t = 0 … T")
      ->capture_default_str()
      ->check(CLI::Range(1, 1'000'000));
  command->add_option("--plot", options->plot_path,
                      "SVG of the distance curves (default demo.svg in the working directory, "
                      "else in the temporary directory; - for none)");
  command->add_flag("--json", options->json, "Machine-readable output (JSON)");
  add_keep_scene_flag(*command, options->keep_scene);
  command->footer(std::string(R"(
With --target the demo scene is deleted from that server at the end (also on Ctrl-C: exit
130/143) unless --keep-scene.
A moving object made of two convex pieces passes five obstacles along a straight line, turning by
a slerp (the paper's Fig. 5; the same scene as bench's Table I). The path is streamed twice to the
server, with warm starts and with single-point starts. Printed per obstacle: the minimum distance
and where (s), the collision intervals [s0, s1] with the largest penetration bound d⁻ inside; then
the warm/single-point ratio of server-side geometry time (the paper's Table I). The plot shows the
five distance curves against s (the paper's Fig. 6).

Example:
  nearpoint demo                   # starts nearpointd on 127.0.0.1:0, T = 1000
  nearpoint demo --steps 100 --json --target 127.0.0.1:50051
)") + kRemoteExitCodes);
  command->callback([options, &exit_code] {
    exit_code = nearpoint::cli::run_demo(*options, std::cout, std::cerr);
  });
}

#endif  // NEARPOINT_WITH_REMOTE

#if !defined(NEARPOINT_WITH_REMOTE) && NEARPOINT_HAVE_DDS
// A build without the gRPC client: `stream` speaks DDS only.
void add_stream_subcommand(CLI::App& app, int& exit_code) {
  struct Arguments {
    DdsStreamArguments dds;
    bool use_dds = false;
    std::string scene, trajectory;
    std::size_t window = 1;
    bool near_points = false;
  };
  auto args = std::make_shared<Arguments>();
  CLI::App* command =
      app.add_subcommand("stream", "Replay a trajectory to nearpointd --dds; print each report");
  command->add_option("SCENE", args->scene, "Scene id on the server")->required();
  command->add_option("TRAJECTORY", args->trajectory, "Poses over time: CSV or JSON Lines")
      ->required();
  command->add_flag("--dds", args->use_dds, "Stream over DDS (the only transport of this build)");
  command->add_option("--window", args->window, "Updates published ahead of their reports")
      ->capture_default_str()
      ->check(CLI::Range(1, 4096));
  command->add_flag("--near-points", args->near_points, "Ask for near points and normals");
  add_dds_stream_options(*command, args->dds);
  command->footer(kDdsStreamHelp);
  command->callback([args, &exit_code] {
    exit_code = run_dds_stream_command(args->dds, args->scene, args->trajectory, args->window,
                                       args->near_points);
  });
}
#endif

#if NEARPOINT_HAVE_DDS
// `nearpoint dds load`: `nearpoint load` over DDS (bench/service/capacity.sh TRANSPORT=dds).
void add_dds_load_subcommand(CLI::App& dds, int& exit_code) {
  struct Arguments {
    nearpoint::cli::DdsLoadOptions load;
    std::string trajectory;
  };
  auto args = std::make_shared<Arguments>();
  CLI::App* command = dds.add_subcommand(
      "load", "Concurrent DDS pose streams for a bounded time: latency, throughput, server time");
  command->add_option("SCENE", args->load.scene_id, "Scene id on the server")->required();
#ifdef NEARPOINT_WITH_REMOTE
  command->add_option("TRAJECTORY", args->trajectory,
                      "Poses replayed in a loop (default: the demo path of `nearpoint load`, for "
                      "the demo scene it creates with --keep-scene)");
#else
  command->add_option("TRAJECTORY", args->trajectory, "Poses replayed in a loop")->required();
#endif
  command->add_option("--streams", args->load.streams, "Concurrent streams (DDS participants)")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  command->add_option("--duration", args->load.duration_s, "Seconds")
      ->capture_default_str()
      ->check(CLI::Range(0.01, 600.0));
  command
      ->add_option("--window", args->load.window,
                   "Updates in flight per stream (within nearpointd's --max-in-flight)")
      ->capture_default_str()
      ->check(CLI::Range(1, 4096));
  command
      ->add_option("--batch", args->load.batch,
                   "Consecutive updates per sample (more than 1: PoseUpdateBatch on "
                   "pose_update_batches; --window then defaults to two batches)")
      ->capture_default_str()
      ->check(CLI::Range(1u, nearpoint::dds::kMaxUpdatesPerBatch));
  command->add_option("--dds-domain", args->load.dds.domain_id, "DDS domain id")
      ->capture_default_str()
      ->check(CLI::Range(0, 230));
  command->add_option("--dds-prefix", args->load.dds.topic_prefix, "Topic prefix, as nearpointd's")
      ->capture_default_str();
  command->add_flag("--json", args->load.json, "One JSON object (as `nearpoint load --json`)");
  command->add_flag("--dds-allow-default-config", args->load.dds.allow_default_config,
                    "Run without CYCLONEDDS_URI (Cyclone's defaults: external interface, "
                    "multicast)");
  command->footer(R"(
Each stream is its own DDS participant; the report topic is keyless, so every stream's reader
also receives the other streams' reports. Prints the reports (answered updates), updates/s,
the publish-to-report latency and the reports' server and geometry time. With --batch N the
window counts updates; keep it within nearpointd's --max-in-flight, or the server merges updates.
  nearpoint dds load cell45 cell45.jsonl --duration 5 --window 4
  nearpoint dds load cell45 cell45.jsonl --duration 5 --batch 8    # nearpointd --max-in-flight 16
)");
  command->callback([command, args, &exit_code] {
    if (args->load.batch > 1 && command->count("--window") == 0)
      args->load.window = 2 * args->load.batch;
    nearpoint::cli::Trajectory trajectory;
    if (!args->trajectory.empty()) {
      if (std::string error;
          !nearpoint::cli::load_trajectory(args->trajectory, trajectory, error)) {
        std::cerr << "nearpoint dds load: " << error << "\n";
        exit_code = nearpoint::cli::kStreamBadConfiguration;
        return;
      }
    }
#ifdef NEARPOINT_WITH_REMOTE
    else {
      constexpr int kSteps = 1000;  // the demo path of `nearpoint load`
      for (int t = 0; t <= kSteps; ++t) {
        const nearpoint::client::ObjectPose pose = nearpoint::cli::demo_pose(double(t) / kSteps);
        const Eigen::Quaterniond& q = pose.rotation;
        nearpoint::cli::TrajectoryStep& step = trajectory.steps.emplace_back();
        step.time = double(t);
        step.poses.push_back({pose.object_id,
                              {q.w(), q.x(), q.y(), q.z()},
                              {pose.translation.x(), pose.translation.y(), pose.translation.z()}});
      }
    }
#endif
    exit_code = nearpoint::cli::run_dds_load(trajectory, args->load, std::cout, std::cerr);
  });
}

// `nearpoint dds topics|echo`: the ROS 2 view of the DDS domain.
void add_dds_subcommand(CLI::App& app, int& exit_code) {
  CLI::App* dds = app.add_subcommand(
      "dds", "The DDS domain as ROS 2 tools see it: topics and types, reports as they pass");
  dds->require_subcommand(1);
  auto topics = std::make_shared<nearpoint::cli::DdsTopicsOptions>();
  auto wait_ms = std::make_shared<int>(2000);
  CLI::App* list = dds->add_subcommand(
      "topics", "List the topics on the domain with their ROS 2 and DDS names and types");
  list->add_option("--dds-domain", topics->dds.domain_id, "DDS domain id")
      ->capture_default_str()
      ->check(CLI::Range(0, 230));
  list->add_option("--wait-ms", *wait_ms, "How long to listen for discovery")
      ->capture_default_str()
      ->check(CLI::Range(0, 600000));
  list->add_option("--filter", topics->filter, "Only DDS topic names starting with this");
  list->add_flag("--dds-allow-default-config", topics->dds.allow_default_config,
                 "Run without CYCLONEDDS_URI (Cyclone's defaults: external interface, multicast)");
  list->callback([topics, wait_ms, &exit_code] {
    topics->wait = std::chrono::milliseconds(*wait_ms);
    exit_code = nearpoint::cli::run_dds_topics(*topics, std::cout, std::cerr);
  });
  auto echo = std::make_shared<nearpoint::cli::DdsEchoOptions>();
  auto timeout_ms = std::make_shared<int>(10000);
  CLI::App* show = dds->add_subcommand(
      "echo", "Print the reports on <prefix>distance_reports as JSON lines (ros2 topic echo)");
  show->add_option("--dds-domain", echo->dds.domain_id, "DDS domain id")
      ->capture_default_str()
      ->check(CLI::Range(0, 230));
  show->add_option("--dds-prefix", echo->dds.topic_prefix, "Topic prefix, as nearpointd's")
      ->capture_default_str();
  show->add_option("--scene", echo->scene_id, "Only this scene's reports");
  show->add_option("--count", echo->count, "Stop after this many reports");
  show->add_option("--timeout-ms", *timeout_ms, "Stop when no report came for this long")
      ->capture_default_str();
  show->add_flag("--dds-allow-default-config", echo->dds.allow_default_config,
                 "Run without CYCLONEDDS_URI (Cyclone's defaults: external interface, multicast)");
  show->callback([echo, timeout_ms, &exit_code] {
    echo->timeout = std::chrono::milliseconds(*timeout_ms);
    exit_code = nearpoint::cli::run_dds_echo(*echo, std::cout, std::cerr);
  });
  add_dds_load_subcommand(*dds, exit_code);
}
#endif

}  // namespace

int main(int argc, char** argv) {
  // Our own stream buffers: faster, and they let `run_distance` see when input is pending.
  std::ios::sync_with_stdio(false);
  try {
    CLI::App app{
        "nearpoint: distances between convex shapes by the GJK algorithm (Gilbert, Johnson and "
        "Keerthi, 1988)",
        "nearpoint"};
    app.set_version_flag("--version", std::string("nearpoint ") + nearpoint::kVersion);
    app.require_subcommand(1);
    int exit_code = kExitOk;
    add_distance_subcommand(app, exit_code);
#ifdef NEARPOINT_WITH_REMOTE
    add_register_subcommand(app, exit_code);
    add_health_subcommand(app, exit_code);
    add_info_subcommand(app, exit_code);
    add_scene_subcommand(app, exit_code);
    nearpoint::cli::add_geometry_subcommand(app, exit_code, add_remote_options, kRemoteExitCodes);
    add_query_subcommand(app, exit_code);
    add_stream_subcommand(app, exit_code);
    add_load_subcommand(app, exit_code);
    add_demo_subcommand(app, exit_code);
#elif NEARPOINT_HAVE_DDS
    add_stream_subcommand(app, exit_code);
#endif
#if NEARPOINT_HAVE_DDS
    add_dds_subcommand(app, exit_code);
#endif
    // Set after the subcommands, which would otherwise inherit it: `nearpoint scene --help`
    // must not repeat the top-level examples.
    app.footer(std::string(R"(
Run 'nearpoint COMMAND --help' for the details of a command. `distance` runs locally; the other
commands talk to nearpointd (--target, default $NEARPOINT_TARGET or 127.0.0.1:50051), and `demo`
starts one of its own when given no --target.

Examples:
  nearpoint demo
  nearpoint distance examples/pairs.jsonl
  echo '{"a": {"sphere": {}, "radius": 1}, "b": {"sphere": {}, "radius": 1, "pose": {"translation": [3,0,0]}}}' | nearpoint distance
)") + "\n" + nearpoint::model::kExitStatusHelp);
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      const int code = app.exit(e);  // prints help / version / the error
      return code == 0 ? kExitOk : kExitUsage;
    }
    return exit_code;
  } catch (const std::exception& e) {
    std::cerr << "nearpoint: " << e.what() << '\n';
    return nearpoint::model::kExitFailure;
  }
}
