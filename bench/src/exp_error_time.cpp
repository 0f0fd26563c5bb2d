// SPDX-License-Identifier: Apache-2.0
// (3) Error against run time on the Section VII examples. Each implementation is run at a range
// of its accuracy knob:
//   nearpoint (Johnson and signed volumes): ε of eq. (35) from 1e-2 to 1e-15 and the engine's
//     default ε, and iteration caps 1 … 12 at the default ε (a capped run is an upper bound with a
//     certified error bound);
//   FCL (libccd and indep): DistanceRequest::distance_tolerance from 1e-2 to 1e-15;
//   Bullet: the simplex solver's equal-vertex threshold from 1e-2 to 1e-15 (its GJK's relative
//     tolerance is compiled in).
// For each setting and case: median and p99 time, max and median |d − d_exact|, and for nearpoint
// how often the reported error bound failed to cover the true error (it never may).
//
// As in experiment (1), settings are interleaved block by block within each round.
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

struct Setting {
  std::string impl;
  std::string knob;
  double value = kNaN;
  bool nearpoint = false;
  std::unique_ptr<Runner> runner;
  std::string declined;
};

std::vector<double> decades() {
  std::vector<double> v;
  for (int e = -2; e >= -15; --e) v.push_back(std::pow(10.0, e));
  return v;
}

}  // namespace

int run_error_time(const Args& args) {
  testkit::PaperExperimentConfig config;
  config.poses_per_case = args.quick ? 10 : 100;
  const int rounds = args.rounds > 0 ? args.rounds : (args.quick ? 2 : 5);
  progress("error-time: generating %d examples", config.poses_per_case * 60);
  const std::vector<PaperExample> examples = testkit::paper_experiment(config);
  const std::size_t n = examples.size();
  std::vector<PairInput> inputs;
  for (const PaperExample& e : examples)
    inputs.push_back({e.vertices_a, e.vertices_b, e.pose_a, e.pose_b, 0, 0});

  std::vector<Setting> settings;
  for (const Subalgorithm method : {Subalgorithm::johnson, Subalgorithm::signed_volumes}) {
    const std::string name =
        method == Subalgorithm::johnson ? "nearpoint_johnson" : "nearpoint_signed_volumes";
    std::vector<double> epsilons = decades();
    // The engine's default ε too, wherever it lies (it need not be a power of ten).
    if (std::find(epsilons.begin(), epsilons.end(), kDefaultEpsilon<double>) == epsilons.end())
      epsilons.push_back(kDefaultEpsilon<double>);
    for (const double eps : epsilons) {
      DistanceOptions<double> options;
      options.subalgorithm = method;
      options.epsilon = eps;
      settings.push_back(
          {name, "epsilon", eps, true, make_nearpoint_runner(inputs, options, false), ""});
    }
    for (const int cap : {1, 2, 3, 4, 5, 6, 8, 12}) {
      DistanceOptions<double> options;
      options.subalgorithm = method;
      options.max_iterations = cap;
      settings.push_back({name, "max_iterations", double(cap), true,
                          make_nearpoint_runner(inputs, options, false), ""});
    }
  }
  for (const Peer peer : {Peer::fcl_libccd, Peer::fcl_indep, Peer::bullet}) {
    const char* knob = peer == Peer::bullet ? "equal_vertex_threshold" : "distance_tolerance";
    for (const double tol : decades()) {
      Setting s{to_string(peer), knob, tol, false, nullptr, ""};
      s.runner = make_peer_runner(peer, inputs, PeerSettings{tol}, &s.declined);
      settings.push_back(std::move(s));
    }
  }
  const std::size_t m = settings.size();

  std::map<std::pair<int, int>, std::vector<std::uint32_t>> block_map;
  for (std::size_t i = 0; i < n; ++i)
    block_map[{examples[i].pair, int(examples[i].kind)}].push_back(std::uint32_t(i));
  std::vector<std::vector<std::uint32_t>> blocks;
  for (auto& [key, indices] : block_map) blocks.push_back(std::move(indices));

  std::vector<std::vector<std::vector<float>>> ns(
      m, std::vector<std::vector<float>>(std::size_t(rounds), std::vector<float>(n)));
  std::vector<std::vector<Outcome>> outcomes(m, std::vector<Outcome>(n));
  std::vector<float> scratch(n);
  std::mt19937_64 rng(20240918);
  for (int round = -1; round < rounds; ++round) {
    std::vector<std::size_t> order(blocks.size());
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), rng);
    for (std::size_t pos = 0; pos < order.size(); ++pos) {
      for (std::size_t k = 0; k < m; ++k) {
        const std::size_t which = (pos * 7 + std::size_t(round + 1) * 13 + k) % m;
        Setting& s = settings[which];
        if (!s.runner) continue;
        if (round < 0)
          time_queries(*s.runner, blocks[order[pos]], scratch, outcomes[which]);
        else
          time_queries(*s.runner, blocks[order[pos]], ns[which][std::size_t(round)]);
      }
    }
    progress("error-time: round %d/%d done", round + 1, rounds);
  }

  Csv table(
      output_path(args, "error_time.csv"),
      {"impl", "knob", "value", "case", "median_ns", "p99_ns", "max_error", "median_error",
       "mean_iterations", "wrong_verdicts", "nans", "capped", "bound_violations", "declined"});
  Csv bounds(output_path(args, "error_bound_points.csv"),
             {"impl", "knob", "value", "case", "error", "error_bound"});
  const std::vector<std::string> case_names = {"separated", "touching", "intersecting"};
  for (const Setting& s : settings) {
    const std::size_t k = std::size_t(&s - settings.data());
    for (int c = 0; c < 3; ++c) {
      if (!s.runner) {
        table << s.impl << s.knob << s.value << case_names[std::size_t(c)] << kNaN << kNaN << kNaN
              << kNaN << kNaN << 0 << 0 << 0 << 0 << s.declined;
        table.end_row();
        continue;
      }
      std::vector<float> times;
      std::vector<double> errors;
      std::vector<std::pair<double, double>> error_bound;  // nearpoint: (true error, bound)
      int wrong = 0, nans = 0, capped = 0, violations = 0;
      long iterations = 0, iteration_reports = 0;
      for (std::size_t i = 0; i < n; ++i) {
        const PaperExample& e = examples[i];
        if (int(e.kind) != c) continue;
        for (int r = 0; r < rounds; ++r) times.push_back(ns[k][std::size_t(r)][i]);
        const Outcome& o = outcomes[k][i];
        // A capped run gives no verdict (its status says so): counted as capped, not as wrong.
        if (o.exit == Exit::iteration_cap)
          ++capped;
        else if (e.kind != PaperCase::touching && o.intersecting != e.exact.intersecting)
          ++wrong;
        if (o.iterations >= 0) {
          iterations += o.iterations;
          ++iteration_reports;
        }
        if (std::isnan(o.distance)) {
          ++nans;
          continue;
        }
        const double error = std::abs(o.distance - e.exact.distance);
        errors.push_back(error);
        if (s.nearpoint) {
          error_bound.emplace_back(error, o.error_bound);
          if (error > o.error_bound) ++violations;
        }
      }
      const double max_error =
          errors.empty() ? kNaN : *std::max_element(errors.begin(), errors.end());
      table << s.impl << s.knob << s.value << case_names[std::size_t(c)] << median(times)
            << quantile(times, 0.99) << max_error << median(errors)
            << (iteration_reports ? double(iterations) / double(iteration_reports) : kNaN) << wrong
            << nans << capped << violations << "";
      table.end_row();

      // A readable sample of (true error, bound) for the bound plot: the 10 largest errors, the
      // 10 tightest bounds (largest error/bound), and 30 spread over the examples.
      if (!error_bound.empty()) {
        std::vector<std::size_t> keep;
        std::vector<std::size_t> idx(error_bound.size());
        std::iota(idx.begin(), idx.end(), 0);
        std::sort(idx.begin(), idx.end(),
                  [&](auto a, auto b) { return error_bound[a].first > error_bound[b].first; });
        keep.insert(keep.end(), idx.begin(),
                    idx.begin() + std::min<std::ptrdiff_t>(10, std::ptrdiff_t(idx.size())));
        auto ratio = [&](std::size_t j) {
          return error_bound[j].second > 0 ? error_bound[j].first / error_bound[j].second : 0.0;
        };
        std::sort(idx.begin(), idx.end(), [&](auto a, auto b) { return ratio(a) > ratio(b); });
        keep.insert(keep.end(), idx.begin(),
                    idx.begin() + std::min<std::ptrdiff_t>(10, std::ptrdiff_t(idx.size())));
        for (std::size_t j = 0; j < error_bound.size();
             j += std::max<std::size_t>(1, error_bound.size() / 30))
          keep.push_back(j);
        std::sort(keep.begin(), keep.end());
        keep.erase(std::unique(keep.begin(), keep.end()), keep.end());
        for (const std::size_t j : keep) {
          bounds << s.impl << s.knob << s.value << case_names[std::size_t(c)]
                 << error_bound[j].first << error_bound[j].second;
          bounds.end_row();
        }
      }
    }
  }
  progress("error-time: done");
  return 0;
}

}  // namespace nearpoint::bench
