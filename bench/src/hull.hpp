// Convex hulls (CGAL, exact predicates) for the peers that need faces: fcl::Convex takes a vertex
// list plus a face list, and its support function walks vertex adjacency on large hulls.
#pragma once

#include <span>
#include <vector>

#include "nearpoint/pose.hpp"

namespace nearpoint::bench {

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
/// inputs (needles, slivers, 1e-12-thin tetrahedra) get their true combinatorial hull.
Hull convex_hull(std::span<const Vec3<double>> points);

}  // namespace nearpoint::bench
