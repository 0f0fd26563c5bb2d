// SPDX-License-Identifier: Apache-2.0
// The experiments. Each writes its CSV files under `args.out_dir`; bench/tools/report.py
// turns them into tables, plots and bench/RESULTS.md.
#pragma once

#include "harness.hpp"

namespace nearpoint::bench {

/// (1) Section VII / Fig. 4: the 6000 examples, every implementation, interleaved rounds.
int run_paper(const Args& args);
/// (2) Section VIII / Table I: the moving two-piece object, cold vs warm starts.
int run_table1(const Args& args);
/// (3) Error against run time: ε (eq. 35) and iteration-cap sweeps, and each peer's knob.
int run_error_time(const Args& args);
/// (4) Large polytopes: hulls of 10²–10⁵ points on spheres and ellipsoids, cold and warm.
int run_large(const Args& args);
/// (5) The stability report over the stiff suite (issue 4).
int run_stability(const Args& args);
/// (6) Primitives against FCL's and coal's specialised routines (issue 25).
int run_primitives(const Args& args);
/// (7) Penetration depth against the exact depth, peers side by side (issue 31).
int run_depth(const Args& args);

}  // namespace nearpoint::bench
