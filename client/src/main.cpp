// The `nearpoint` command-line tool. One CLI11 subcommand per verb; each `add_*_subcommand`
// function declares its arguments and help and runs its command from the callback, setting the
// process's exit code. The server-facing verbs (register, query, stream, demo, load) slot in beside
// `distance` the same way once the gRPC client exists.
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

#include <CLI/CLI.hpp>

#include "distance_command.hpp"
#include "nearpoint/options.hpp"
#if NEARPOINT_HAVE_DDS
#include "dds_stream.hpp"
#endif

#ifndef NEARPOINT_VERSION
#define NEARPOINT_VERSION "unknown"
#endif

namespace {

using nearpoint::cli::kExitIoError;
using nearpoint::cli::kExitOk;

constexpr int kExitUsage = 2;  // as for an I/O failure: the command could not do its work

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
                                    the duality gap g <= epsilon * D(K)^2
  )" << pad(std::string(R"("near_points": )") + near_points)
       << R"(add point_a, point_b (world frame) and the unit
                                    normal from A towards B
  "penetration": "none"             "bound": when intersecting, add penetration_bound, a
                                    certified lower bound on the penetration depth (eq.
                                    32-33); "depth" (exact depth by EPA) is not available
                                    yet: such a line is answered with an error
  "warm": false                     warm-start from the line before (see below)

Output line:
  {"id": as given (null if absent),
   "status": "separated" | "intersecting" | "iteration_limit" | "error",
   "distance": d, "point_a": [x,y,z], "point_b": [x,y,z], "normal": [x,y,z],
   "error_bound": e, "iterations": k, "warm_started": bool, "penetration_bound": p,
   "message": "line N: what is wrong"}
  distance is 0 when the shapes intersect (touching counts); |distance - true distance| <=
  error_bound. normal is left out when it is undefined (the shapes' cores overlap). An error
  line has only id, status and message, and the next line is processed as usual. Numbers are
  printed with full round-trip precision; NaN and Infinity never appear.

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

// `nearpoint stream --dds`: the DDS transport's half of the `stream` verb (the gRPC half joins it
// when the gRPC client lands).
void add_stream_subcommand(CLI::App& app, int& exit_code) {
  CLI::App* command =
      app.add_subcommand("stream", "Replay a trajectory to nearpointd and print each report");
  struct Arguments {
    bool dds = false;
    std::string trajectory;
#if NEARPOINT_HAVE_DDS
    nearpoint::cli::DdsStreamOptions options;
    std::string flow_control = "block";
    long long match_timeout_ms = 10000;
    long long report_timeout_ms = 10000;
#endif
  };
  auto args = std::make_shared<Arguments>();
  command
      ->add_option("TRAJECTORY", args->trajectory,
                   "JSON Lines ({\"t\": s, \"poses\": {\"OBJ\": {\"rotation\": [w,x,y,z], "
                   "\"translation\": [x,y,z]}}}) or .csv (t,object,tx,ty,tz,qw,qx,qy,qz)")
      ->required();
  command->add_flag("--dds", args->dds, "Stream over DDS (nearpointd --dds) instead of gRPC");
#if NEARPOINT_HAVE_DDS
  nearpoint::cli::DdsStreamOptions& options = args->options;
  command->add_option("--scene", options.scene_id, "Scene id on the server")->required();
  command->add_option("--domain", options.dds.domain_id, "DDS domain id")
      ->capture_default_str()
      ->check(CLI::Range(0, 230));
  command
      ->add_option("--prefix", options.dds.topic_prefix,
                   "DDS topic prefix (as nearpointd --dds-prefix)")
      ->capture_default_str();
  command->add_option("--client-id", options.client_id,
                      "Echoed in this client's reports (default nearpoint-cli-PID)");
  command
      ->add_option("--window", options.window,
                   "Updates published ahead of their reports (1: lock step)")
      ->capture_default_str()
      ->check(CLI::Range(1, 4096));
  command
      ->add_option("--flow-control", args->flow_control,
                   "block: every update its own report; coalesce: merge updates that arrive "
                   "while the server is busy")
      ->capture_default_str()
      ->check(CLI::IsMember({"block", "coalesce"}));
  command->add_flag("--near-points", options.near_points, "Ask for near points and normals");
  command
      ->add_option("--match-timeout-ms", args->match_timeout_ms,
                   "How long to wait for the server to be matched on the topics")
      ->capture_default_str();
  command
      ->add_option("--report-timeout-ms", args->report_timeout_ms,
                   "How long to wait for the next report")
      ->capture_default_str();
  command->add_flag("--dds-allow-default-config", options.dds.allow_default_config,
                    "Run without CYCLONEDDS_URI (Cyclone's defaults: external interface, "
                    "multicast)");
#endif
  command->footer(R"(
Publishes one update per trajectory step (sequence numbers 1, 2, ...) and prints one JSON line
per report. Checks that every update is answered once and in order; a summary goes to stderr.
Exit status: 0 all answered; 1 rejected updates or missing / out-of-order reports; 2 cannot run.
DDS needs CYCLONEDDS_URI, e.g. file://$PWD/deploy/cyclonedds-loopback.xml (loopback only).

Example:
  nearpoint stream --dds --scene scene-1 examples/trajectory.jsonl
)");
  command->callback([args, &exit_code] {
    if (!args->dds) {
      std::cerr << "nearpoint stream: only --dds is available in this build\n";
      exit_code = kExitUsage;
      return;
    }
#if NEARPOINT_HAVE_DDS
    nearpoint::cli::Trajectory trajectory;
    std::string error;
    if (!nearpoint::cli::load_trajectory(args->trajectory, trajectory, error)) {
      std::cerr << "nearpoint stream: " << error << '\n';
      exit_code = kExitUsage;
      return;
    }
    args->options.flow_control = args->flow_control == "coalesce" ? 2 : 0;
    args->options.match_timeout = std::chrono::milliseconds(args->match_timeout_ms);
    args->options.report_timeout = std::chrono::milliseconds(args->report_timeout_ms);
    exit_code = nearpoint::cli::run_dds_stream(trajectory, args->options, std::cout, std::cerr);
#else
    std::cerr << "nearpoint stream --dds: this nearpoint was built without DDS "
                 "(NEARPOINT_WITH_DDS=OFF)\n";
    exit_code = kExitUsage;
#endif
  });
}

}  // namespace

int main(int argc, char** argv) {
  // Our own stream buffers: faster, and they let `run_distance` see when input is pending.
  std::ios::sync_with_stdio(false);
  try {
    CLI::App app{
        "nearpoint: distances between convex shapes by the GJK algorithm (Gilbert, Johnson and "
        "Keerthi, 1988)",
        "nearpoint"};
    app.set_version_flag("--version", std::string("nearpoint ") + NEARPOINT_VERSION);
    app.require_subcommand(1);
    app.footer(R"(
Run 'nearpoint COMMAND --help' for the details of a command.

Example:
  nearpoint distance examples/pairs.jsonl
  echo '{"a": {"sphere": {}, "radius": 1}, "b": {"sphere": {}, "radius": 1, "pose": {"translation": [3,0,0]}}}' | nearpoint distance
)");
    int exit_code = kExitOk;
    add_distance_subcommand(app, exit_code);
    add_stream_subcommand(app, exit_code);
    try {
      app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
      const int code = app.exit(e);  // prints help / version / the error
      return code == 0 ? kExitOk : kExitUsage;
    }
    return exit_code;
  } catch (const std::exception& e) {
    std::cerr << "nearpoint: " << e.what() << '\n';
    return kExitIoError;
  }
}
