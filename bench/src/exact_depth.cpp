// SPDX-License-Identifier: Apache-2.0
#include "exact_depth.hpp"

#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/boost/graph/helpers.h>
#include <CGAL/convex_hull_3.h>

#include <array>
#include <cmath>

namespace nearpoint::bench {

using Kernel = CGAL::Exact_predicates_exact_constructions_kernel;
using FT = Kernel::FT;
using Point3 = Kernel::Point_3;

struct ExactDepth::Exact {
  FT depth2 = 0;  ///< the exact squared depth (0 when the origin is not strictly inside K)
};

ExactDepth::ExactDepth(const std::vector<Vec3<double>>& a, const Pose<double>& pose_a,
                       const std::vector<Vec3<double>>& b, const Pose<double>& pose_b)
    : exact_(std::make_unique<Exact>()) {
  // R·v + t with the pose's double entries, exactly (the input the implementations are given).
  const auto place = [](const Pose<double>& p, const Vec3<double>& v) {
    std::array<FT, 3> x;
    for (int i = 0; i < 3; ++i) {
      x[std::size_t(i)] = FT(p.translation[i]);
      for (int j = 0; j < 3; ++j) x[std::size_t(i)] += FT(p.rotation(i, j)) * FT(v[j]);
      x[std::size_t(i)].exact();  // keep the lazy DAG shallow: every later use reads the value
    }
    return x;
  };
  std::vector<std::array<FT, 3>> pb;
  pb.reserve(b.size());
  for (const Vec3<double>& v : b) pb.push_back(place(pose_b, v));
  std::vector<Point3> points;
  points.reserve(a.size() * b.size());
  for (const Vec3<double>& v : a) {
    const std::array<FT, 3> x = place(pose_a, v);
    for (const std::array<FT, 3>& y : pb)
      points.emplace_back(x[0] - y[0], x[1] - y[1], x[2] - y[2]);
  }
  CGAL::Surface_mesh<Point3> hull;
  CGAL::convex_hull_3(points.begin(), points.end(), hull);
  // A flat or needle-thin K has no interior (CGAL then returns an open, flat mesh): depth 0.
  if (hull.number_of_faces() < 4 || !CGAL::is_closed(hull)) return;
  const Point3 origin(0, 0, 0);
  bool first = true;
  FT best = 0;
  for (auto f : hull.faces()) {
    std::vector<Point3> corner;
    for (auto v : CGAL::vertices_around_face(hull.halfedge(f), hull))
      corner.push_back(hull.point(v));
    const Kernel::Plane_3 plane(corner[0], corner[1], corner[2]);
    if (plane.oriented_side(origin) != CGAL::ON_NEGATIVE_SIDE) return;  // outside or on: depth 0
    const FT d2 = CGAL::squared_distance(origin, plane);
    if (first || d2 < best) best = d2;
    first = false;
  }
  best.exact();
  exact_->depth2 = best;
  intersecting_ = best > 0;
  depth_ = std::sqrt(CGAL::to_double(best));
}

ExactDepth::~ExactDepth() = default;
ExactDepth::ExactDepth(ExactDepth&&) noexcept = default;
ExactDepth& ExactDepth::operator=(ExactDepth&&) noexcept = default;

bool ExactDepth::below(double x) const {
  if (!(x >= 0)) return x < 0;  // negative: below; NaN: neither
  return FT(x) * FT(x) < exact_->depth2;
}

bool ExactDepth::above(double x) const {
  if (!(x >= 0)) return false;
  return FT(x) * FT(x) > exact_->depth2;
}

double ExactDepth::error(double x) const {
  if (std::isnan(x)) return x;
  if (x < 0) return depth_ - x;  // a negative depth estimate: the error is at least this
  const double sum = x + depth_;
  if (sum == 0) return 0;
  const FT difference = FT(x) * FT(x) - exact_->depth2;
  return std::abs(CGAL::to_double(difference)) / sum;
}

}  // namespace nearpoint::bench
