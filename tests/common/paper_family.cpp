// SPDX-License-Identifier: Apache-2.0
#include "common/paper_family.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace nearpoint::testkit {

const char* to_string(PaperCase c) {
  switch (c) {
    case PaperCase::separated:
      return "separated";
    case PaperCase::touching:
      return "touching";
    case PaperCase::intersecting:
      return "intersecting";
  }
  return "?";
}

double normal(std::mt19937_64& rng) {
  // Box–Muller with u1 in (0, 1] so that the logarithm is finite.
  const double u1 = 1.0 - uniform01(rng);
  const double u2 = uniform01(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

Vec3<double> random_unit_vector(std::mt19937_64& rng) {
  // Rejection from the cube into the unit ball, then normalised: uniform on the sphere, and only
  // +, ×, √ (correctly rounded everywhere), so the same on every platform.
  for (;;) {
    const Vec3<double> v(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1));
    const double n2 = v.squaredNorm();
    if (n2 <= 1.0 && n2 > 1e-6) return v / std::sqrt(n2);
  }
}

Mat3<double> random_rotation(std::mt19937_64& rng) {
  // A point uniform in the 4-ball, normalised, is a unit quaternion uniform on S³, i.e. a
  // uniformly distributed rotation.
  for (;;) {
    const Eigen::Vector4d v(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1),
                            uniform(rng, -1, 1));
    const double n2 = v.squaredNorm();
    if (n2 <= 1.0 && n2 > 1e-6) {
      const Eigen::Quaterniond q(v[0], v[1], v[2], v[3]);
      return q.normalized().toRotationMatrix();
    }
  }
}

namespace {

using Vertices = std::vector<Vec3<double>>;

// A regular n-gon of circumradius r in the plane z, first vertex at angle phase.
void add_polygon(Vertices& out, int n, double r, double z, double phase = 0) {
  for (int k = 0; k < n; ++k) {
    const double angle = phase + 2.0 * std::numbers::pi * k / n;
    out.emplace_back(r * std::cos(angle), r * std::sin(angle), z);
  }
}

// Irregular polytope of Section VII: m/2 vertices at uniformly random angles on each of two
// circles in the planes z = ±h, fitted in a sphere of radius `radius`. The half height is drawn in
// [0.2, 0.6]·radius; the upper circle touches the sphere, the lower one has 50–100% of its radius.
Vertices irregular(std::mt19937_64& rng, int m, double radius) {
  const double h = uniform(rng, 0.2, 0.6) * radius;
  const double rho_top = std::sqrt(radius * radius - h * h);
  const double rho_bottom = rho_top * uniform(rng, 0.5, 1.0);
  Vertices out;
  for (int k = 0; k < m / 2; ++k) {
    const double angle = uniform(rng, 0, 2.0 * std::numbers::pi);
    out.emplace_back(rho_top * std::cos(angle), rho_top * std::sin(angle), h);
  }
  for (int k = 0; k < m / 2; ++k) {
    const double angle = uniform(rng, 0, 2.0 * std::numbers::pi);
    out.emplace_back(rho_bottom * std::cos(angle), rho_bottom * std::sin(angle), -h);
  }
  return out;
}

double max_norm(const Vertices& v) {
  double r = 0;
  for (const auto& x : v) r = std::max(r, x.norm());
  return r;
}

// World-frame support value max_v u·(R v + t) in double (for the push-apart step only, whose
// margin dwarfs rounding).
double support(const Vertices& local, const Pose<double>& pose, const Vec3<double>& u) {
  const Vec3<double> local_u = pose.rotation.transpose() * u;
  double best = -INFINITY;
  for (const auto& v : local) best = std::max(best, local_u.dot(v));
  return best + u.dot(pose.translation);
}

// The index of the vertex reaching furthest along u (world frame).
int deepest(const Vertices& local, const Pose<double>& pose, const Vec3<double>& u) {
  const Vec3<double> local_u = pose.rotation.transpose() * u;
  int best = 0;
  for (std::size_t k = 1; k < local.size(); ++k)
    if (local_u.dot(local[k]) > local_u.dot(local[std::size_t(best)])) best = int(k);
  return best;
}

}  // namespace

std::vector<PaperPolytope> paper_polytopes(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<Vertices> shapes(12);
  // 1: segment of length 4.
  shapes[0] = {Vec3<double>(0, 0, -2), Vec3<double>(0, 0, 2)};
  // 2: equilateral triangle, circumradius 1.5.
  add_polygon(shapes[1], 3, 1.5, 0, std::numbers::pi / 2);
  // 3: rectangular box 2.4 × 1.6 × 1.0.
  for (int k = 0; k < 8; ++k)
    shapes[2].emplace_back(k & 1 ? 1.2 : -1.2, k & 2 ? 0.8 : -0.8, k & 4 ? 0.5 : -0.5);
  // 4: truncated cone with hexagonal ends: radius 2 at z = −1.2, radius 1 at z = +1.2.
  add_polygon(shapes[3], 6, 2.0, -1.2);
  add_polygon(shapes[3], 6, 1.0, 1.2);
  // 5: truncated cylinder with octagonal cross section, radius 1.5, height 4.
  add_polygon(shapes[4], 8, 1.5, -2.0);
  add_polygon(shapes[4], 8, 1.5, 2.0);
  // 6: truncated cylinder with decagonal cross section, radius 2.5, height 2.
  add_polygon(shapes[5], 10, 2.5, -1.0);
  add_polygon(shapes[5], 10, 2.5, 1.0);
  // 7–12: irregular, M = 20, 40, 50, 60, 100, 100, in spheres of radius 1, 3, 2, 4, 3.5, 1.5.
  const int counts[6] = {20, 40, 50, 60, 100, 100};
  const double radii[6] = {1.0, 3.0, 2.0, 4.0, 3.5, 1.5};
  for (int k = 0; k < 6; ++k) shapes[std::size_t(6 + k)] = irregular(rng, counts[k], radii[k]);

  static const char* const names[12] = {"segment",        "triangle",        "box",
                                        "hexagonal cone", "octagonal prism", "decagonal prism",
                                        "irregular M=20", "irregular M=40",  "irregular M=50",
                                        "irregular M=60", "irregular M=100", "irregular M=100'"};
  std::vector<PaperPolytope> out;
  for (int k = 0; k < 12; ++k) {
    PaperPolytope p;
    p.number = k + 1;
    p.name = names[k];
    p.bounding_radius = max_norm(shapes[std::size_t(k)]);
    p.vertices = std::make_shared<const Vertices>(std::move(shapes[std::size_t(k)]));
    out.push_back(std::move(p));
  }
  return out;
}

std::vector<PaperExample> paper_experiment(const PaperExperimentConfig& config,
                                           PaperExperimentStats* stats) {
  const std::vector<PaperPolytope> polytopes = paper_polytopes(config.seed);
  PaperExperimentStats local_stats;
  std::vector<PaperExample> out;
  out.reserve(kPaperPairs.size() * 3 * std::size_t(std::max(config.poses_per_case, 0)));

  for (std::size_t pair = 0; pair < kPaperPairs.size(); ++pair) {
    const PaperPolytope& pa = polytopes[std::size_t(kPaperPairs[pair].first - 1)];
    const PaperPolytope& pb = polytopes[std::size_t(kPaperPairs[pair].second - 1)];
    const Vertices& va = *pa.vertices;
    const Vertices& vb = *pb.vertices;
    // One stream per pair (seed mixed with the pair index by a golden-ratio step).
    std::mt19937_64 rng(config.seed + 0x9e3779b97f4a7c15ULL * (pair + 1));

    auto make = [&](PaperCase kind, int draw, const Pose<double>& a, const Pose<double>& b,
                    ExactDistance exact) {
      PaperExample e;
      e.pair = int(pair);
      e.kind = kind;
      e.draw = draw;
      e.polytope_a = pa.number;
      e.polytope_b = pb.number;
      e.vertices_a = pa.vertices;
      e.vertices_b = pb.vertices;
      e.pose_a = a;
      e.pose_b = b;
      e.radius_a = pa.bounding_radius;
      e.radius_b = pb.bounding_radius;
      e.exact = std::move(exact);
      return e;
    };

    for (int draw = 0; draw < config.poses_per_case;) {
      // Separated.
      Pose<double> pose_a, pose_b;
      pose_a.rotation = random_rotation(rng);
      pose_a.translation =
          Vec3<double>(uniform(rng, -2, 2), uniform(rng, -2, 2), uniform(rng, -2, 2));
      pose_b.rotation = random_rotation(rng);
      const Vec3<double> u = random_unit_vector(rng);
      const double length = uniform(rng, 0, 20.0 / 3.0);
      pose_b.translation = pose_a.translation + length * u;
      const double target_gap = uniform(rng, kMinSeparatedGap, 1.0);
      const double gap = -support(vb, pose_b, -u) - support(va, pose_a, u);
      if (gap < kMinSeparatedGap) {
        pose_b.translation += (target_gap - gap) * u;
        ++local_stats.pushed_apart;
      }
      ExactDistance separated = exact_distance(va, pose_a, vb, pose_b);
      if (separated.intersecting) {  // cannot happen: the gap along u is at least 0.05
        ++local_stats.discarded_draws;
        continue;
      }

      // Just touching: B moved back along the near-point line by the distance.
      const Vec3<double> gap_vector = separated.point_b - separated.point_a;
      const Vec3<double> n = gap_vector.normalized();
      Pose<double> pose_touch = pose_b;
      pose_touch.translation -= gap_vector;
      // Hint for the oracle: the separated support sets plus the vertex of each polytope lying
      // deepest behind its support plane, so that a rounding-level or deliberate overlap of a
      // face by a vertex is caught by a small tetrahedron at the first round.
      std::vector<int> hint_a = separated.support_a, hint_b = separated.support_b;
      hint_a.push_back(deepest(va, pose_a, -n));
      hint_b.push_back(deepest(vb, pose_b, n));
      ExactDistance touching = exact_distance(va, pose_a, vb, pose_touch, hint_a, hint_b);

      // Intersecting: further along the same line by 10–50% of the smaller radius.
      bool found = false;
      Pose<double> pose_overlap = pose_touch;
      ExactDistance overlap;
      for (int attempt = 0; attempt < 3 && !found; ++attempt) {
        const double depth =
            uniform(rng, 0.1, 0.5) * std::min(pa.bounding_radius, pb.bounding_radius);
        pose_overlap.translation = pose_touch.translation - depth * n;
        overlap = exact_distance(va, pose_a, vb, pose_overlap, hint_a, hint_b);
        found = overlap.intersecting;
      }
      if (!found) {
        ++local_stats.discarded_draws;
        continue;
      }

      out.push_back(make(PaperCase::separated, draw, pose_a, pose_b, std::move(separated)));
      out.push_back(make(PaperCase::touching, draw, pose_a, pose_touch, std::move(touching)));
      out.push_back(make(PaperCase::intersecting, draw, pose_a, pose_overlap, std::move(overlap)));
      ++draw;
    }
  }
  if (stats) *stats = local_stats;
  return out;
}

}  // namespace nearpoint::testkit
