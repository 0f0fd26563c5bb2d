// SPDX-License-Identifier: Apache-2.0
// The moving-object scene of the paper's Section VIII (after its Fig. 5, Canny's example): a
// two-piece object K_A = K6 ∪ K7 moves through five convex obstacles K1 … K5 along a straight
// line while its orientation turns by spherical linear interpolation (slerp); the distances are
// evaluated at s = t/T, t = 0 … T. As in the paper, the object passes through K3 and K5 (the
// distance reaches 0 there) and stays clear of K1, K2 and K4.
//
// The paper does not give the shapes' coordinates, so these are our own, chosen to resemble the
// figure: an L-shaped object (a long hexagonal bar and an octagonal frustum) and obstacles of
// 8–40 vertices. Everything is deterministic (no random numbers), so the benchmark's Table I and
// the `nearpoint demo` command see exactly the same scene.
//
// Header-only, depends on the core library only: link the CMake target nearpoint_scenes. The vertex
// lists are kept beside the engine's compounds so that a client can send exactly these vertices to
// a server (the engine stores polytopes centred, which would round the coordinates once more).
#pragma once

#include <array>
#include <cmath>
#include <numbers>
#include <vector>

#include "nearpoint/compound.hpp"

namespace nearpoint::scenes {

struct MovingObjectScene {
  /// The moving object K_A = K6 ∪ K7, in its own frame (piece 0 is K6, piece 1 is K7).
  Compound<double> object;
  /// The vertices of K6 and K7 (object frame) and of K1 … K5 (each obstacle's own frame): the
  /// polytopes above are the convex hulls of these.
  std::array<std::vector<Vec3<double>>, 2> object_piece_vertices;
  std::array<std::vector<Vec3<double>>, 5> obstacle_vertices;
  /// The fixed obstacles K1 … K5 (one convex piece each) and where they stand (world frame).
  std::array<Compound<double>, 5> obstacles;
  std::array<Pose<double>, 5> obstacle_poses;
  std::array<const char*, 5> obstacle_names = {"K1 box", "K2 hexagonal frustum",
                                               "K3 irregular M=40", "K4 32-point ball",
                                               "K5 decagonal prism"};
  /// The path's ends: q(0) and q(1) (world frame).
  Vec3<double> translation_start, translation_end;
  Eigen::Quaterniond rotation_start, rotation_end;

  /// q(s), s ∈ [0, 1]: the object's pose, position linear in s, orientation by slerp.
  Pose<double> pose_at(double s) const {
    Pose<double> pose;
    pose.rotation = rotation_start.slerp(s, rotation_end).normalized().toRotationMatrix();
    pose.translation = (1 - s) * translation_start + s * translation_end;
    return pose;
  }
};

namespace detail {

using Vertices = std::vector<Vec3<double>>;

// A regular n-gon of circumradius r at height `along` of the given axis (0 x, 1 y, 2 z).
inline void add_ring(Vertices& out, int n, double r, double along, int axis, double phase = 0) {
  for (int k = 0; k < n; ++k) {
    const double a = phase + 2 * std::numbers::pi * k / n;
    Vec3<double> p;
    p[axis] = along;
    p[(axis + 1) % 3] = r * std::cos(a);
    p[(axis + 2) % 3] = r * std::sin(a);
    out.push_back(p);
  }
}

inline Compound<double> single(Vertices v) {
  std::vector<Piece<double>> pieces;
  pieces.push_back({Shape<double>(Polytope<double>(v)), Pose<double>::identity()});
  return Compound<double>(std::move(pieces));
}

inline Pose<double> placed(const Vec3<double>& t, const Vec3<double>& axis = Vec3<double>::UnitZ(),
                           double angle = 0) {
  Pose<double> p;
  p.rotation = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  p.translation = t;
  return p;
}

}  // namespace detail

/// The scene. Units: metres-like, the object is about 4 × 2.5 × 1.4; the path is 24 long.
inline MovingObjectScene moving_object_scene() {
  using detail::Vertices;
  MovingObjectScene scene;

  // K6: a hexagonal bar of length 4 along x, circumradius 0.5.
  Vertices bar;
  detail::add_ring(bar, 6, 0.5, -2.0, 0);
  detail::add_ring(bar, 6, 0.5, 2.0, 0);
  // K7: an octagonal frustum standing on the bar's right end, along +y (radius 0.7 → 0.35).
  Vertices frustum;
  detail::add_ring(frustum, 8, 0.7, 0.3, 1, std::numbers::pi / 8);
  detail::add_ring(frustum, 8, 0.35, 2.4, 1, std::numbers::pi / 8);
  for (Vec3<double>& v : frustum) v.x() += 1.5;
  scene.object_piece_vertices = {bar, frustum};
  std::vector<Piece<double>> pieces;
  pieces.push_back({Shape<double>(Polytope<double>(bar)), Pose<double>::identity()});
  pieces.push_back({Shape<double>(Polytope<double>(frustum)), Pose<double>::identity()});
  scene.object = Compound<double>(std::move(pieces));

  // K1: a box 2 × 3 × 2.
  Vertices box;
  for (int k = 0; k < 8; ++k)
    box.emplace_back(k & 1 ? 1.0 : -1.0, k & 2 ? 1.5 : -1.5, k & 4 ? 1.0 : -1.0);
  // K2: a hexagonal frustum (radius 1.4 → 0.7, height 2.4) about z.
  Vertices cone;
  detail::add_ring(cone, 6, 1.4, -1.2, 2);
  detail::add_ring(cone, 6, 0.7, 1.2, 2);
  // K3: irregular, 20 vertices on each of two circles (z = ±0.8), angles from the golden ratio
  // sequence (deterministic, well spread, not regular).
  Vertices irregular;
  const double golden = (std::sqrt(5.0) - 1) / 2;
  for (int k = 0; k < 40; ++k) {
    const double a = 2 * std::numbers::pi * std::fmod(k * golden, 1.0);
    const double r = k < 20 ? 1.5 : 1.1;
    irregular.emplace_back(r * std::cos(a), r * std::sin(a), k < 20 ? 0.8 : -0.8);
  }
  // K4: 32 points spread over a sphere of radius 1.3 (Fibonacci lattice).
  Vertices ball;
  for (int k = 0; k < 32; ++k) {
    const double z = 1 - 2 * (k + 0.5) / 32, rho = std::sqrt(1 - z * z);
    const double a = std::numbers::pi * (3 - std::sqrt(5.0)) * k;
    ball.emplace_back(1.3 * rho * std::cos(a), 1.3 * rho * std::sin(a), 1.3 * z);
  }
  // K5: a decagonal prism, radius 1.2, height 2.5, about z.
  Vertices prism;
  detail::add_ring(prism, 10, 1.2, -1.25, 2);
  detail::add_ring(prism, 10, 1.2, 1.25, 2);

  scene.obstacle_vertices = {box, cone, irregular, ball, prism};
  scene.obstacles = {detail::single(box), detail::single(cone), detail::single(irregular),
                     detail::single(ball), detail::single(prism)};
  scene.obstacle_poses = {
      detail::placed(Vec3<double>(-8.0, 5.0, 0.5), Vec3<double>(0, 0, 1), 0.4),
      detail::placed(Vec3<double>(-3.5, -3.6, -0.5), Vec3<double>(1, 0, 0), 0.3),
      detail::placed(Vec3<double>(0.5, 1.4, 0.2), Vec3<double>(1, 1, 0), 0.6),
      detail::placed(Vec3<double>(4.5, -3.4, 1.0)),
      detail::placed(Vec3<double>(8.5, 2.2, 0.8), Vec3<double>(0, 1, 0), 0.2),
  };

  scene.translation_start = Vec3<double>(-12.0, -0.5, 0.0);
  scene.translation_end = Vec3<double>(12.0, 1.0, 0.6);
  scene.rotation_start = Eigen::Quaterniond::Identity();
  scene.rotation_end = Eigen::Quaterniond(
      Eigen::AngleAxisd(0.85 * std::numbers::pi, Vec3<double>(0.2, 0.4, 1).normalized()));
  return scene;
}

}  // namespace nearpoint::scenes
