// SPDX-License-Identifier: Apache-2.0
// The convex shapes the engine knows, each described by what GJK needs from it: a support function
// (paper eq. 15–17), a centre (the z̄ of eq. 34) and an extent about that centre (a term of eq. 37).
// Every shape may carry a spherical-extension radius r (eq. 5–8): a sphere is a point with a
// radius, a capsule a segment with a radius, a rounded box a box with a radius.
#pragma once

#include <cmath>
#include <cstdint>
#include <span>
#include <variant>
#include <vector>

#include "nearpoint/pose.hpp"

namespace nearpoint {

namespace detail {
struct PairScan;  // the engine's scan of two polytopes at once (core/src/support.hpp)
}  // namespace detail

/// A single point at the local origin. With a radius it is a sphere.
struct Point {};

/// The segment from `a` to `b` (local frame). With a radius it is a capsule.
template <class Scalar>
struct Segment {
  Vec3<Scalar> a = Vec3<Scalar>::Zero();
  Vec3<Scalar> b = Vec3<Scalar>::Zero();
};

/// The axis-aligned box [-h, h] (local frame), h = `half_extents`. Its 8 corners are its vertices;
/// vertex i has coordinate k positive when bit k of i is set.
template <class Scalar>
struct Box {
  Vec3<Scalar> half_extents = Vec3<Scalar>::Ones();
};

/// The solid cylinder about the local z axis, radius `radius`, from z = -half_height to
/// +half_height.
template <class Scalar>
struct Cylinder {
  Scalar radius = 1;
  Scalar half_height = 1;
};

/// The solid cone about the local z axis: base disc of radius `radius` at z = -half_height, apex at
/// z = +half_height.
template <class Scalar>
struct Cone {
  Scalar radius = 1;
  Scalar half_height = 1;
};

/// The solid ellipsoid x²/rx² + y²/ry² + z²/rz² ≤ 1 (local frame), `radii` = (rx, ry, rz).
template <class Scalar>
struct Ellipsoid {
  Vec3<Scalar> radii = Vec3<Scalar>::Ones();
};

/// How much of a faces list Polytope's constructor checks.
enum class FacesCheck : unsigned char {
  /// The surface's topology and its geometry (planar faces, convex edges, to within the rounding
  /// of the stored vertices): for faces from a caller.
  full,
  /// The topology only: for faces computed with exact predicates from exactly these vertices
  /// (`nearpoint::convex_hull`), whose convexity is proved; a floating-point re-check could
  /// only refuse a valid hull.
  topology,
};

/// The convex hull of a vertex list (the paper's co Z, eq. 19). Vertices need not be on the hull:
/// interior points, duplicates and coplanar sets are fine and cost only their scan time.
///
/// Construction does the one-time work the queries rely on: the vertex centroid z̄ (eq. 34), the
/// extent max |z − z̄| (eq. 37), and a copy of the vertices relative to z̄ so that coordinates far
/// from the origin do not eat the precision of every support evaluation. It also validates the
/// input: `invalid_reason()` is non-null for an empty list or a non-finite coordinate, and a query
/// on such a polytope returns `Status::invalid_input` instead of computing anything.
template <class Scalar>
class Polytope {
 public:
  Polytope() = default;
  explicit Polytope(std::span<const Vec3<Scalar>> vertices);
  explicit Polytope(const std::vector<Vec3<Scalar>>& vertices)
      : Polytope(std::span<const Vec3<Scalar>>(vertices.data(), vertices.size())) {}

  /// A polytope that also knows the faces of its hull, so that support queries climb from vertex
  /// to better neighbour over the hull's edges (a few dozen inner products on a hull of thousands
  /// of vertices) instead of scanning every vertex. `vertices` must be exactly the hull's
  /// vertices and `faces` its faces, each a cycle of vertex indices counter-clockwise seen from
  /// outside (what `nearpoint::convex_hull` in nearpoint/hull.hpp returns). The faces are checked:
  /// indices in range, every vertex on a face, a closed oriented surface of sphere topology
  /// (V − E + F = 2), planar faces and convex edges to within the rounding of the centred vertices.
  /// A set that fails any check leaves the polytope invalid with the reason; `FacesCheck::topology`
  /// skips the geometric checks for faces proved convex by exact predicates. Below
  /// `kHillClimbThreshold` vertices the faces are checked but the scan is used: it is faster there.
  Polytope(std::span<const Vec3<Scalar>> vertices, std::span<const std::vector<int>> faces,
           FacesCheck check = FacesCheck::full);

  /// From this many vertices on, a polytope built with faces climbs instead of scanning (the
  /// crossover measured by bench/ experiment `large`).
  static constexpr std::size_t kHillClimbThreshold = 64;

  /// Number of vertices as given (duplicates included).
  std::size_t size() const { return size_; }
  /// Vertex `index` in the local frame, as given.
  Vec3<Scalar> vertex(std::size_t index) const { return centered_vertex(index) + centroid_; }
  /// Vertex `index` relative to the centroid.
  Vec3<Scalar> centered_vertex(std::size_t index) const {
    return Vec3<Scalar>(xs_[index], ys_[index], zs_[index]);
  }
  /// The index of a vertex maximising v·direction (eq. 17); never selects on a NaN product. A
  /// vectorised scan over the structure-of-arrays storage (the first maximiser on ties), or, for
  /// a large polytope built with its faces, a climb over the hull's edges that starts from the
  /// better of `hint` (a vertex index, e.g. the previous answer; -1 for none) and a few
  /// precomputed extreme vertices.
  std::size_t support_index(const Vec3<Scalar>& direction, std::int32_t hint = -1) const {
    if (neighbor_begin_.empty())
      return scan_(xs_.data(), ys_.data(), zs_.data(), xs_.size(), direction.x(), direction.y(),
                   direction.z());
    return climb(direction, hint);
  }
  /// True when support queries climb the hull's edges (built with faces, at least
  /// kHillClimbThreshold vertices).
  bool climbs() const { return !neighbor_begin_.empty(); }
  /// The vertex mean z̄ of eq. (34), local frame.
  const Vec3<Scalar>& centroid() const { return centroid_; }
  /// A point of the hull relative to z̄, to within ulps of extent(): the mean of the centred
  /// vertices. z̄ itself (0 here) is only within ulps of |z̄| of the hull, which for a thin shape
  /// modelled far from its origin can be outside it.
  const Vec3<Scalar>& centered_interior() const { return centered_interior_; }
  /// max |z − z̄| over the vertices: the shape's term in the D(K) bound of eq. (37).
  Scalar extent() const { return extent_; }
  /// nullptr when the polytope is usable, else why it is not.
  const char* invalid_reason() const { return invalid_reason_; }

 private:
  friend struct detail::PairScan;
  const char* check_faces(std::span<const std::vector<int>> faces, FacesCheck check) const;
  std::size_t climb(const Vec3<Scalar>& direction, std::int32_t hint) const;

  // The vectorised scan compiled for this CPU (AVX2 or the baseline), chosen once per process and
  // called through this pointer so that a support call costs one call, not a dispatch chain.
  using Scan = std::size_t (*)(const Scalar*, const Scalar*, const Scalar*, std::size_t, Scalar,
                               Scalar, Scalar);
  static Scan best_scan();
  Scan scan_ = best_scan();

  // Coordinates relative to z̄, one array per axis so the support scan runs four (or eight)
  // vertices per instruction; padded to whole blocks of two vectors (8 doubles, 16 floats) with
  // copies of vertex 0, which can never win a tie against vertex 0 itself.
  std::vector<Scalar> xs_, ys_, zs_;
  // The hull's edge graph in compressed rows (vertex i's neighbours are
  // neighbors_[neighbor_begin_[i] .. neighbor_begin_[i + 1])), empty when the polytope scans;
  // and the extreme vertices along 728 fixed integer directions, where climbs start, kept by
  // direction (see seed_code in shapes.cpp).
  std::vector<std::uint32_t> neighbor_begin_, neighbors_;
  std::vector<std::uint32_t> seeds_;
  std::size_t size_ = 0;
  Vec3<Scalar> centroid_ = Vec3<Scalar>::Zero();
  Vec3<Scalar> centered_interior_ = Vec3<Scalar>::Zero();
  Scalar extent_ = 0;
  const char* invalid_reason_ = "polytope has no vertices";
};

/// Any of the shapes above, plus its spherical-extension radius (eq. 5–8). This is the type-erased
/// form used at the edges (files, the wire, the geometry store); the engine dispatches once per
/// query and then runs a loop specialised for the two concrete shape types.
template <class Scalar>
struct Shape {
  using Geometry = std::variant<Point, Segment<Scalar>, Box<Scalar>, Polytope<Scalar>,
                                Cylinder<Scalar>, Cone<Scalar>, Ellipsoid<Scalar>>;
  Geometry geometry = Point{};
  /// Spherical-extension radius r ≥ 0: the shape is the set of points within r of its core.
  Scalar radius = 0;

  Shape() = default;
  template <class G>
  Shape(G g, Scalar r = 0) : geometry(std::move(g)), radius(r) {}

  static Shape sphere(Scalar r) { return Shape(Point{}, r); }
  static Shape capsule(const Vec3<Scalar>& a, const Vec3<Scalar>& b, Scalar r) {
    return Shape(Segment<Scalar>{a, b}, r);
  }
};

/// Why a shape cannot be used (a non-finite or negative parameter, an empty polytope), or nullptr
/// when it can. O(1): a polytope's vertices were checked when it was built.
template <class Scalar>
const char* invalid_reason(const Shape<Scalar>& shape);

/// The centre z̄ (local frame) and the extent max |z − z̄| of a shape's core (radius excluded).
template <class Scalar>
Vec3<Scalar> core_center(const Shape<Scalar>& shape);
template <class Scalar>
Scalar core_extent(const Shape<Scalar>& shape);

/// The support point s(η) of the shape's core in its local frame (eq. 16), with `index` set to the
/// vertex index for shapes with vertices (polytope, box, segment, point) and -1 otherwise.
template <class Scalar>
Vec3<Scalar> support(const Shape<Scalar>& shape, const Vec3<Scalar>& direction, int& index);

}  // namespace nearpoint
