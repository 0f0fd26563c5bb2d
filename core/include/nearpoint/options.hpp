// Query options. Every default lives here, once, with what it means physically.
#pragma once

#include <limits>

namespace nearpoint {

/// Which routine computes ν(co Y), the point of the current simplex nearest the origin.
enum class Subalgorithm : unsigned char {
  /// Johnson's distance subalgorithm (paper eq. 29–31) with the Backup Procedure (eq. 38) when it
  /// fails numerically. The paper's method, and the default.
  johnson,
};

/// The stopping tolerance ε of eq. (35), g(ν) ≤ ε·D(K)². The paper uses 100× the machine precision
/// (1e-9 on a machine with 1e-11). For doubles that is 2.2e-14: for metre-sized shapes the loop
/// stops once the duality gap is below ~1e-13 m², i.e. the distance is certified to ~1e-13 m when
/// the shapes are a metre apart (bound g/|ν|) and to ~3e-7 m when they touch (bound √g; polytopes
/// almost always end exactly, far below that bound).
template <class Scalar>
inline constexpr Scalar kDefaultEpsilon = Scalar(100) * std::numeric_limits<Scalar>::epsilon();

/// An upper limit on GJK iterations. Polytopes end in 3–6 iterations (paper, Section VII) and never
/// need more than a few dozen; smooth shapes converge geometrically and meet eq. (35) within ~40.
/// The cap only guards against pathological input: a capped run says so in its status.
inline constexpr int kDefaultMaxIterations = 256;

template <class Scalar>
struct DistanceOptions {
  /// ε of eq. (35). Smaller is more accurate until roundoff dominates; larger exits earlier for
  /// smooth shapes (polytopes end in finitely many steps either way).
  Scalar epsilon = kDefaultEpsilon<Scalar>;
  /// Iteration cap (see kDefaultMaxIterations).
  int max_iterations = kDefaultMaxIterations;
  /// Move the origin to the midpoint of the two centroids (eq. 34) so that inner products do not
  /// lose precision to large coordinates. Off only for studying its effect.
  bool origin_shift = true;
  /// Subalgorithm used for ν(co Y).
  Subalgorithm subalgorithm = Subalgorithm::johnson;
  /// Stop as soon as the shapes are proven farther apart than this (a certified lower bound from
  /// the support plane exceeds it): the answer is then "separated, distance > cutoff" and the
  /// result says `beyond_cutoff`. 0 turns a query into a yes/no intersection test.
  Scalar distance_cutoff = std::numeric_limits<Scalar>::infinity();

  // What to compute beyond the distance. Each is opt-in: a query pays only for what it asks.
  /// Near points on each shape and the unit normal (eq. 23–24).
  bool near_points = false;
  /// The lower bound d⁻ on the penetration depth when the shapes intersect (eq. 32–33).
  bool penetration_bound = false;
  /// The gradient of the distance with respect to both poses (Section II).
  bool gradient = false;
};

}  // namespace nearpoint
