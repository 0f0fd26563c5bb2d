// SPDX-License-Identifier: Apache-2.0
// nearpoint-bench: the benchmark driver. `nearpoint-bench EXPERIMENT [--out DIR] [--quick]
// [--rounds N]` runs one experiment (or `all`) and writes its CSV files; bench/run.sh runs them
// all in sequence (never two at once: they would disturb each other's timings) and makes the
// tables, plots and bench/RESULTS.md from the CSVs.
#include <cstdlib>
#include <cstring>
#include <string>

#include "experiments.hpp"
#include "runners.hpp"

namespace {

int usage() {
  std::fprintf(
      stderr,
      "usage: nearpoint-bench paper|table1|error-time|large|stability|primitives|depth|all "
      "[--out DIR] [--quick] [--rounds N]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace nearpoint::bench;
  if (argc < 2) return usage();
  Args args;
  args.experiment = argv[1];
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") {
      args.quick = true;
    } else if (a == "--out" && i + 1 < argc) {
      args.out_dir = argv[++i];
    } else if (a == "--rounds" && i + 1 < argc) {
      args.rounds = std::atoi(argv[++i]);
    } else {
      return usage();
    }
  }
  if (const std::string problem = check_peer_builds(); !problem.empty()) {
    std::fprintf(stderr, "nearpoint-bench: %s\n", problem.c_str());
    return 1;
  }
  if (!peers_available()) progress("built without NEARPOINT_BENCH_PEERS: peers are not measured");

  const std::string& e = args.experiment;
  const bool all = e == "all";
  int status = 0;
  bool ran = false;
  auto maybe = [&](const char* name, int (*run)(const Args&)) {
    if (all || e == name) {
      ran = true;
      status |= run(args);
    }
  };
  maybe("paper", run_paper);
  maybe("table1", run_table1);
  maybe("error-time", run_error_time);
  maybe("large", run_large);
  maybe("stability", run_stability);
  maybe("primitives", run_primitives);
  maybe("depth", run_depth);
  if (!ran) return usage();
  return status;
}
