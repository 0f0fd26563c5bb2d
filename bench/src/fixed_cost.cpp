// SPDX-License-Identifier: Apache-2.0
// nearpoint-fixed-cost: the fixed cost of a query on the smallest shapes (issue 25, item 2), with
// nothing but the core linked, so that two builds can be run alternately and callgrind can count
// one case's instructions without the bench's set-up.
//
//   nearpoint-fixed-cost [--passes N] [--case NAME] [--count]
//
// Cases: point-point (two spheres), segment-triangle (polytopes of 2 and 3 vertices, as in the
// paper set), capsule-capsule, box-box, sphere-hull24, hull24-hull24 (two 24-vertex polytopes).
// Each has 1,000 fixed-seed poses about half of them separated; near points are asked for, as in
// the bench. Timing: one pass runs the 1,000 queries back to back; reported is the median over
// passes of the time per query (ns), which includes the loop and a volatile store of the distance,
// ≈ 1 ns. With --count the passes are run untimed (for `valgrind --tool=callgrind`; divide Ir by
// passes × 1,000).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "nearpoint/distance.hpp"

namespace {

using nearpoint::Box;
using nearpoint::DistanceOptions;
using nearpoint::Mat3;
using nearpoint::Polytope;
using nearpoint::Pose;
using nearpoint::Shape;
using nearpoint::Vec3;

struct Case {
  std::string name;
  Shape<double> a, b;
  double reach;
};

Mat3<double> random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  Eigen::Quaterniond q(normal(rng), normal(rng), normal(rng), normal(rng));
  q.normalize();
  return q.toRotationMatrix();
}

}  // namespace

int main(int argc, char** argv) {
  int passes = 2000;
  bool count = false;
  std::string only;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--passes") && i + 1 < argc) {
      passes = std::atoi(argv[++i]);
    } else if (!std::strcmp(argv[i], "--case") && i + 1 < argc) {
      only = argv[++i];
    } else if (!std::strcmp(argv[i], "--count")) {
      count = true;
    } else {
      std::fprintf(stderr, "usage: nearpoint-fixed-cost [--passes N] [--case NAME] [--count]\n");
      return 2;
    }
  }
  std::vector<Vec3<double>> hull;
  {
    std::mt19937_64 rng(25);
    std::normal_distribution<double> normal;
    for (int k = 0; k < 24; ++k) {
      Vec3<double> p(normal(rng), normal(rng), normal(rng));
      hull.push_back(p.normalized().cwiseProduct(Vec3<double>(0.45, 0.35, 0.3)));
    }
  }
  const std::vector<Vec3<double>> segment = {Vec3<double>(-0.5, 0, 0), Vec3<double>(0.5, 0, 0)};
  const std::vector<Vec3<double>> triangle = {Vec3<double>(0.6, 0, 0), Vec3<double>(-0.3, 0.5, 0),
                                              Vec3<double>(-0.3, -0.5, 0)};
  std::vector<Case> cases = {
      {"point-point", Shape<double>::sphere(0.5), Shape<double>::sphere(0.3), 1.3},
      {"segment-triangle", Shape<double>(Polytope<double>(segment)),
       Shape<double>(Polytope<double>(triangle)), 1.3},
      {"capsule-capsule",
       Shape<double>::capsule(Vec3<double>(0, 0, -0.5), Vec3<double>(0, 0, 0.5), 0.2),
       Shape<double>::capsule(Vec3<double>(0, 0, -0.4), Vec3<double>(0, 0, 0.4), 0.15), 1.8},
      {"box-box", Shape<double>(Box<double>{Vec3<double>(0.5, 0.3, 0.2)}),
       Shape<double>(Box<double>{Vec3<double>(0.4, 0.4, 0.25)}), 1.6},
      {"sphere-hull24", Shape<double>::sphere(0.3), Shape<double>(Polytope<double>(hull)), 1.0},
      {"hull24-hull24", Shape<double>(Polytope<double>(hull)),
       Shape<double>(Polytope<double>(hull)), 1.2},
  };
  DistanceOptions<double> options;
  options.near_points = true;
  constexpr int kPoses = 1000;
  [[maybe_unused]] volatile double sink = 0;  // keeps the queries from being optimised away
  std::printf("%-18s %10s %10s %10s %12s\n", "case", "median_ns", "q10_ns", "q90_ns", "separated");
  for (const Case& c : cases) {
    if (!only.empty() && only != c.name) continue;
    std::mt19937_64 rng(20261202);
    std::uniform_real_distribution<double> dist(0, c.reach);
    std::normal_distribution<double> normal;
    std::vector<Pose<double>> pa(kPoses), pb(kPoses);
    int separated = 0;
    for (int k = 0; k < kPoses; ++k) {
      const Vec3<double> u = Vec3<double>(normal(rng), normal(rng), normal(rng)).normalized();
      pa[k] = Pose<double>{random_rotation(rng), Vec3<double>(0.1, -0.2, 0.3)};
      pb[k] = Pose<double>{random_rotation(rng), pa[k].translation + dist(rng) * u};
      separated += nearpoint::distance(c.a, pa[k], c.b, pb[k], options).status ==
                   nearpoint::Status::separated;
    }
    std::vector<double> per_query;
    per_query.reserve(std::size_t(passes));
    for (int p = 0; p < passes; ++p) {
      const auto t0 = std::chrono::steady_clock::now();
      for (int k = 0; k < kPoses; ++k)
        sink = nearpoint::distance(c.a, pa[k], c.b, pb[k], options).distance;
      const auto t1 = std::chrono::steady_clock::now();
      if (!count)
        per_query.push_back(std::chrono::duration<double, std::nano>(t1 - t0).count() / kPoses);
    }
    if (count) {
      std::printf("%-18s %d passes of %d queries\n", c.name.c_str(), passes, kPoses);
      continue;
    }
    std::sort(per_query.begin(), per_query.end());
    auto q = [&](double f) { return per_query[std::size_t(f * double(per_query.size() - 1))]; };
    std::printf("%-18s %10.1f %10.1f %10.1f %12d\n", c.name.c_str(), q(0.5), q(0.1), q(0.9),
                separated);
  }
  return 0;
}
