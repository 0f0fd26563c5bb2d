// SPDX-License-Identifier: Apache-2.0
#include "nearpoint/hull.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/convex_hull_2.h>
#include <CGAL/convex_hull_3.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>

namespace nearpoint {
namespace {

// Exact predicates, double constructions: the hull only selects input points (no new point is
// constructed), so it is exact for double input.
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using HullPoint = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<HullPoint>;

// The canonical form of a hull, whatever order CGAL produced it in: vertices in the order of their
// first occurrence in the input, each face rotated to start at its smallest vertex (its
// orientation kept), faces in lexicographic order. CGAL's convex_hull_3 emits vertices and faces
// in an order that follows the addresses of its internal nodes, i.e. the heap's state, so without
// this the same input gave a different vertex order, support ties broken differently and answers
// moving in the last bit from run to run.
void canonicalize(Hull& hull) {
  const std::size_t n = hull.vertices.size();
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  // First input indices are distinct (equal points share theirs, and a hull holds each once).
  std::sort(order.begin(), order.end(), [&](int x, int y) {
    return hull.input_index[std::size_t(x)] < hull.input_index[std::size_t(y)];
  });
  std::vector<int> label(n);
  std::vector<Vec3<double>> vertices(n);
  std::vector<int> input_index(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t old = std::size_t(order[i]);
    label[old] = int(i);
    vertices[i] = hull.vertices[old];
    input_index[i] = hull.input_index[old];
  }
  hull.vertices = std::move(vertices);
  hull.input_index = std::move(input_index);
  for (std::vector<int>& face : hull.faces) {
    for (int& v : face) v = label[std::size_t(v)];
    std::rotate(face.begin(), std::min_element(face.begin(), face.end()), face.end());
  }
  std::sort(hull.faces.begin(), hull.faces.end());
}

Hull hull_in_cgal_order(std::span<const Vec3<double>> input) {
  Hull hull;
  if (input.empty()) return hull;
  std::vector<HullPoint> points;
  points.reserve(input.size());
  std::map<HullPoint, int> first_index;
  for (std::size_t i = 0; i < input.size(); ++i) {
    points.emplace_back(input[i].x(), input[i].y(), input[i].z());
    first_index.emplace(points.back(), int(i));
  }
  // The vertex's coordinates from its first occurrence in the input, not from CGAL's copy: points
  // that compare equal (0.0 and -0.0) may differ in their bits, and CGAL keeps either.
  auto add_vertex = [&](const HullPoint& p) {
    const int i = first_index.at(p);
    hull.vertices.push_back(input[std::size_t(i)]);
    hull.input_index.push_back(i);
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
    // A flat polygon: drop one coordinate. The projection along axis k is a bijection of the
    // plane onto a coordinate plane exactly when the plane's normal has a non-zero k component,
    // i.e. when the projections of p0, p1, p2 are not collinear: decided by the exact 2-D
    // predicate, not by the double cross product, whose components underflow to zero for offsets
    // such as 1e-319 (then the set was projected onto a line and lost its extreme points). The
    // 2-D hull of the projected points (exact predicates again) is then the projection of the
    // polygon. Among the valid axes the largest normal component is preferred (any is exact).
    const Kernel::Vector_3 normal = CGAL::cross_product(*p1 - p0, *p2 - p0);
    std::array<int, 3> axes = {0, 1, 2};
    std::stable_sort(axes.begin(), axes.end(),
                     [&](int x, int y) { return std::abs(normal[x]) > std::abs(normal[y]); });
    auto project = [](const HullPoint& p, int drop) {
      return Kernel::Point_2(p[(drop + 1) % 3], p[(drop + 2) % 3]);
    };
    const int drop = *std::find_if(axes.begin(), axes.end(), [&](int k) {
      return !CGAL::collinear(project(p0, k), project(*p1, k), project(*p2, k));
    });
    std::map<Kernel::Point_2, int> by_projection;
    std::vector<Kernel::Point_2> projected;
    for (std::size_t i = 0; i < points.size(); ++i) {
      projected.push_back(project(points[i], drop));
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

}  // namespace

Hull convex_hull(std::span<const Vec3<double>> input) {
  Hull hull = hull_in_cgal_order(input);
  canonicalize(hull);
  return hull;
}

Polytope<double> hull_polytope(std::span<const Vec3<double>> points) {
  for (const Vec3<double>& p : points)
    if (!p.allFinite()) return Polytope<double>(points);  // invalid, with the reason
  if (points.empty()) return Polytope<double>(points);
  const Hull hull = convex_hull(points);
  if (hull.dimension < 3) return Polytope<double>(hull.vertices);
  // The faces come from exact predicates on exactly these vertices: their convexity is proved,
  // and a floating-point re-check could only refuse a valid hull.
  return Polytope<double>(hull.vertices, hull.faces, FacesCheck::topology);
}

}  // namespace nearpoint
