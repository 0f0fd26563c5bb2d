// SPDX-License-Identifier: Apache-2.0
// (1) The paper's Section VII experiment (Fig. 4): 12 polytopes, 20 pairs, separated / just
// touching / intersecting, 100 random poses each — 6000 examples from the fixed-seed generator of
// tests/common/paper_family.hpp, each with CGAL's exact distance.
//
// Timing design. Every query is timed on its own (clock overhead subtracted). A round runs every
// implementation on every example; within a round the 60 (pair, case) blocks come in a shuffled
// order and, block by block, the implementations take turns in a rotating order. So a burst of
// noise from the other processes on this machine lands on all implementations alike instead of
// on whichever happened to run at that moment. Reported: pooled medians and p99 over all
// examples × rounds, and the spread of the per-round medians (run-to-run variation).
#include <algorithm>
#include <map>
#include <numeric>
#include <random>

#include "common/paper_family.hpp"
#include "experiments.hpp"
#include "runners.hpp"

namespace nearpoint::bench {
namespace {

using testkit::PaperCase;
using testkit::PaperExample;

struct Impl {
  std::string name;
  bool yes_no = false;  // answers only "intersecting?"
  std::unique_ptr<Runner> runner;
  std::string declined;  // why the implementation is missing from this run, or ""
};

std::vector<Impl> make_impls(std::span<const PairInput> inputs) {
  std::vector<Impl> impls;
  auto nearpoint = [&](const char* name, Subalgorithm method, bool yes_no) {
    DistanceOptions<double> options;
    options.subalgorithm = method;
    if (yes_no) {
      options.distance_cutoff = 0;  // "intersecting?" only: stops at the first separating plane
    } else {
      options.near_points = true;  // as the peers are asked for theirs
    }
    impls.push_back({name, yes_no, make_nearpoint_runner(inputs, options, false), ""});
  };
  auto peer = [&](Peer p, bool yes_no, std::string name = "", double tolerance = kNaN) {
    Impl impl{name.empty() ? to_string(p) : name, yes_no, nullptr, ""};
    impl.runner = make_peer_runner(p, inputs, PeerSettings{tolerance}, &impl.declined);
    impls.push_back(std::move(impl));
  };
  nearpoint("nearpoint_johnson", Subalgorithm::johnson, false);
  nearpoint("nearpoint_signed_volumes", Subalgorithm::signed_volumes, false);
  peer(Peer::fcl_libccd, false);
  peer(Peer::fcl_indep, false);
  peer(Peer::bullet, false);
  // The fastest open peers (issue 25): openGJK, and coal at 1e-12 (an answer as exact as the
  // others') and at its default 1e-6 (its own speed).
  peer(Peer::opengjk, false);
  peer(Peer::coal, false, "coal_1e-12", 1e-12);
  peer(Peer::coal, false, "coal_1e-6", 1e-6);
  nearpoint("nearpoint_johnson_yesno", Subalgorithm::johnson, true);
  nearpoint("nearpoint_signed_volumes_yesno", Subalgorithm::signed_volumes, true);
  peer(Peer::ccd_intersect, true);
  return impls;
}

// Accuracy of one answer against the exact distance.
struct Accuracy {
  double max_error = 0;
  std::vector<double> errors;
  int wrong_verdicts = 0;  // separated and intersecting cases only (see below)
  int nans = 0;
  int bound_violations = 0;  // nearpoint: |d − d_exact| > reported error bound
  int intersecting_answers = 0;
  long iterations = 0;
  int iteration_reports = 0;
};

void account(const PaperExample& e, const Outcome& o, bool yes_no, Accuracy& acc) {
  // The verdict is judged where the truth has a margin: separated examples are ≥ 0.05 apart,
  // intersecting ones overlap by 10–50% of the smaller radius. A just-touching example is at
  // distance 0 up to the rounding of its pose (±1e-16), so either verdict is right there; its
  // distance error is what counts.
  if (o.intersecting) ++acc.intersecting_answers;
  // A capped run (status iteration_limit) gives no verdict, so it cannot give a wrong one; with
  // the default cap it does not happen here.
  if (e.kind != PaperCase::touching && o.exit != Exit::iteration_cap &&
      o.intersecting != e.exact.intersecting)
    ++acc.wrong_verdicts;
  if (o.iterations >= 0) {
    acc.iterations += o.iterations;
    ++acc.iteration_reports;
  }
  if (yes_no) return;
  if (std::isnan(o.distance)) {
    ++acc.nans;
    return;
  }
  const double error = std::abs(o.distance - e.exact.distance);
  acc.errors.push_back(error);
  acc.max_error = std::max(acc.max_error, error);
  if (!std::isnan(o.error_bound) && error > o.error_bound) ++acc.bound_violations;
}

}  // namespace

int run_paper(const Args& args) {
  testkit::PaperExperimentConfig config;
  config.poses_per_case = args.quick ? 10 : 100;
  const int rounds = args.rounds > 0 ? args.rounds : (args.quick ? 3 : 41);
  progress("paper: generating %d examples with exact distances (CGAL)", config.poses_per_case * 60);
  testkit::PaperExperimentStats stats;
  const std::vector<PaperExample> examples = testkit::paper_experiment(config, &stats);
  const std::size_t n = examples.size();

  std::vector<PairInput> inputs;
  inputs.reserve(n);
  for (const PaperExample& e : examples)
    inputs.push_back({e.vertices_a, e.vertices_b, e.pose_a, e.pose_b, 0, 0});
  std::vector<Impl> impls = make_impls(inputs);
  const std::size_t m = impls.size();

  // Blocks of one (pair, case): the examples are ordered pair, draw, case.
  std::map<std::pair<int, int>, std::vector<std::uint32_t>> block_map;
  for (std::size_t i = 0; i < n; ++i)
    block_map[{examples[i].pair, int(examples[i].kind)}].push_back(std::uint32_t(i));
  std::vector<std::vector<std::uint32_t>> blocks;
  for (auto& [key, indices] : block_map) blocks.push_back(std::move(indices));

  // ns[impl][round][example]; outcomes from round 0 (every round computes the same answers).
  std::vector<std::vector<std::vector<float>>> ns(
      m, std::vector<std::vector<float>>(std::size_t(rounds), std::vector<float>(n, 0.f)));
  std::vector<std::vector<Outcome>> outcomes(m, std::vector<Outcome>(n));
  std::vector<float> scratch(n);

  std::mt19937_64 rng(20240917);
  for (int round = -1; round < rounds; ++round) {  // round −1 warms caches and pages, untimed
    std::vector<std::size_t> order(blocks.size());
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), rng);
    for (std::size_t pos = 0; pos < order.size(); ++pos) {
      const std::vector<std::uint32_t>& block = blocks[order[pos]];
      for (std::size_t k = 0; k < m; ++k) {
        Impl& impl = impls[(pos + std::size_t(round + 1) + k) % m];
        if (!impl.runner) continue;
        const std::size_t which = std::size_t(&impl - impls.data());
        if (round < 0) {
          time_queries(*impl.runner, block, scratch, outcomes[which]);
        } else {
          time_queries(*impl.runner, block, ns[which][std::size_t(round)]);
        }
      }
    }
    if (round >= 0 && (round % 10 == 0 || round + 1 == rounds))
      progress("paper: round %d/%d done", round + 1, rounds);
  }

  // ---- per (implementation, case, pair) ----
  Csv pairs(output_path(args, "paper_pairs.csv"),
            {"impl", "yes_no", "case", "pair", "polytope_a", "polytope_b", "M", "examples",
             "samples", "median_ns", "p99_ns", "ns_per_vertex", "mean_iterations", "max_error",
             "median_error", "wrong_verdicts", "nans", "bound_violations", "intersecting_answers"});
  Csv cases(output_path(args, "paper_cases.csv"),
            {"impl", "yes_no", "case", "examples", "samples", "median_ns", "p99_ns",
             "round_median_min", "round_median_max", "spread_pct", "mean_iterations", "max_error",
             "median_error", "wrong_verdicts", "nans", "bound_violations", "declined"});
  const std::vector<std::string> case_names = {"separated", "touching", "intersecting", "all"};
  for (std::size_t k = 0; k < m; ++k) {
    const Impl& impl = impls[k];
    for (int c = 0; c < 4; ++c) {
      auto in_case = [&](const PaperExample& e) { return c == 3 || int(e.kind) == c; };
      if (!impl.runner) {
        cases << impl.name << int(impl.yes_no) << case_names[std::size_t(c)] << 0 << 0 << kNaN
              << kNaN << kNaN << kNaN << kNaN << kNaN << kNaN << kNaN << 0 << 0 << 0
              << impl.declined;
        cases.end_row();
        continue;
      }
      // Pooled over the case.
      std::vector<float> pooled;
      std::vector<double> round_medians;
      Accuracy acc;
      int count = 0;
      for (int r = 0; r < rounds; ++r) {
        std::vector<float> this_round;
        for (std::size_t i = 0; i < n; ++i)
          if (in_case(examples[i])) this_round.push_back(ns[k][std::size_t(r)][i]);
        pooled.insert(pooled.end(), this_round.begin(), this_round.end());
        round_medians.push_back(median(this_round));
      }
      for (std::size_t i = 0; i < n; ++i) {
        if (!in_case(examples[i])) continue;
        account(examples[i], outcomes[k][i], impl.yes_no, acc);
        ++count;
      }
      const double med = median(pooled);
      const double p99 = quantile(pooled, 0.99);
      const auto [lo, hi] = std::minmax_element(round_medians.begin(), round_medians.end());
      cases << impl.name << int(impl.yes_no) << case_names[std::size_t(c)] << count << pooled.size()
            << med << p99 << *lo << *hi << 100.0 * (*hi - *lo) / med
            << (acc.iteration_reports ? double(acc.iterations) / acc.iteration_reports : kNaN)
            << (impl.yes_no ? kNaN : acc.max_error) << (impl.yes_no ? kNaN : median(acc.errors))
            << acc.wrong_verdicts << acc.nans << acc.bound_violations << "";
      cases.end_row();
      if (c == 3) continue;

      // Per pair within the case.
      for (std::size_t p = 0; p < testkit::kPaperPairs.size(); ++p) {
        std::vector<float> samples;
        Accuracy pacc;
        int examples_in_pair = 0;
        std::size_t vertices = 0;
        for (std::size_t i = 0; i < n; ++i) {
          const PaperExample& e = examples[i];
          if (e.pair != int(p) || int(e.kind) != c) continue;
          ++examples_in_pair;
          vertices = e.vertices_a->size() + e.vertices_b->size();
          for (int r = 0; r < rounds; ++r) samples.push_back(ns[k][std::size_t(r)][i]);
          account(e, outcomes[k][i], impl.yes_no, pacc);
        }
        const double pmed = median(samples);
        pairs << impl.name << int(impl.yes_no) << case_names[std::size_t(c)] << int(p)
              << testkit::kPaperPairs[p].first << testkit::kPaperPairs[p].second << vertices
              << examples_in_pair << samples.size() << pmed << quantile(samples, 0.99)
              << pmed / double(vertices)
              << (pacc.iteration_reports ? double(pacc.iterations) / pacc.iteration_reports : kNaN)
              << (impl.yes_no ? kNaN : pacc.max_error) << (impl.yes_no ? kNaN : median(pacc.errors))
              << pacc.wrong_verdicts << pacc.nans << pacc.bound_violations
              << pacc.intersecting_answers;
        pairs.end_row();
      }
    }
  }

  Csv meta(output_path(args, "paper_meta.csv"), {"key", "value"});
  meta << "examples" << n;
  meta.end_row();
  meta << "poses_per_case" << config.poses_per_case;
  meta.end_row();
  meta << "rounds" << rounds;
  meta.end_row();
  meta << "discarded_draws" << stats.discarded_draws;
  meta.end_row();
  meta << "pushed_apart" << stats.pushed_apart;
  meta.end_row();
  meta << "clock_overhead_ns" << clock_overhead_ns();
  meta.end_row();
  // The engine's defaults at the time of the run (the report quotes them, never a stale copy).
  const DistanceOptions<double> defaults;
  meta << "default_epsilon" << defaults.epsilon;
  meta.end_row();
  meta << "default_subalgorithm"
       << (defaults.subalgorithm == Subalgorithm::johnson ? "johnson" : "signed_volumes");
  meta.end_row();
  meta << "default_max_iterations" << defaults.max_iterations;
  meta.end_row();
  progress("paper: done");
  return 0;
}

}  // namespace nearpoint::bench
