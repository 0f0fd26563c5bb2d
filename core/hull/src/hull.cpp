#include "nearpoint/hull.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/convex_hull_2.h>
#include <CGAL/convex_hull_3.h>

#include <algorithm>
#include <cmath>
#include <map>

namespace nearpoint {
namespace {

// Exact predicates, double constructions: the hull only selects input points (no new point is
// constructed), so it is exact for double input.
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using HullPoint = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<HullPoint>;

}  // namespace

Hull convex_hull(std::span<const Vec3<double>> input) {
  Hull hull;
  if (input.empty()) return hull;
  std::vector<HullPoint> points;
  points.reserve(input.size());
  std::map<HullPoint, int> first_index;
  for (std::size_t i = 0; i < input.size(); ++i) {
    points.emplace_back(input[i].x(), input[i].y(), input[i].z());
    first_index.emplace(points.back(), int(i));
  }
  auto add_vertex = [&](const HullPoint& p) {
    hull.vertices.emplace_back(p.x(), p.y(), p.z());
    hull.input_index.push_back(first_index.at(p));
    return int(hull.vertices.size()) - 1;
  };

  // The affine dimension, from exact predicates on witnesses p0, p1, p2, p3.
  const HullPoint& p0 = points[0];
  const auto p1 =
      std::find_if(points.begin(), points.end(), [&](const HullPoint& p) { return p != p0; });
  if (p1 == points.end()) {
    hull.dimension = 0;
    add_vertex(p0);
    return hull;
  }
  const auto p2 = std::find_if(points.begin(), points.end(),
                               [&](const HullPoint& p) { return !CGAL::collinear(p0, *p1, p); });
  if (p2 == points.end()) {
    // A segment: its two extreme points along p1 − p0 (lexicographic order is the same order
    // on a line, and exact).
    hull.dimension = 1;
    const auto [lo, hi] = std::minmax_element(points.begin(), points.end());
    add_vertex(*lo);
    add_vertex(*hi);
    return hull;
  }
  const auto p3 = std::find_if(points.begin(), points.end(), [&](const HullPoint& p) {
    return CGAL::orientation(p0, *p1, *p2, p) != CGAL::COPLANAR;
  });
  if (p3 == points.end()) {
    hull.dimension = 2;
    // A flat polygon: drop the coordinate along which the plane's normal is largest. That
    // projection is a bijection of the plane onto a coordinate plane, so the 2-D hull of the
    // projected points (exact predicates again) is the projection of the polygon.
    const Kernel::Vector_3 normal = CGAL::cross_product(*p1 - p0, *p2 - p0);
    int drop = 0;
    for (int k = 1; k < 3; ++k)
      if (std::abs(normal[k]) > std::abs(normal[drop])) drop = k;
    const int u = (drop + 1) % 3, w = (drop + 2) % 3;
    std::map<Kernel::Point_2, int> by_projection;
    std::vector<Kernel::Point_2> projected;
    for (std::size_t i = 0; i < points.size(); ++i) {
      projected.emplace_back(points[i][u], points[i][w]);
      by_projection.emplace(projected.back(), int(i));
    }
    std::vector<Kernel::Point_2> polygon;
    CGAL::convex_hull_2(projected.begin(), projected.end(), std::back_inserter(polygon));
    std::vector<int> face;
    for (const Kernel::Point_2& q : polygon)
      face.push_back(add_vertex(points[std::size_t(by_projection.at(q))]));
    hull.faces.push_back(face);
    std::reverse(face.begin(), face.end());
    hull.faces.push_back(face);
    return hull;
  }

  hull.dimension = 3;
  Mesh mesh;
  CGAL::convex_hull_3(points.begin(), points.end(), mesh);
  std::map<Mesh::Vertex_index, int> index;
  for (const Mesh::Vertex_index v : mesh.vertices()) index[v] = add_vertex(mesh.point(v));
  for (const Mesh::Face_index f : mesh.faces()) {
    std::vector<int> face;
    for (const Mesh::Vertex_index v : CGAL::vertices_around_face(mesh.halfedge(f), mesh))
      face.push_back(index.at(v));
    hull.faces.push_back(std::move(face));
  }
  return hull;
}

Polytope<double> hull_polytope(std::span<const Vec3<double>> points) {
  for (const Vec3<double>& p : points)
    if (!p.allFinite()) return Polytope<double>(points);  // invalid, with the reason
  if (points.empty()) return Polytope<double>(points);
  const Hull hull = convex_hull(points);
  if (hull.dimension < 3) return Polytope<double>(hull.vertices);
  return Polytope<double>(hull.vertices, hull.faces);
}

}  // namespace nearpoint
