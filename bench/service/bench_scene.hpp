// SPDX-License-Identifier: Apache-2.0
// The service benchmarks' scene, shared by nearpoint_service_bench (gRPC) and
// nearpoint_dds_bench (gRPC beside DDS): 10 polytopes shaped like the paper's Section VII family
// (12–100 vertices, 448 in all, 45 pairs) moving along a smooth trajectory.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>
#include <random>
#include <utility>
#include <vector>

namespace bench_scene {

using Vec3 = Eigen::Vector3d;

inline std::vector<Vec3> polygon_prism(int sides, double bottom_radius, double top_radius,
                                       double half) {
  std::vector<Vec3> out;
  for (int k = 0; k < sides; ++k) {
    const double angle = 2 * std::numbers::pi * k / sides;
    out.emplace_back(bottom_radius * std::cos(angle), bottom_radius * std::sin(angle), -half);
    out.emplace_back(top_radius * std::cos(angle), top_radius * std::sin(angle), half);
  }
  return out;
}

// M/2 vertices at random angles on each of two circles in the planes z = ±h (the paper's 7–12).
inline std::vector<Vec3> irregular(std::mt19937_64& rng, int m, double radius) {
  std::uniform_real_distribution<double> unit(0, 1);
  const double h = (0.2 + 0.4 * unit(rng)) * radius;
  const double top = std::sqrt(radius * radius - h * h);
  const double bottom = top * (0.5 + 0.5 * unit(rng));
  std::vector<Vec3> out;
  for (int k = 0; k < m / 2; ++k) {
    const double a = 2 * std::numbers::pi * unit(rng);
    out.emplace_back(top * std::cos(a), top * std::sin(a), h);
  }
  for (int k = 0; k < m / 2; ++k) {
    const double a = 2 * std::numbers::pi * unit(rng);
    out.emplace_back(bottom * std::cos(a), bottom * std::sin(a), -h);
  }
  return out;
}

inline std::vector<std::vector<Vec3>> paper_like_polytopes() {
  std::mt19937_64 rng(1988);
  std::vector<std::vector<Vec3>> out;
  out.push_back(polygon_prism(6, 1.0, 0.6, 0.8));   // 12: truncated cone, hexagonal ends
  out.push_back(polygon_prism(8, 1.0, 1.0, 1.0));   // 16: octagonal cylinder
  out.push_back(polygon_prism(10, 0.9, 0.9, 1.2));  // 20: decagonal cylinder
  for (const int m : {20, 30, 40, 50, 60, 100, 100})
    out.push_back(irregular(rng, m, 1.0 + m / 100.0));
  return out;
}

/// The pose of object `i` (of 10) at `step`: on a circle of radius 3.2 (neighbours ~2 m apart,
/// about their size, so pairs pass in and out of contact), each drifting and turning slowly — a
/// smooth trajectory with a period of ~1000 steps, like the paper's T = 1000.
inline std::pair<Eigen::Quaterniond, Vec3> object_pose(int i, int step, double phase) {
  const double t = 2 * std::numbers::pi * step / 1000.0 + phase;
  const double theta = 2 * std::numbers::pi * i / 10;
  const Vec3 position =
      3.2 * Vec3(std::cos(theta), std::sin(theta), 0) +
      Vec3(0.6 * std::sin(t + i), 0.6 * std::cos(1.3 * t + 2 * i), 0.3 * std::sin(0.7 * t + i));
  const Eigen::Quaterniond q(
      Eigen::AngleAxisd(t * (1 + 0.1 * i) + i, Vec3(1 + i % 3, 1 - i % 2, 0.5 + i).normalized()));
  return {q, position};
}

}  // namespace bench_scene
