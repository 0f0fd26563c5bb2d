// SPDX-License-Identifier: Apache-2.0
// Support adaptors: each concrete shape seen through what GJK needs (paper eq. 15–17).
// E. G. Gilbert, D. W. Johnson, S. S. Keerthi, "A Fast Procedure for Computing the Distance Between
// Complex Objects in Three-Dimensional Space", IEEE Journal of Robotics and Automation 4(2), 1988
// (equations as numbered there; docs/design.md has the paper by section).
// Section IX gives the support functions of general convex sets (ellipsoids, cylinders); here
// each is written for its shape about its centre.
//
// Every adaptor works relative to the shape's centre z̄ (eq. 34): `support` returns s(η) − z̄, so
// the engine never forms large coordinates. `vertex` returns a vertex by index for warm starts.
// These are templates used inside the hot loop: no virtual calls, no allocation.
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>

#include "nearpoint/shapes.hpp"

namespace nearpoint::detail {

/// Scales a direction so its largest component is ±1: support functions of smooth shapes square
/// the direction, and a tiny ν (1e-170) would underflow. Returns false for a zero (or NaN) vector.
template <class S>
inline bool normalise_direction(const Vec3<S>& d, Vec3<S>& out) {
  const S m = d.cwiseAbs().maxCoeff();
  if (!(m > 0) || !std::isfinite(m)) return false;  // NaN-safe on purpose: !(m > 0) catches NaN
  out = d / m;
  return true;
}

/// 2^exponent as a compile-time constant.
template <class S>
constexpr S power_of_two(int exponent) {
  S p = 1;
  for (; exponent > 0; --exponent) p *= 2;
  for (; exponent < 0; ++exponent) p /= 2;
  return p;
}

/// |v|, not lost to the squares' under- or overflow. An extent enters D(K) (eq. 37) and the
/// compound's bounding spheres, both of which must not be below the truth: a float box of
/// half-extents 3.6e-32 had |h|² = 0, its compound piece a bounding sphere of its radius alone, and
/// the piece that touched the other object was pruned (found by fuzz_engine). The plain norm is
/// kept where its squares are normal numbers, bit for bit as before.
template <class S>
inline S extent_norm(const Vec3<S>& v) {
  // 2^±(half the exponent range − 10): the squares of such norms are normal numbers.
  constexpr int half_range = std::numeric_limits<S>::max_exponent / 2 - 10;
  constexpr S tiny = power_of_two<S>(-half_range), huge = power_of_two<S>(half_range);
  const S n = v.norm();
  if (n >= tiny && n <= huge) [[likely]]
    return n;
  return v.stableNorm();
}

/// The two support indices of a PairScan, returned in registers.
struct IndexPair {
  std::size_t a, b;
};

/// Both support indices of K = A − B in one call: s_A(η) and s_B(η_B) by eq. (17), each exactly
/// what Polytope::support_index(direction, hint) gives. When both polytopes scan, the two argmax
/// chains run interleaved in one loop; when both climb their hulls, the two climbs step in turn.
/// Their latencies then overlap instead of adding up: GJK's loop is one dependency chain
/// (support → ν → support), and two searches one after the other were a fixed part of every
/// iteration (measured: 5–9% of a query on the paper set, 15% at p99). Defined next to the
/// single-polytope searches in shapes.cpp.
struct PairScan {
  /// Directions by component, so that they travel in registers rather than through memory (the
  /// call is on GJK's critical path). One indirect call, straight into the build of the search
  /// this CPU runs (AVX2 or the baseline): a dispatching function in between cost a second call
  /// and return per support call (measured: about 2% of a query on the paper set).
  template <class S>
  [[gnu::always_inline]] static IndexPair support_indices(const Polytope<S>& a, S ax, S ay, S az,
                                                          std::int32_t hint_a, const Polytope<S>& b,
                                                          S bx, S by, S bz, std::int32_t hint_b) {
    return chosen<S>.load(std::memory_order_relaxed)(a, ax, ay, az, hint_a, b, bx, by, bz, hint_b);
  }

 private:
  template <class S>
  using Search = IndexPair (*)(const Polytope<S>&, S, S, S, std::int32_t, const Polytope<S>&, S, S,
                               S, std::int32_t);
  /// The search this CPU runs. Constant-initialised to `resolve`, which makes the choice on the
  /// first call and stores it (every thread stores the same value): no static-initialisation
  /// order to depend on, and a relaxed load is a plain load.
  template <class S>
  static std::atomic<Search<S>> chosen;
  template <class S>
  static IndexPair resolve(const Polytope<S>& a, S ax, S ay, S az, std::int32_t hint_a,
                           const Polytope<S>& b, S bx, S by, S bz, std::int32_t hint_b);
  /// The search: both climbs, or both scans interleaved. Inlined into its two builds below.
  template <class S>
  static IndexPair search(const Polytope<S>& a, S ax, S ay, S az, std::int32_t hint_a,
                          const Polytope<S>& b, S bx, S by, S bz, std::int32_t hint_b);
  /// The search compiled for the baseline and (x86) for AVX2.
  template <class S>
  static IndexPair search_baseline(const Polytope<S>& a, S ax, S ay, S az, std::int32_t hint_a,
                                   const Polytope<S>& b, S bx, S by, S bz, std::int32_t hint_b);
  template <class S>
  static IndexPair search_avx2(const Polytope<S>& a, S ax, S ay, S az, std::int32_t hint_a,
                               const Polytope<S>& b, S bx, S by, S bz, std::int32_t hint_b);
  template <class S>
  static IndexPair climb_indices(const Polytope<S>& a, const Vec3<S>& direction_a,
                                 std::int32_t hint_a, const Polytope<S>& b,
                                 const Vec3<S>& direction_b, std::int32_t hint_b);
};
// Defined and instantiated in shapes.cpp: declared here so that code using the search does not
// instantiate the variable itself (clang: -Wundefined-var-template).
extern template std::atomic<PairScan::Search<float>> PairScan::chosen<float>;
extern template std::atomic<PairScan::Search<double>> PairScan::chosen<double>;

template <class G, class S>
struct Support;

template <class S>
struct Support<Point, S> {
  const Point& shape;
  Vec3<S> center() const { return Vec3<S>::Zero(); }
  Vec3<S> interior() const { return Vec3<S>::Zero(); }
  S extent() const { return 0; }
  Vec3<S> support(const Vec3<S>&, std::int32_t& index) const {
    index = 0;
    return Vec3<S>::Zero();
  }
  bool vertex(std::int32_t index, Vec3<S>& out) const {
    out.setZero();
    return index == 0;
  }
};

template <class S>
struct Support<Segment<S>, S> {
  const Segment<S>& shape;
  // Each end is given relative to the centre as its own difference, a − c and b − c, each rounded
  // once relative to the segment's length. The centre's own rounding then moves nothing: it is a
  // reference point, placed by the pose like any centre. (The half-difference ±(b − a)/2 about a
  // rounded centre was off by half an ulp of the centre, which for a segment modelled far from its
  // local origin is far more than its length.) Halves first, so that the sum cannot overflow (an
  // outside fuzzer's segment at 1.8e308 had D(K) = inf).
  Vec3<S> center() const { return S(0.5) * shape.a + S(0.5) * shape.b; }
  // A point of the segment about its rounded centre: the centre itself may be off the segment by
  // half an ulp of its coordinates (float ends near 8e6 had a centre 0.5 off its line, and the
  // cold start's centroids' point, taken as a point of K, gave 0.55 for 0.79 with bound 3e-6;
  // found by fuzz_engine). The midpoint of the stored ends is off by ulps of the length only.
  Vec3<S> interior() const { return S(0.5) * end(0) + S(0.5) * end(1); }
  Vec3<S> end(std::int32_t index) const { return (index == 1 ? shape.b : shape.a) - center(); }
  S extent() const { return std::max(extent_norm(end(0)), extent_norm(end(1))); }
  Vec3<S> support(const Vec3<S>& d, std::int32_t& index) const {
    const Vec3<S> a = end(0), b = end(1);
    // Ties and NaN choose a (index 0): any point of the segment is a valid support then.
    if ((b - a).dot(d) > 0) {
      index = 1;
      return b;
    }
    index = 0;
    return a;
  }
  bool vertex(std::int32_t index, Vec3<S>& out) const {
    if (index != 0 && index != 1) return false;
    out = end(index);
    return true;
  }
};

template <class S>
struct Support<Box<S>, S> {
  const Box<S>& shape;
  Vec3<S> center() const { return Vec3<S>::Zero(); }
  Vec3<S> interior() const { return Vec3<S>::Zero(); }
  S extent() const { return extent_norm(shape.half_extents); }
  Vec3<S> support(const Vec3<S>& d, std::int32_t& index) const {
    Vec3<S> p;
    index = 0;
    for (int k = 0; k < 3; ++k) {
      const bool positive = d[k] > 0;  // NaN and 0 choose the negative side: still a support point
      p[k] = positive ? shape.half_extents[k] : -shape.half_extents[k];
      index |= std::int32_t(positive) << k;
    }
    return p;
  }
  bool vertex(std::int32_t index, Vec3<S>& out) const {
    if (index < 0 || index > 7) return false;
    for (int k = 0; k < 3; ++k)
      out[k] = (index >> k) & 1 ? shape.half_extents[k] : -shape.half_extents[k];
    return true;
  }
};

template <class S>
struct Support<Polytope<S>, S> {
  const Polytope<S>& shape;
  // Where a climbing polytope's next support query starts: the last answer (or the warm-start
  // vertex). GJK's directions turn a little per iteration, so the answer is usually a step away.
  mutable std::int32_t hint = -1;
  Vec3<S> center() const { return shape.centroid(); }
  Vec3<S> interior() const { return shape.centered_interior(); }
  S extent() const { return shape.extent(); }
  // eq. (17): an enumeration of inner products (vectorised), or a climb over the hull's edges
  // (see Polytope::support_index).
  Vec3<S> support(const Vec3<S>& d, std::int32_t& index) const {
    const std::size_t best = shape.support_index(d, hint);
    index = static_cast<std::int32_t>(best);
    hint = index;
    return shape.centered_vertex(best);
  }
  bool vertex(std::int32_t index, Vec3<S>& out) const {
    if (index < 0 || std::size_t(index) >= shape.size()) return false;
    out = shape.centered_vertex(std::size_t(index));
    hint = index;
    return true;
  }
};

template <class S>
struct Support<Cylinder<S>, S> {
  const Cylinder<S>& shape;
  Vec3<S> center() const { return Vec3<S>::Zero(); }
  Vec3<S> interior() const { return Vec3<S>::Zero(); }
  S extent() const { return std::hypot(shape.radius, shape.half_height); }
  Vec3<S> support(const Vec3<S>& direction, std::int32_t& index) const {
    index = -1;
    Vec3<S> d;
    if (!normalise_direction(direction, d)) return Vec3<S>(0, 0, -shape.half_height);
    const S radial = std::hypot(d.x(), d.y());
    Vec3<S> p(0, 0, d.z() > 0 ? shape.half_height : -shape.half_height);
    if (radial > 0) {
      p.x() = shape.radius * d.x() / radial;
      p.y() = shape.radius * d.y() / radial;
    }
    return p;
  }
  bool vertex(std::int32_t, Vec3<S>&) const { return false; }
};

template <class S>
struct Support<Cone<S>, S> {
  const Cone<S>& shape;
  Vec3<S> center() const { return Vec3<S>::Zero(); }
  Vec3<S> interior() const { return Vec3<S>::Zero(); }
  S extent() const { return std::hypot(shape.radius, shape.half_height); }
  Vec3<S> support(const Vec3<S>& direction, std::int32_t& index) const {
    index = -1;
    const Vec3<S> apex(0, 0, shape.half_height);
    Vec3<S> d;
    if (!normalise_direction(direction, d)) return apex;
    const S radial = std::hypot(d.x(), d.y());
    Vec3<S> rim(0, 0, -shape.half_height);
    if (radial > 0) {
      rim.x() = shape.radius * d.x() / radial;
      rim.y() = shape.radius * d.y() / radial;
    }
    return rim.dot(d) > apex.dot(d) ? rim : apex;
  }
  bool vertex(std::int32_t, Vec3<S>&) const { return false; }
};

template <class S>
struct Support<Ellipsoid<S>, S> {
  const Ellipsoid<S>& shape;
  Vec3<S> center() const { return Vec3<S>::Zero(); }
  Vec3<S> interior() const { return Vec3<S>::Zero(); }
  S extent() const { return shape.radii.maxCoeff(); }
  // s(η) = D²η / |Dη| with D = diag(radii): the point where the outward normal D⁻²x is along η.
  Vec3<S> support(const Vec3<S>& direction, std::int32_t& index) const {
    index = -1;
    Vec3<S> d;
    if (!normalise_direction(direction, d)) return Vec3<S>(shape.radii.x(), 0, 0);
    const Vec3<S> scaled = shape.radii.cwiseProduct(d);
    const S norm = scaled.norm();
    if (!(norm > 0)) return Vec3<S>::Zero();  // all radii zero: the ellipsoid is a point
    return shape.radii.cwiseProduct(scaled) / norm;
  }
  bool vertex(std::int32_t, Vec3<S>&) const { return false; }
};

/// A polytope seen at scale 2^k (distance.cpp rescales K by a power of two when D(K) is far from 1,
/// so that the loop's squares and products neither under- nor overflow). The vertices stay where
/// they are; every coordinate handed to the loop is multiplied by 2^k, which is exact. Not used on
/// the normal path, which keeps its fused pair scan.
template <class S>
struct ScaledPolytope {
  const Polytope<S>* polytope;
  int exponent;            // k
  int direction_exponent;  // k clamped to what a direction can carry (see Support::support)
};

template <class S>
struct Support<ScaledPolytope<S>, S> {
  const ScaledPolytope<S>& shape;
  mutable std::int32_t hint = -1;
  Vec3<S> scaled(const Vec3<S>& v) const {
    return Vec3<S>(std::ldexp(v.x(), shape.exponent), std::ldexp(v.y(), shape.exponent),
                   std::ldexp(v.z(), shape.exponent));
  }
  Vec3<S> center() const { return scaled(shape.polytope->centroid()); }
  Vec3<S> interior() const { return scaled(shape.polytope->centered_interior()); }
  S extent() const { return std::ldexp(shape.polytope->extent(), shape.exponent); }
  Vec3<S> support(const Vec3<S>& direction, std::int32_t& index) const {
    // The scan's products v·η are formed with the unscaled vertices: η is brought to the vertices'
    // scale (largest component 2^k, as far as representable) so that they stay normal numbers
    // whatever the polytope's size. A positive factor does not change the maximiser.
    Vec3<S> d = direction;
    if (normalise_direction(direction, d))
      d = Vec3<S>(std::ldexp(d.x(), shape.direction_exponent),
                  std::ldexp(d.y(), shape.direction_exponent),
                  std::ldexp(d.z(), shape.direction_exponent));
    const std::size_t best = shape.polytope->support_index(d, hint);
    index = static_cast<std::int32_t>(best);
    hint = index;
    return scaled(shape.polytope->centered_vertex(best));
  }
  bool vertex(std::int32_t index, Vec3<S>& out) const {
    if (index < 0 || std::size_t(index) >= shape.polytope->size()) return false;
    out = scaled(shape.polytope->centered_vertex(std::size_t(index)));
    hint = index;
    return true;
  }
};

template <class G, class S>
Support<G, S> make_support(const G& g) {
  return Support<G, S>{g};
}

}  // namespace nearpoint::detail
