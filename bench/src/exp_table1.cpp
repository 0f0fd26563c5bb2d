// SPDX-License-Identifier: Apache-2.0
// (2) The paper's Section VIII / Table I: the two-piece object moving through five obstacles
// (scenes/include/nearpoint/scenes/moving_object.hpp), distances to every obstacle at s = t/T,
// t = 0 … T, for T = 10, 100, 1000, 10000. Total time with the single-point initialisation of
// Section VI (cold: no cache) against the warm start from the previous step's simplex (one
// SimplexCache per piece pair and obstacle, carried along the path), and their ratio.
//
// A sweep is timed as a whole, in CPU time of the measuring thread (the paper's CPU times; wall
// time would include other processes' time slices on a shared machine). Cold and warm sweeps
// alternate, their order swapped every round, and the reported time is the median over rounds.
#include <time.h>

#include <algorithm>
#include <array>

#include "experiments.hpp"
#include "nearpoint/scenes/moving_object.hpp"

namespace nearpoint::bench {
namespace {

using scenes::MovingObjectScene;

// This thread's CPU time (ns). A sweep of T = 10000 lasts ~0.1 s, long enough for the scheduler
// to hand the core to the other processes on this shared machine several times; wall-clock time
// would count their time slices, CPU time does not.
double thread_cpu_ns() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) * 1e9 + double(ts.tv_nsec);
}

struct SweepResult {
  double ns = 0;
  long iterations = 0;  // iterations of the nearest piece pair, summed
  long pairs_evaluated = 0;
  long warm_started = 0;
  long support_calls = 0;  // over all evaluated piece pairs (CompoundResult's sums)
  long subalgorithm_runs = 0;
  double checksum = 0;
};

class Sweeper {
 public:
  Sweeper(const MovingObjectScene& scene, int T) : scene_(scene), poses_(std::size_t(T) + 1) {
    for (int t = 0; t <= T; ++t) poses_[std::size_t(t)] = scene.pose_at(double(t) / T);
    for (auto& c : caches_) c.assign(scene.object.size(), SimplexCache{});
  }

  // One pass over the path. Distances go to `distances[t * 5 + i]` when given.
  SweepResult run(const DistanceOptions<double>& options, bool warm,
                  std::vector<double>* distances = nullptr) {
    for (auto& c : caches_) std::fill(c.begin(), c.end(), SimplexCache{});  // start cold
    SweepResult out;
    const double t0 = thread_cpu_ns();
    for (std::size_t t = 0; t < poses_.size(); ++t) {
      for (std::size_t i = 0; i < 5; ++i) {
        const CompoundResult<double> r = distance(
            scene_.object, poses_[t], scene_.obstacles[i], scene_.obstacle_poses[i], options,
            warm ? std::span<SimplexCache>(caches_[i]) : std::span<SimplexCache>());
        out.checksum += r.nearest.distance;
        out.iterations += r.nearest.iterations;
        out.pairs_evaluated += r.pairs_evaluated;
        out.warm_started += r.nearest.warm_started;
        out.support_calls += r.support_calls;
        out.subalgorithm_runs += r.subalgorithm_runs;
        if (distances) distances->push_back(r.nearest.distance);
      }
    }
    out.ns = thread_cpu_ns() - t0;
    return out;
  }

  const std::vector<Pose<double>>& poses() const { return poses_; }

 private:
  const MovingObjectScene& scene_;
  std::vector<Pose<double>> poses_;
  std::array<std::vector<SimplexCache>, 5> caches_;  // per obstacle: one per piece pair (2 × 1)
};

}  // namespace

int run_table1(const Args& args) {
  const MovingObjectScene scene = scenes::moving_object_scene();
  const std::array<int, 4> grid = {10, 100, 1000, 10000};
  // Rounds per T: enough for a stable median of short sweeps, few for the long ones.
  const std::array<int, 4> full_rounds = {401, 101, 31, 15};
  const std::array<int, 4> quick_rounds = {21, 11, 3, 1};

  Csv table(output_path(args, "table1.csv"), {"subalgorithm",
                                              "T",
                                              "queries",
                                              "rounds",
                                              "cold_ms",
                                              "warm_ms",
                                              "ratio",
                                              "cold_ms_min",
                                              "cold_ms_max",
                                              "warm_ms_min",
                                              "warm_ms_max",
                                              "cold_mean_iterations",
                                              "warm_mean_iterations",
                                              "warm_started_fraction",
                                              "pairs_evaluated_per_query",
                                              "max_abs_cold_warm_difference",
                                              "cold_support_calls_per_query",
                                              "warm_support_calls_per_query",
                                              "cold_subalgorithm_runs_per_query",
                                              "warm_subalgorithm_runs_per_query",
                                              "operation_ceiling"});
  for (const Subalgorithm method : {Subalgorithm::johnson, Subalgorithm::signed_volumes}) {
    DistanceOptions<double> options;
    options.subalgorithm = method;
    // The paper's comparison: warm start against Section VI's single-point initialisation.
    options.cold_start = ColdStart::single_point;
    const char* method_name = method == Subalgorithm::johnson ? "johnson" : "signed_volumes";
    for (std::size_t g = 0; g < grid.size(); ++g) {
      const int T = grid[g];
      const int rounds =
          args.rounds > 0 ? args.rounds : (args.quick ? quick_rounds[g] : full_rounds[g]);
      Sweeper sweeper(scene, T);
      // Untimed: agreement of cold and warm answers (both within their error bounds).
      std::vector<double> cold_d, warm_d;
      const SweepResult cold_stats = sweeper.run(options, false, &cold_d);
      const SweepResult warm_stats = sweeper.run(options, true, &warm_d);
      double max_difference = 0;
      for (std::size_t k = 0; k < cold_d.size(); ++k)
        max_difference = std::max(max_difference, std::abs(cold_d[k] - warm_d[k]));

      std::vector<double> cold_ns, warm_ns;
      for (int r = 0; r < rounds; ++r) {
        const bool cold_first = r % 2 == 0;
        for (int pass = 0; pass < 2; ++pass) {
          const bool warm = (pass == 0) != cold_first;
          const SweepResult s = sweeper.run(options, warm);
          (warm ? warm_ns : cold_ns).push_back(s.ns);
        }
      }
      const auto [cold_lo, cold_hi] = std::minmax_element(cold_ns.begin(), cold_ns.end());
      const auto [warm_lo, warm_hi] = std::minmax_element(warm_ns.begin(), warm_ns.end());
      const double lo_c = *cold_lo, hi_c = *cold_hi, lo_w = *warm_lo, hi_w = *warm_hi;
      const double cold = median(cold_ns), warm = median(warm_ns);
      const double queries = 5.0 * (T + 1);
      // A query's time is (work outside the two operations) + calls·c_s + runs·c_r. With the
      // operations costing no less warm than cold (the same scans; warm runs are on the larger
      // simplices), cold/warm ≤ max(calls_cold/calls_warm, runs_cold/runs_warm) whatever c_s,
      // c_r and the work outside are: the ceiling that no tuning of the operations can pass.
      const double ceiling =
          std::max(double(cold_stats.support_calls) / double(warm_stats.support_calls),
                   double(cold_stats.subalgorithm_runs) / double(warm_stats.subalgorithm_runs));
      table << method_name << T << long(queries) << rounds << cold * 1e-6 << warm * 1e-6
            << cold / warm << lo_c * 1e-6 << hi_c * 1e-6 << lo_w * 1e-6 << hi_w * 1e-6
            << double(cold_stats.iterations) / queries << double(warm_stats.iterations) / queries
            << double(warm_stats.warm_started) / queries
            << double(cold_stats.pairs_evaluated) / queries << max_difference
            << double(cold_stats.support_calls) / queries
            << double(warm_stats.support_calls) / queries
            << double(cold_stats.subalgorithm_runs) / queries
            << double(warm_stats.subalgorithm_runs) / queries << ceiling;
      table.end_row();
      progress("table1: %s T=%d cold %.3f ms warm %.3f ms ratio %.2f (operation ceiling %.2f)",
               method_name, T, cold * 1e-6, warm * 1e-6, cold / warm, ceiling);
    }
  }

  // The distances along the path (the paper's Fig. 6), with the penetration lower bound d⁻ of
  // eq. (32)–(33) as a negative extension where the object intersects an obstacle.
  {
    const int T = 1000;
    DistanceOptions<double> options;
    options.penetration_bound = true;
    Csv curve(output_path(args, "table1_distances.csv"),
              {"s", "obstacle", "name", "distance", "penetration_bound", "piece"});
    for (int t = 0; t <= T; ++t) {
      const double s = double(t) / T;
      const Pose<double> pose = scene.pose_at(s);
      for (std::size_t i = 0; i < 5; ++i) {
        const CompoundResult<double> r =
            distance(scene.object, pose, scene.obstacles[i], scene.obstacle_poses[i], options);
        curve << s << int(i + 1) << scene.obstacle_names[i] << r.nearest.distance
              << (r.nearest.has_penetration_bound ? r.nearest.penetration_bound : 0.0) << r.piece_a;
        curve.end_row();
      }
    }
  }
  progress("table1: done");
  return 0;
}

}  // namespace nearpoint::bench
