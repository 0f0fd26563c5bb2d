// SPDX-License-Identifier: Apache-2.0
// Convex hulls (CGAL, exact predicates): the hull's vertices and faces of a point set, and a
// Polytope built from them that climbs its edges for support queries (see Polytope's constructor
// with faces). A separate library (nearpoint::hull) so that the engine itself needs Eigen only.
#pragma once

#include <span>
#include <vector>

#include "nearpoint/pose.hpp"
#include "nearpoint/shapes.hpp"

namespace nearpoint {

struct Hull {
  /// Affine dimension of the point set: 0 a point, 1 a segment, 2 a flat polygon, 3 a solid.
  int dimension = -1;
  /// The extreme points (the hull's vertices), each once.
  std::vector<Vec3<double>> vertices;
  /// For each hull vertex, the index of its first occurrence in the input.
  std::vector<int> input_index;
  /// Faces as vertex cycles (indices into `vertices`), counter-clockwise seen from outside. A flat
  /// polygon is given as its two sides; a segment or a point has no faces.
  std::vector<std::vector<int>> faces;
};

/// The convex hull of `points` (non-empty, finite). Predicates are exact, so near-degenerate
/// inputs (needles, slivers, 1e-12-thin tetrahedra, flat sets with sub-normal offsets) get their
/// true combinatorial hull. The result is canonical, so the same input gives the same hull bit for
/// bit in any process state: vertices in the order of their first occurrence in the input (each
/// with that occurrence's coordinates), each face starting at its smallest vertex index, faces in
/// lexicographic order.
Hull convex_hull(std::span<const Vec3<double>> points);

/// The polytope co(points), reduced to the hull's vertices and, for a solid hull, given its faces
/// so that large ones climb instead of scanning. Vertex indices in results refer to the hull's
/// vertices (`convex_hull(points).input_index` maps them back). A flat, linear or single-point set
/// gives a scanning polytope of its extreme points. Empty or non-finite input gives an invalid
/// polytope (see Polytope::invalid_reason).
Polytope<double> hull_polytope(std::span<const Vec3<double>> points);

}  // namespace nearpoint
