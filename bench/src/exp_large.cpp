// SPDX-License-Identifier: Apache-2.0
// (4) Large polytopes: the hulls of N random points on a unit sphere (A) and on an ellipsoid with
// radii 1, 0.6, 0.35 (B), N = 10² … 10⁵. B follows a closed path around A that alternates between
// separated (gaps up to ~0.75), touching and deeply intersecting configurations while it turns, in
// P small steps. Timed per query: nearpoint cold (no cache: the default start) and warm (the
// cache carried from the previous step, Section VIII), and the peers cold. The exact distance
// (CGAL) is computed on every 10th step (50th above 10⁴ vertices) for the error columns.
//
// nearpoint runs twice: with polytopes from nearpoint::hull_polytope (hull faces given, so from
// Polytope::kHillClimbThreshold vertices on the support climbs the hull's edges), and with plain
// vertex lists (the vectorised linear scan), so the crossover can be read off. FCL's fcl::Convex
// walks the adjacency on its own for hulls above 32 vertices.
#include <algorithm>
#include <numbers>
#include <random>

#include "common/exact_distance.hpp"
#include "common/paper_family.hpp"
#include "experiments.hpp"
#include "nearpoint/hull.hpp"
#include "runners.hpp"

namespace nearpoint::bench {
namespace {

std::shared_ptr<const std::vector<Vec3<double>>> hull_of_samples(int n, const Vec3<double>& radii,
                                                                 std::uint64_t seed,
                                                                 std::size_t& hull_size) {
  std::mt19937_64 rng(seed);
  std::vector<Vec3<double>> points;
  points.reserve(std::size_t(n));
  for (int k = 0; k < n; ++k)
    points.push_back(radii.cwiseProduct(testkit::random_unit_vector(rng)));
  // Rounded to double, a few points may fall a hair inside the hull of their neighbours: the
  // polytope is the hull's vertex list, as a user building it from a mesh would have it.
  const Hull hull = convex_hull(points);
  hull_size = hull.vertices.size();
  return std::make_shared<const std::vector<Vec3<double>>>(hull.vertices);
}

// B's pose at s ∈ [0, 1): centre circling A at a distance oscillating between 1.1 and 2.1 (three
// times per turn), rotating about a fixed tilted axis by two full turns.
Pose<double> path_pose(double s) {
  const double theta = 2 * std::numbers::pi * s;
  const double rho = 1.6 + 0.5 * std::cos(3 * theta);
  Pose<double> pose;
  pose.translation =
      Vec3<double>(rho * std::cos(theta), rho * std::sin(theta), 0.25 * std::sin(2 * theta));
  pose.rotation = Eigen::AngleAxisd(4 * std::numbers::pi * s, Vec3<double>(1, 2, 3).normalized())
                      .toRotationMatrix();
  return pose;
}

}  // namespace

int run_large(const Args& args) {
  const std::vector<int> sizes = args.quick
                                     ? std::vector<int>{100, 1000, 10000}
                                     : std::vector<int>{100, 300, 1000, 3000, 10000, 30000, 100000};
  const int steps = args.quick ? 100 : 500;
  const int rounds = args.rounds > 0 ? args.rounds : (args.quick ? 2 : 5);

  Csv table(output_path(args, "large.csv"),
            {"points", "hull_vertices_a", "hull_vertices_b", "impl", "mode", "steps", "rounds",
             "median_ns", "p99_ns", "round_median_min", "round_median_max", "mean_iterations",
             "max_error", "exact_checked", "intersecting_steps", "steps_timed", "declined"});
  for (const int n : sizes) {
    const auto started = Clock::now();
    std::size_t hull_a = 0, hull_b = 0;
    const auto a = hull_of_samples(n, Vec3<double>(1, 1, 1), 1000 + std::uint64_t(n), hull_a);
    const auto b = hull_of_samples(n, Vec3<double>(1, 0.6, 0.35), 2000 + std::uint64_t(n), hull_b);
    std::vector<PairInput> inputs;
    for (int t = 0; t < steps; ++t)
      inputs.push_back({a, b, Pose<double>::identity(), path_pose(double(t) / steps), 0, 0});

    // Exact distances on every 10th step, every 50th above 10⁴ vertices (the oracle costs up to
    // half a second per query at 10⁵ vertices).
    const int exact_stride = n > 10000 ? 50 : 10;
    std::vector<double> exact(std::size_t(steps), kNaN);
    int intersecting_steps = 0;
    for (int t = 0; t < steps; t += exact_stride) {
      const testkit::ExactDistance e = testkit::exact_distance<double>(
          *a, inputs[std::size_t(t)].pose_a, *b, inputs[std::size_t(t)].pose_b);
      exact[std::size_t(t)] = e.distance;
      intersecting_steps += e.intersecting;
    }

    struct Impl {
      std::string name;
      std::string mode;
      std::unique_ptr<Runner> runner;
      std::string declined;
    };
    std::vector<Impl> impls;
    for (const Subalgorithm method : {Subalgorithm::johnson, Subalgorithm::signed_volumes}) {
      DistanceOptions<double> options;
      options.subalgorithm = method;
      options.near_points = true;
      const char* name =
          method == Subalgorithm::johnson ? "nearpoint_johnson" : "nearpoint_signed_volumes";
      impls.push_back({name, "cold", make_nearpoint_runner(inputs, options, false, true), ""});
      impls.push_back({name, "warm", make_nearpoint_runner(inputs, options, true, true), ""});
      const std::string scan = std::string(name) + "_scan";
      impls.push_back({scan, "cold", make_nearpoint_runner(inputs, options, false, false), ""});
      impls.push_back({scan, "warm", make_nearpoint_runner(inputs, options, true, false), ""});
    }
    for (const Peer peer : {Peer::fcl_libccd, Peer::fcl_indep, Peer::bullet}) {
      Impl impl{to_string(peer), "cold", nullptr, ""};
      impl.runner = make_peer_runner(peer, inputs, PeerSettings{}, &impl.declined);
      impls.push_back(std::move(impl));
    }

    // Steps in path order (the warm runs need it); implementations in a rotating order per round.
    // Cold queries do not depend on their predecessor, so above 10⁴ vertices, where one query
    // costs milliseconds, the cold runs take every 5th or 10th step only (an even subsample of the
    // same path, still containing every step with an exact distance): that keeps the whole run
    // within its time budget. Warm runs always take every step.
    const std::size_t m = impls.size();
    const std::size_t p = std::size_t(steps);
    const int stride = n > 30000 ? 10 : (n > 10000 ? 5 : 1);
    std::vector<std::uint32_t> order(p), cold_order;
    for (int t = 0; t < steps; ++t) {
      order[std::size_t(t)] = std::uint32_t(t);
      if (t % stride == 0) cold_order.push_back(std::uint32_t(t));
    }
    std::vector<std::vector<std::vector<float>>> ns(
        m, std::vector<std::vector<float>>(std::size_t(rounds), std::vector<float>(p)));
    std::vector<std::vector<Outcome>> outcomes(m, std::vector<Outcome>(p));
    std::vector<float> scratch(p);
    for (int round = -1; round < rounds; ++round) {
      for (std::size_t k = 0; k < m; ++k) {
        const std::size_t which = (k + std::size_t(round + 1)) % m;
        Impl& impl = impls[which];
        if (!impl.runner) continue;
        impl.runner->reset();
        const std::vector<std::uint32_t>& steps_run = impl.mode == "warm" ? order : cold_order;
        if (round < 0)
          time_queries(*impl.runner, steps_run, scratch, outcomes[which]);
        else
          time_queries(*impl.runner, steps_run, ns[which][std::size_t(round)]);
      }
    }

    for (std::size_t k = 0; k < m; ++k) {
      const Impl& impl = impls[k];
      if (!impl.runner) {
        table << n << hull_a << hull_b << impl.name << impl.mode << steps << rounds << kNaN << kNaN
              << kNaN << kNaN << kNaN << kNaN << 0 << intersecting_steps << 0 << impl.declined;
        table.end_row();
        continue;
      }
      std::vector<float> pooled;
      std::vector<double> round_medians;
      const std::vector<std::uint32_t>& steps_run = impl.mode == "warm" ? order : cold_order;
      for (int r = 0; r < rounds; ++r) {
        std::vector<float> v;
        for (const std::uint32_t t : steps_run) v.push_back(ns[k][std::size_t(r)][t]);
        pooled.insert(pooled.end(), v.begin(), v.end());
        round_medians.push_back(median(v));
      }
      double max_error = 0;
      int checked = 0;
      long iterations = 0, iteration_reports = 0;
      for (const std::uint32_t t : steps_run) {
        const Outcome& o = outcomes[k][t];
        if (o.iterations >= 0) {
          iterations += o.iterations;
          ++iteration_reports;
        }
        if (std::isnan(exact[t])) continue;
        ++checked;
        max_error = std::max(max_error,
                             std::isnan(o.distance) ? INFINITY : std::abs(o.distance - exact[t]));
      }
      const auto [lo, hi] = std::minmax_element(round_medians.begin(), round_medians.end());
      const double round_lo = *lo, round_hi = *hi;
      table << n << hull_a << hull_b << impl.name << impl.mode << steps << rounds << median(pooled)
            << quantile(pooled, 0.99) << round_lo << round_hi
            << (iteration_reports ? double(iterations) / double(iteration_reports) : kNaN)
            << max_error << checked << intersecting_steps << steps_run.size() << "";
      table.end_row();
    }
    progress("large: N=%d done (hull %zu / %zu vertices, %.0f s)", n, hull_a, hull_b,
             std::chrono::duration<double>(Clock::now() - started).count());
  }
  progress("large: done");
  return 0;
}

}  // namespace nearpoint::bench
