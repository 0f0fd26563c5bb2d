// SPDX-License-Identifier: Apache-2.0
// Random convex polytopes for tests: the hull of random points in a ball. Seeded, so a test sees
// the same polytope every run.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "nearpoint/pose.hpp"

namespace nearpoint::testkit {

/// `count` random points in a ball of radius `radius` (their hull is a random polytope).
inline std::vector<Vec3<double>> random_hull_vertices(std::uint64_t seed, int count,
                                                      double radius) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(-1, 1);
  std::vector<Vec3<double>> out;
  while (int(out.size()) < count) {
    const Vec3<double> v(unit(rng), unit(rng), unit(rng));
    if (v.squaredNorm() <= 1) out.push_back(radius * v);
  }
  return out;
}

}  // namespace nearpoint::testkit
