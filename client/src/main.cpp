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
