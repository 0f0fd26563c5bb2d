// SPDX-License-Identifier: Apache-2.0
// The paper's Numerical Algorithm (Section VI, steps 1–6) on K = A − B, for two concrete shapes.
// E. G. Gilbert, D. W. Johnson, S. S. Keerthi, "A Fast Procedure for Computing the Distance Between
// Complex Objects in Three-Dimensional Space", IEEE Journal of Robotics and Automation 4(2), 1988
// (equations as numbered there; docs/design.md has the paper by section).
//
// Where it departs from the paper: ε defaults to machine precision squared rather than "100 ×
// machine error" (options.hpp); the loop keeps the best support-plane lower bound L of every
// iteration besides g (eq. 25), and ends on whichever certifies first; a cold start may add the
// centroids' point to V_0 (ColdStart::with_centroids); every roundoff allowance is a few ulps of
// one working magnitude (distance_roundoff); an "enclosed" origin is certified before it is
// answered (enclosure_certified); closed forms replace the loop for point and segment cores.
#pragma once

#include <algorithm>
#ifdef NEARPOINT_TRACE
#include <cstdio>
#define NEARPOINT_TRACE_PRINTF(...) std::fprintf(stderr, __VA_ARGS__)
#else
#define NEARPOINT_TRACE_PRINTF(...) ((void)0)
#endif
#include <cmath>
#include <limits>
#include <type_traits>
#include <utility>

#include "distance_internal.hpp"
#include "johnson.hpp"
#include "nearpoint/distance.hpp"
#include "signed_volumes.hpp"
#include "support.hpp"

namespace nearpoint::detail {

/// K = A − B seen from A's frame with the origin moved to the midpoint of the centroids (eq. 34).
/// A support point of K is y = a − b − δ, where a = s_A(η) − z̄_A and b = R·(s_B(−Rᵀη) − z̄_B) are
/// centred support points and δ = z̄_B − z̄_A is the centroid offset (B's centroid placed in A's
/// frame). Only δ carries the objects' relative placement, computed once per query, so a large
/// common offset of both poses never enters an inner product.
template <class S, class SA, class SB>
struct MinkowskiDifference {
  SA a;
  SB b;
  Mat3<S> rotation;      // B's frame → A's frame
  Vec3<S> offset;        // δ = R z̄_B + t − z̄_A
  Vec3<S> a_center;      // z̄_A (local frame of A)
  Vec3<S> b_center_rel;  // R z̄_B + t: B's centroid in A's frame (for the unshifted variant)
  bool origin_shift = true;

  // s_K(η) = s_A(η) − s_B(−η), eq. (21).
  void support(const Vec3<S>& eta, Vec3<S>& y, Vec3<S>& on_a, Vec3<S>& on_b, std::int32_t& ia,
               std::int32_t& ib) const {
    if constexpr (std::is_same_v<SA, Support<Polytope<S>, S>> &&
                  std::is_same_v<SB, Support<Polytope<S>, S>>) {
      // Both polytopes searched in one call (interleaved when alike).
      const Vec3<S> eta_b = -rotate_back(rotation, eta);
      const IndexPair index =
          PairScan::support_indices(a.shape, eta.x(), eta.y(), eta.z(), a.hint, b.shape, eta_b.x(),
                                    eta_b.y(), eta_b.z(), b.hint);
      ia = a.hint = std::int32_t(index.a);
      ib = b.hint = std::int32_t(index.b);
      // y from the values in registers, not read back from on_a/on_b: rotate's three scalar
      // stores read back as a 16-byte load would stall store forwarding once per support call.
      const Vec3<S> point_a = a.shape.centered_vertex(index.a);
      const Vec3<S> point_b = rotate(rotation, b.shape.centered_vertex(index.b));
      y = difference(point_a, point_b);
      on_a = point_a;
      on_b = point_b;
    } else {
      on_a = a.support(eta, ia);
      on_b = rotate(rotation, b.support(-rotate_back(rotation, eta), ib));
      y = difference(on_a, on_b);
    }
  }

  // Per component, always inline: GCC left Eigen's expression out of line as a call where the
  // warm start forms its points (measured: 8% of a warm compound query).
  [[gnu::always_inline]] Vec3<S> difference(const Vec3<S>& on_a, const Vec3<S>& on_b) const {
    if (origin_shift)
      return Vec3<S>(on_a.x() - on_b.x() - offset.x(), on_a.y() - on_b.y() - offset.y(),
                     on_a.z() - on_b.z() - offset.z());
    // Without eq. (34): the points in A's frame as given, subtracted as they are.
    return Vec3<S>((on_a.x() + a_center.x()) - (on_b.x() + b_center_rel.x()),
                   (on_a.y() + a_center.y()) - (on_b.y() + b_center_rel.y()),
                   (on_a.z() + a_center.z()) - (on_b.z() + b_center_rel.z()));
  }

  bool vertex_pair(std::int32_t ia, std::int32_t ib, Vec3<S>& y, Vec3<S>& on_a,
                   Vec3<S>& on_b) const {
    Vec3<S> local_b;
    if (ia < 0 || ib < 0 || !a.vertex(ia, on_a) || !b.vertex(ib, local_b)) return false;
    on_b = rotate(rotation, local_b);
    y = difference(on_a, on_b);
    return true;
  }
};

/// D(K) of eq. (37) for this K: the extents about the centroids plus the centroids' distance.
template <class K>
auto diameter_bound(const K& k_set) {
  return k_set.a.extent() + k_set.b.extent() + k_set.offset.norm();
}

// Roundoff. Every roundoff term of the loop and of the reported bound is a few ulps of one
// number, the working magnitude M: the largest coordinate the loop forms, and so the scale of
// every rounding in placing the shapes (a vertex's offset from its centre, the relative rotation
// applied to it, the centroid offset δ) and in the loop's own arithmetic. With the origin shift
// (eq. 34) every point of K is formed relative to the centroids, so M = D(K) of eq. (37); without
// it the loop adds the centroids back and M grows by their size (query() in distance.cpp is the
// one place that decides M). Callers pass M where these functions say `magnitude`.

/// The roundoff allowance every reported error bound carries: a few ulps of M. No certificate
/// resolves the distance more finely than this.
template <class S>
S distance_roundoff(S magnitude) {
  return S(8) * std::numeric_limits<S>::epsilon() * magnitude;
}

/// The size of the roundoff in a computed g = ν·ν − ν·w. ν = Σλy carries an absolute error of a
/// few ulps of M whatever its length, and that error meets w (|w| ≤ M) in the inner product:
/// a few ulps of M·(|ν| + M).
template <class S>
S roundoff_gap_of_length(S nu_length, S magnitude) {
  return S(16) * std::numeric_limits<S>::epsilon() * magnitude * (nu_length + magnitude);
}
template <class S>
S roundoff_gap(S nu_norm2, S magnitude) {
  using std::sqrt;
  return roundoff_gap_of_length(sqrt(nu_norm2), magnitude);
}

/// The certified gap: min(g, |ν|² − L²), clamped at 0. |ν|² − L² is only trusted while |ν| is
/// consistent with the proven lower bound L: |ν| is an upper bound on d only if ν ∈ K, and should
/// roundoff ever put it clearly below L, the iterate's own g (not the clamped difference) decides.
template <class S>
S certified_gap(S gap, S nu_norm2, S lower_bound, S roundoff) {
  const S sharpened = nu_norm2 - lower_bound * lower_bound;
  return std::max(S(0), sharpened >= -roundoff ? std::min(gap, sharpened) : gap);
}

/// Whether ν = 0 from a full tetrahedron is certified. The subalgorithms call the origin
/// enclosed from the signs of volumes of size |y|·|n| (n a face normal): on a needle-thin
/// tetrahedron with edges ~D long, n's own cancellation can flip them (found by fuzz_engine: a
/// polytope with a spike 2e9 long answered 'intersecting' where the shapes are 0.014 apart). The
/// verdict claims d ≈ 0, and either of two things proves it to within `tolerance`:
///  - the weights λ the signs produced: d ≤ |Σλᵢyᵢ|, a convex combination of points of K (up to
///    rounding). Decisive when the tetrahedron is well shaped, whatever the origin's depth;
///  - the nearest point of the faces: d ≤ its distance. Decisive when the tetrahedron is flat or
///    the origin lies near a face, where the weights carry large relative errors (a flat
///    tetrahedron around the origin gives garbage λ but a face through the origin).
/// A wrong "enclosed" fails both: its weights miss the origin and so do its faces. `certified2`
/// receives the square of the proven bound (0 for fewer than four points, whose ν is formed as
/// Σλy already). NaN is not certified.
template <class S>
bool enclosure_certified(const Simplex<S>& simplex, const Nearest<S>& nearest, S tolerance,
                         S& certified2) {
  certified2 = 0;
  if (nearest.subset != 15u) return true;
  const S tolerance2 = tolerance * tolerance;
  const Vec3<S>(&y)[4] = simplex.y;
  const auto residual2 = [&](const S(&lambda)[4]) {
    Vec3<S> residual = Vec3<S>::Zero();
    for (int i = 0; i < 4; ++i) residual += lambda[i] * y[i];
    return residual.squaredNorm();
  };
  // The subalgorithm's own weights first (the common case: twelve multiply-adds).
  certified2 = residual2(nearest.lambda);
  if (certified2 <= tolerance2) return true;
  // Then signed volumes' weights: Johnson's Δ's for the whole tetrahedron can miss where these
  // hold (36 of the paper set's 2000 intersecting pairs, with the paper's ε).
  const Vec3<S> zero = Vec3<S>::Zero();
  const S c[4] = {volume_with_origin(y[1], y[2], y[3]),
                  det3<S>(zero - y[0], y[2] - y[0], y[3] - y[0]),
                  det3<S>(y[1] - y[0], zero - y[0], y[3] - y[0]),
                  det3<S>(y[1] - y[0], y[2] - y[0], zero - y[0])};
  const S sum = c[0] + c[1] + c[2] + c[3];
  const S lambda[4] = {c[0] / sum, c[1] / sum, c[2] / sum, c[3] / sum};
  certified2 = residual2(lambda);
  if (certified2 <= tolerance2) return true;
  Nearest<S> faces;
  nearest_of_faces(simplex.y, 15u, faces);
  if (!(faces.nu_norm2 <= tolerance2)) return false;
  certified2 = faces.nu_norm2;
  return true;
}

/// What the loop hands back to the query: the final simplex and ν, and how the run ended.
template <class S>
struct LoopOutcome {
  Simplex<S> simplex;
  Nearest<S> nearest;
  /// The duality gap at exit, sharpened by the best lower bound: min(g(ν), |ν|² − L²). Theorem 1's
  /// |ν − ν(K)|² ≤ g holds for both terms (the second since z·ν(K) ≥ |ν(K)|² ≥ L² on K).
  S gap = 0;
  /// L: the largest support-plane lower bound ν_k·s_K(−ν_k)/|ν_k| over all iterations. Each is a
  /// certified lower bound on |ν(K)|, so the distance lies in [L, |ν|].
  S lower_bound = 0;
  /// |ν| of the final iterate: the core distance.
  S nu_length = 0;
  int iterations = 0;
  /// Support calls of K and runs of step 2 (subalgorithm or Backup Procedure): the query's cost.
  int support_calls = 0;
  int subalgorithm_runs = 0;
  Termination termination = Termination::tolerance;
  bool warm_started = false;
  FinishedBy finished_by = FinishedBy::distance_subalgorithm;
};

/// Step 2's "Distance Subalgorithm": Johnson's (which may fail on roundoff, step 4 of the
/// subalgorithm) or signed volumes (which always answers).
template <class S>
bool nearest_of_simplex(Subalgorithm method, const Simplex<S>& simplex, const Vec3<S>& newest,
                        Nearest<S>& nearest) {
  if (method == Subalgorithm::signed_volumes) {
    signed_volumes(simplex, nearest);
    return true;
  }
  return distance_subalgorithm(simplex, subset_order(simplex, newest), nearest);
}

/// What the loop needs besides K (as Box2D's b2DistanceInput groups a query's inputs): its
/// tolerances, its exits and how it starts.
template <class S>
struct LoopInput {
  /// The working magnitude M that every roundoff term is a few ulps of (distance_roundoff).
  S magnitude;
  /// ε·D(K)² of eq. (35), D(K) of eq. (37).
  S d2_tolerance;
  int max_iterations;
  /// On the core distance: a support plane proving d past it (by its roundoff) ends the loop.
  S cutoff;
  /// An iterate with |ν| ≤ this ends the loop (Termination::contact): the caller's verdict
  /// cannot change any more. Negative: never.
  S settled_below;
  Subalgorithm method;
  ColdStart cold_start;
};

/// Step 1: V_0 from the warm-start cache (Section VIII), or the single-point initialisation
/// V_0 = {s_K(−z̄₁ + z̄₂)} (Section VI), in our frame −z̄₁ + z̄₂ = δ, with the centroids' point
/// beside it for ColdStart::with_centroids. Returns the support calls made (0 or 1) and writes
/// the first support plane's lower bound on d into `lower_bound` (0 when it proves nothing).
template <class S, class K>
[[gnu::always_inline]] inline int initial_simplex(const K& k_set, const LoopInput<S>& in,
                                                  const SimplexCache* cache, bool tables,
                                                  LoopOutcome<S>& out, S& lower_bound) {
  Simplex<S>& simplex = out.simplex;
  Vec3<S> y, on_a, on_b;
  lower_bound = 0;
  if (cache && cache->count > 0 && cache->count <= 4) {
    for (int i = 0; i < cache->count; ++i) {
      bool duplicate = false;
      for (int j = 0; j < i; ++j)
        duplicate |=
            cache->index_a[j] == cache->index_a[i] && cache->index_b[j] == cache->index_b[i];
      if (duplicate) continue;
      if (k_set.vertex_pair(cache->index_a[i], cache->index_b[i], y, on_a, on_b))
        simplex.add(y, on_a, on_b, cache->index_a[i], cache->index_b[i], tables);
    }
    out.warm_started = simplex.used != 0;
  }
  if (simplex.used != 0) return 0;
  std::int32_t ia = 0, ib = 0;
  Vec3<S> direction = k_set.offset;
  const S offset_norm2 = direction.squaredNorm();
  if (!(offset_norm2 > 0)) direction = Vec3<S>(1, 0, 0);  // concentric: any will do
  k_set.support(direction, y, on_a, on_b, ia, ib);
  simplex.add(y, on_a, on_b, ia, ib, tables);
  // This first support point is already a support plane: every x ∈ K has u·x ≥ u·s_K(−u) for
  // any unit u, and |x| ≥ u·x, so d ≥ u·s_K(−u). With u = −δ/|δ| (towards K's centroid
  // z̄₁ − z̄₂), s_K(−u) is the point just found. Well-separated pairs are decided by this bound
  // without a second support call: the yes/no query's common case.
  const S along = -direction.dot(y);
  if (offset_norm2 > 0 && along > 0) {
    using std::sqrt;
    lower_bound = along / sqrt(offset_norm2);
  }
  // The centroids' difference z̄_A − z̄_B is a point of K (each centroid lies in its shape),
  // here y = 0 − 0 − δ, and costs no support call. When the shapes overlap it usually lies
  // deep inside K, and the simplex that encloses the origin needs one support point fewer.
  // Not when the first support plane already proves the shapes apart (then it is an interior
  // point the descent would only drop: measured, it cost separated pairs more than it saved),
  // nor when it would repeat y (two points, say).
  // (Each centroid as a point its shape's adaptor vouches for, interior(): a polytope's rounded
  // vertex mean can lie outside a thin hull modelled far from its origin.)
  if (in.cold_start == ColdStart::with_centroids &&
      !(lower_bound > distance_roundoff(in.magnitude))) {
    const Vec3<S> inner_a = k_set.a.interior();
    const Vec3<S> inner_b = rotate(k_set.rotation, k_set.b.interior());
    const Vec3<S> centroids = k_set.difference(inner_a, inner_b);
    if (centroids != y) simplex.add(centroids, inner_a, inner_b, -1, -1, tables);
  }
  return 1;
}

/// The support plane with unit normal n̂ (towards ν) proves d ≥ n̂·s_K(−n̂): raises
/// `out.lower_bound` and sharpens `out.gap` when it proves more than the loop's planes did.
template <class S, class K>
[[gnu::always_inline]] inline void sharpen_by_plane(const K& k_set, const Vec3<S>& normal,
                                                    const Nearest<S>& nearest, S magnitude,
                                                    LoopOutcome<S>& out) {
  Vec3<S> w, on_a, on_b;
  std::int32_t ia, ib;
  k_set.support(-normal, w, on_a, on_b, ia, ib);
  const S plane_bound = normal.dot(w);
  if (plane_bound > out.lower_bound) {
    out.lower_bound = plane_bound;
    out.gap = certified_gap(out.gap, nearest.nu_norm2, plane_bound,
                            roundoff_gap(nearest.nu_norm2, magnitude));
  }
}

/// A sharper certificate near contact, for an answer ν on a triangle (y0, y1, y2) of K's points.
/// ν's direction carries an error of ~ulp(M)/|ν|, so when ν is short the support plane normal to
/// ν proves little; the triangle's own normal (accurate whatever |ν| is) gives the plane of K's
/// face or of the two shapes' edge–edge contact, and one more support call proves
/// d ≥ n̂·s_K(−n̂). Raises `out.lower_bound` and sharpens `out.gap` when it proves more. Returns
/// the support calls made (0 or 1).
template <class S, class K>
[[gnu::always_inline]] inline int sharpen_by_triangle_plane(const K& k_set, const Vec3<S>& y0,
                                                            const Vec3<S>& y1, const Vec3<S>& y2,
                                                            const Nearest<S>& nearest, S magnitude,
                                                            LoopOutcome<S>& out) {
  Vec3<S> normal = (y1 - y0).cross(y2 - y0);
  const S length = normal.norm();
  if (!(length > 0)) return 0;
  normal /= length;
  if (normal.dot(nearest.nu) < 0) normal = -normal;
  sharpen_by_plane(k_set, normal, nearest, magnitude, out);
  return 1;
}

/// The same certificate for an answer ν on an edge (y0, y1) of K (an edge of one shape against a
/// vertex of the other, the common near-contact end between polytopes with few faces). ν's
/// error along the edge tilts the plane normal to ν by ~ulp(M)/|ν| along it, and the edge, up to
/// D(K) long, then dips below the plane by that angle times its length: at a gap of 1e-9·D the
/// bound was the gap itself. The component of ν across the edge, n = ν − (ν·e)e/|e|², has no
/// such error (e is accurate to ulp(M)/|e|); its remaining error turns n within the edge's normal
/// wedge, where the plane still touches the edge, and costs only second order. Any direction
/// gives a valid bound d ≥ n̂·s_K(−n̂), so a wrong guess is never unsafe, only unsharp.
template <class S, class K>
[[gnu::always_inline]] inline int sharpen_by_edge_plane(const K& k_set, const Vec3<S>& y0,
                                                        const Vec3<S>& y1,
                                                        const Nearest<S>& nearest, S magnitude,
                                                        LoopOutcome<S>& out) {
  const Vec3<S> edge = y1 - y0;
  const S edge2 = edge.squaredNorm();
  if (!(edge2 > 0)) return 0;
  Vec3<S> normal = nearest.nu - (nearest.nu.dot(edge) / edge2) * edge;
  const S length = normal.norm();
  if (!(length > 0)) return 0;
  normal /= length;
  sharpen_by_plane(k_set, normal, nearest, magnitude, out);
  return 1;
}

/// Runs steps 1–6 of Section VI on K (see LoopInput). One function: the loop is GJK's single
/// dependency chain (support → ν → support), and its state lives in registers across the steps.
template <class S, class K>
void run_numerical_algorithm(const K& k_set, const LoopInput<S>& in, const SimplexCache* cache,
                             LoopOutcome<S>& out) {
  const S magnitude = in.magnitude, d2_tolerance = in.d2_tolerance;
  const int max_iterations = in.max_iterations;
  const S settled_below = in.settled_below;
  const Subalgorithm method = in.method;
  Simplex<S>& simplex = out.simplex;
  const S interval_floor = distance_roundoff(magnitude);
  // A computed support-plane bound L carries roundoff of a few ulps of D(K) (in y and in the
  // inner product), so "d > cutoff" is proven only when L clears the cutoff by that much.
  // Without the margin, touching pairs were reported beyond a zero cutoff.
  const S proven_beyond = in.cutoff + interval_floor;
  // Johnson's method reads the inner products and Δ's every step; signed volumes never does, and
  // the Backup Procedure rebuilds them on the rare occasions it runs.
  const bool tables = method == Subalgorithm::johnson;
  // ν_k and ν_{k−1} live in two buffers that trade places each step, rather than ν_k being
  // copied aside: the subalgorithm writes its answer field by field, and the copy read those
  // fresh 8-byte stores back as 16-byte loads (a store-forwarding stall every iteration).
  Nearest<S> spare;
  Nearest<S>* nearest = &out.nearest;
  Nearest<S>* previous = &spare;
  // Zeroed although every read follows a support call that wrote them: GCC 12 at -O3 cannot see
  // that a step-4 descent implies step 3's call (ν ≠ 0) and warned on the float build.
  Vec3<S> on_a = Vec3<S>::Zero(), on_b = Vec3<S>::Zero();
  std::int32_t ia = 0, ib = 0;
  // The cost counters (LoopOutcome::support_calls, subalgorithm_runs) are derived at the end from
  // k and a few events counted off the common path: increments in the loop itself measurably
  // slowed the warm-started queries they exist to account for (2–3% on the Table I path).
  int rare_support_calls = 0;        // passes that tested (35) and then ran step 6
  int extra_runs = 0;                // Backup Procedure runs
  bool exit_before_support = false;  // the last pass ended before step 3's support call

  // Step 1: V_0. The best support-plane lower bound L found so far starts with its first plane.
  S best_lower_bound;
  int support_calls = initial_simplex(k_set, in, cache, tables, out, best_lower_bound);
  simplex.newest = -1;  // V_0 has no "newest" point: try its subsets largest first

  Vec3<S> w = Vec3<S>::Zero();
  bool backup = false;
  int k = 0;

  // Step 2 for V_0.
  if (!nearest_of_simplex(method, simplex, w, *nearest)) {
    backup_procedure(simplex, *nearest);
    ++extra_runs;
    backup = true;
  }
  // The previous iterate ν_{k−1}: the best so far, since every accepted step descends. Its slots
  // stay intact while step k runs (only the new support point's slot is written), so a failed
  // step can fall back to it by trading the two buffers back.
  S previous_gap = 0;
  for (;;) {
    // One square root per iteration, taken as soon as ν is known: the query's distance is this
    // |ν| at exit, ready before the exit branch resolves instead of computed after it.
    using std::sqrt;
    const S nu_length = sqrt(nearest->nu_norm2);
    out.nu_length = nu_length;
    // A lower bound past the cutoff ends the query (here only the first support plane's can be;
    // later ones are tested right after their support call, below).
    if (best_lower_bound > proven_beyond) {
      out.gap = std::max(S(0), nearest->nu_norm2 - best_lower_bound * best_lower_bound);
      out.lower_bound = best_lower_bound;
      out.termination = Termination::beyond_cutoff;
      exit_before_support = true;
      break;
    }
    // Contact settled: ν ∈ K proves d ≤ |ν|, and the distance lies in [L, |ν|] (no support call
    // needed for that), so the gap |ν|² − L² certifies this iterate.
    if (nearest->nu_norm2 > 0 && settled_below >= 0 &&
        nearest->nu_norm2 <= settled_below * settled_below) {
      out.gap = std::max(S(0), nearest->nu_norm2 - best_lower_bound * best_lower_bound);
      out.lower_bound = best_lower_bound;
      out.termination = Termination::contact;
      exit_before_support = true;
      break;
    }
    // Step 3: the stopping rule (35), g(ν_k) ≤ ε·D(K)².
    S gap = 0;
    bool repeated = false;
    if (nearest->nu_norm2 > 0) {
      k_set.support(-nearest->nu, w, on_a, on_b, ia, ib);
      const S nu_dot_w = nearest->nu.dot(w);
      gap = nearest->nu_norm2 - nu_dot_w;  // g = |ν|² + h_K(−ν), h_K(−ν) = −ν·w   (25)
      best_lower_bound = std::max(best_lower_bound, nu_dot_w / nu_length);
      // Bitwise, not short-circuit: the outcome is data-dependent and would mispredict.
      for (int i = 0; i < 4; ++i)
        repeated |= bool((nearest->subset >> i) & 1u) & (simplex.index_a[i] == ia) &
                    (simplex.index_b[i] == ib);
      repeated &= (ia >= 0) & (ib >= 0);
    } else {
      best_lower_bound = 0;
    }
    // On curved or flat-sided shapes the support point can jump between iterations (a cylinder's
    // two rims), so g of the latest iterate may be far worse than what an earlier support plane
    // proved: the stopping test uses the sharper of the two certificates.
    const S roundoff = roundoff_gap_of_length(nu_length, magnitude);
    out.gap = certified_gap(gap, nearest->nu_norm2, best_lower_bound, roundoff);
    out.lower_bound = best_lower_bound;
    NEARPOINT_TRACE_PRINTF("k=%d |V|=%d subset=%x |nu|^2=%.17g g=%.6g backup=%d rep=%d\n", k,
                           simplex.size(), nearest->subset, double(nearest->nu_norm2), double(gap),
                           int(backup), int(repeated));
    if (!(nearest->nu_norm2 > 0)) {
      S certified2;
      if (enclosure_certified(simplex, *nearest, interval_floor, certified2)) {
        out.gap = certified2;  // d ≤ its square root: the verdict's own certificate
        out.termination = Termination::origin_enclosed;  // ν = 0: "intersecting"
        exit_before_support = true;
        break;
      }
      // Neither the weights nor the faces put the origin within roundoff of the tetrahedron:
      // the signs that said "enclosed" were wrong. The nearest point of its faces is the iterate
      // instead, and the loop goes on from there.
      nearest_of_faces(simplex.y, 15u, *nearest);
      ++extra_runs;
      continue;
    }
    if (out.gap <= d2_tolerance) {
      out.termination = Termination::tolerance;  // eq. (35)
      break;
    }
    // The support point repeats a vertex of V̂_k: in exact arithmetic g = 0 (ν·(ν − y_i) = 0 on
    // V̂_k, eq. 43). Accept when g is at its roundoff level; otherwise let the descent check and
    // the Backup Procedure deal with the inconsistency.
    if (repeated && gap <= roundoff) {
      out.termination = Termination::repeated_support;
      break;
    }
    // A new support point that ties with the current face (the fourth vertex of a box's face,
    // say): g is zero to within its roundoff, and the certified interval [L, |ν|] is already as
    // narrow as the roundoff allowance the error bound carries. Adding the point could move the
    // distance by no more than that interval, and in practice leaves ν unchanged: the step would
    // only find no descent and end, after the Backup Procedure, at the same roundoff floor.
    // Only between vertices (both indices known): on a finite vertex set a face that is not the
    // optimum leaves g a geometric margin above roundoff. On a curved shape g ≤ roundoff still
    // leaves ν's direction √g/|ν| uncertain, which near points and gradients would inherit.
    if (gap <= roundoff && ia >= 0 && ib >= 0 && nu_length - best_lower_bound <= interval_floor) {
      out.termination = Termination::roundoff_floor;
      break;
    }
    if (out.lower_bound > proven_beyond) {
      out.termination = Termination::beyond_cutoff;  // the support plane proves d > cutoff
      break;
    }
    // Step 4: descend with V_{k+1} = V̂_k ∪ {s_K(−ν_k)} while |ν| strictly decreases (26).
    if ((k == 0 || nearest->nu_norm2 < previous->nu_norm2) && subset_size(nearest->subset) <= 3) {
      if (k >= max_iterations) {
        out.termination = Termination::iteration_limit;  // the cap, not convergence
        break;
      }
      std::swap(nearest, previous);
      previous_gap = out.gap;
      simplex.keep(previous->subset);
      simplex.add(w, on_a, on_b, ia, ib, tables);
      ++k;
      backup = false;
      if (!nearest_of_simplex(method, simplex, w, *nearest)) {
        backup_procedure(simplex, *nearest);
        ++extra_runs;
        backup = true;
      }
      continue;
    }
    // Step 5: no descent although the Backup Procedure was used: the numerical limit is reached.
    // Return the best iterate, ν_{k−1} when step k made things worse.
    if (backup) {
      if (k > 0 && !(nearest->nu_norm2 < previous->nu_norm2)) {
        out.gap = certified_gap(previous_gap, previous->nu_norm2, best_lower_bound,
                                roundoff_gap(previous->nu_norm2, magnitude));
        std::swap(nearest, previous);
        out.nu_length = sqrt(nearest->nu_norm2);
      }
      out.termination = out.gap <= roundoff_gap(nearest->nu_norm2, magnitude)
                            ? Termination::roundoff_floor
                            : Termination::numerical_limit;
      break;
    }
    // Step 6: recompute ν_k on V_k with the Backup Procedure and test (35) again.
    backup_procedure(simplex, *nearest);
    ++extra_runs;
    ++rare_support_calls;
    backup = true;
  }
  // The closing certificate near contact (sharpen_by_triangle_plane, sharpen_by_edge_plane).
  const int final_size = subset_size(nearest->subset);
  if ((final_size == 2 || final_size == 3) && nearest->nu_norm2 > 0 &&
      out.termination != Termination::beyond_cutoff && out.termination != Termination::contact &&
      out.nu_length - out.lower_bound > distance_roundoff(magnitude)) {
    int idx[3], n = 0;
    for (int i = 0; i < 4; ++i)
      if (nearest->subset & (1u << i)) idx[n++] = i;
    support_calls += final_size == 3
                         ? sharpen_by_triangle_plane(k_set, simplex.y[idx[0]], simplex.y[idx[1]],
                                                     simplex.y[idx[2]], *nearest, magnitude, out)
                         : sharpen_by_edge_plane(k_set, simplex.y[idx[0]], simplex.y[idx[1]],
                                                 *nearest, magnitude, out);
  }
  if (nearest != &out.nearest) out.nearest = *nearest;
  out.iterations = k;
  // Every pass through step 3 with ν ≠ 0 makes one support call: the k passes that added a point,
  // those that went on to step 6, and the last one unless it ended before its call. Step 2 runs
  // once on V_0 and once per added point, plus each Backup Procedure.
  out.support_calls = support_calls + k + rare_support_calls + (exit_before_support ? 0 : 1);
  out.subalgorithm_runs = k + 1 + extra_runs;
  out.finished_by = backup ? FinishedBy::backup_procedure : FinishedBy::distance_subalgorithm;
}

/// The loop's outcome when both cores are points (spheres, or points): K = A − B is the single
/// point y = −δ (eq. 34's frame), so ν(K) = y, and its support point in every direction is y
/// itself: g(ν) = |ν|² + h_K(−ν) = |ν|² − ν·ν = 0 (eq. 25), and Theorem 1 certifies ν exactly,
/// up to the rounding of δ that the roundoff allowance covers. run_numerical_algorithm reaches
/// the same ν after its first support call and a second that repeats it; this is that run written
/// out, without the simplex machinery. Its exits and counts are the loop's: the first support
/// plane (cold starts) proves a cutoff, the contact settles the verdict, ν = 0 encloses the
/// origin, otherwise step 3's support call meets eq. (35) with g = 0. The certificate is the
/// exact one whichever exit (gap 0, L = |ν|), where the loop's early exits kept a weaker one.
template <class S, class K>
void point_pair_outcome(const K& k_set, S magnitude, S cutoff, S settled_below,
                        const SimplexCache* cache, LoopOutcome<S>& out) {
  using std::sqrt;
  const Vec3<S> zero = Vec3<S>::Zero();
  const Vec3<S> y = k_set.difference(zero, zero);  // −δ: all of K
  out.simplex.add(y, zero, zero, 0, 0, /*update_tables=*/false);
  out.simplex.newest = -1;
  Nearest<S>& nearest = out.nearest;
  nearest.subset = 1u;
  nearest.lambda[0] = S(1);
  nearest.lambda[1] = nearest.lambda[2] = nearest.lambda[3] = S(0);
  nearest.nu = y;
  nearest.nu_norm2 = y.squaredNorm();
  const S nu_length = sqrt(nearest.nu_norm2);
  out.nu_length = nu_length;
  out.gap = 0;
  out.lower_bound = nu_length;
  // A warm start reads the cached pairs as the loop would: a point's only vertex is index 0.
  bool warm = false;
  if (cache && cache->count > 0 && cache->count <= 4)
    for (int i = 0; i < cache->count; ++i)
      warm |= (cache->index_a[i] == 0) & (cache->index_b[i] == 0);
  out.warm_started = warm;
  bool before_support = true;
  if (!warm && nu_length > cutoff + distance_roundoff(magnitude)) {
    out.termination = Termination::beyond_cutoff;  // the first support plane: d ≥ |δ|
  } else if (nearest.nu_norm2 > 0 && settled_below >= 0 &&
             nearest.nu_norm2 <= settled_below * settled_below) {
    out.termination = Termination::contact;
  } else if (!(nearest.nu_norm2 > 0)) {
    out.termination = Termination::origin_enclosed;
  } else {
    out.termination = Termination::tolerance;  // eq. (35) with g = 0
    before_support = false;
  }
  out.iterations = 0;
  out.support_calls = (warm ? 0 : 1) + (before_support ? 0 : 1);
  out.subalgorithm_runs = 1;
  out.finished_by = FinishedBy::distance_subalgorithm;
}

/// The loop's outcome when both cores are segments (capsules), from the closed form of the
/// nearest points of two segments, certified as the loop certifies its answers. K = A − B is the
/// parallelogram {a(s) − b(t) − δ : s, t ∈ [0, 1]}; the parameters (s, t) of its point nearest
/// the origin are found by clamping the stationary point of |a(s) − b(t) − δ|² to the unit
/// square (the segments' nearest points, as in Ericson's Real-Time Collision Detection, 5.1.9).
/// ν is written as a convex combination of K's vertices y_ij = a_i − b_j − δ (eq. 22): (s, t)
/// lies in one of the square's two triangles along its diagonal, whose barycentric weights are
/// (1 − s, s − t, t) or (1 − t, t − s, s). One support call then gives g(ν) = |ν|² − ν·s_K(−ν)
/// (eq. 25) and the support-plane bound L, and the answer is kept only when g is at its roundoff
/// level (the loop's own acceptance of a polytope answer, Termination::roundoff_floor, or eq. 35
/// when g is below ε·D²), so the reported bound is Theorem 1's as for any loop exit. Otherwise
/// (nearly parallel segments whose stationary point the rounding moved, say) it returns false
/// and the caller runs the loop. A warm-start cache is not read: the answer needs none.
template <class S, class K>
bool segment_pair_outcome(const K& k_set, S magnitude, S d2_tolerance, S cutoff, S settled_below,
                          LoopOutcome<S>& out) {
  using std::sqrt;
  Vec3<S> y[2][2], on_a[2], on_b[2];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) k_set.vertex_pair(i, j, y[i][j], on_a[i], on_b[j]);
  // a(s) − b(t) − δ = r + s·d1 − t·d2 with r = y00, d1 = a1 − a0, d2 = b1 − b0.
  const Vec3<S> r = y[0][0];
  const Vec3<S> d1 = on_a[1] - on_a[0];
  const Vec3<S> d2 = on_b[1] - on_b[0];
  const S a = d1.dot(d1), e = d2.dot(d2), f = d2.dot(r), c = d1.dot(r);
  const auto clamp01 = [](S x) { return x > S(0) ? (x < S(1) ? x : S(1)) : S(0); };
  S s_par = 0, t_par = 0;
  if (!(a > 0) && !(e > 0)) {
    // both segments are points
  } else if (!(a > 0)) {
    t_par = clamp01(f / e);
  } else if (!(e > 0)) {
    s_par = clamp01(-c / a);
  } else {
    const S b = d1.dot(d2);
    const S denominator = a * e - b * b;  // ≥ 0; 0 when parallel
    s_par = denominator > 0 ? clamp01((b * f - c * e) / denominator) : S(0);
    t_par = (b * s_par + f) / e;
    if (t_par < 0) {
      t_par = 0;
      s_par = clamp01(-c / a);
    } else if (t_par > 1) {
      t_par = 1;
      s_par = clamp01((b - c) / a);
    }
  }
  // The triangle of the unit square that holds (s, t), and its barycentric weights.
  const bool lower = s_par >= t_par;
  const int corner[3][2] = {{0, 0}, {lower ? 1 : 0, lower ? 0 : 1}, {1, 1}};
  const S weight[3] = {lower ? S(1) - s_par : S(1) - t_par, lower ? s_par - t_par : t_par - s_par,
                       lower ? t_par : s_par};
  Simplex<S>& simplex = out.simplex;
  Nearest<S>& nearest = out.nearest;
  Vec3<S> nu = Vec3<S>::Zero();
  nearest.subset = 0;
  for (int k = 0; k < 3; ++k) {
    if (!(weight[k] > 0)) continue;
    const int i = corner[k][0], j = corner[k][1];
    const int slot = simplex.add(y[i][j], on_a[i], on_b[j], i, j, /*update_tables=*/false);
    nearest.subset |= 1u << slot;
    nearest.lambda[slot] = weight[k];
    nu += weight[k] * y[i][j];  // eq. (22)
  }
  for (int slot = simplex.size(); slot < 4; ++slot) nearest.lambda[slot] = S(0);
  simplex.newest = -1;
  nearest.nu = nu;
  nearest.nu_norm2 = nu.squaredNorm();
  const S nu_length = sqrt(nearest.nu_norm2);
  out.nu_length = nu_length;
  out.iterations = 0;
  out.subalgorithm_runs = 1;
  out.warm_started = false;
  out.finished_by = FinishedBy::distance_subalgorithm;
  if (!(nearest.nu_norm2 > 0)) {  // the segments cross: ν = 0, g = 0
    out.gap = 0;
    out.lower_bound = 0;
    out.support_calls = 0;
    out.termination = Termination::origin_enclosed;
    return true;
  }
  // The certificate: one support call, eq. (25), and the support plane's lower bound.
  Vec3<S> w, support_a, support_b;
  std::int32_t ia, ib;
  k_set.support(-nu, w, support_a, support_b, ia, ib);
  const S nu_dot_w = nu.dot(w);
  const S gap = nearest.nu_norm2 - nu_dot_w;
  const S lower_bound = std::max(S(0), nu_dot_w / nu_length);
  const S roundoff = roundoff_gap_of_length(nu_length, magnitude);
  if (!(gap <= roundoff)) return false;  // not at the optimum to within roundoff: run the loop
  out.gap = certified_gap(gap, nearest.nu_norm2, lower_bound, roundoff);
  out.lower_bound = lower_bound;
  out.support_calls = 1;
  // The loop's closing certificate (sharpen_by_triangle_plane): when ν lies inside a triangle of
  // K's vertices (the segments' nearest points inside both, the usual near-contact case), the
  // triangle's own normal is K's plane and proves d ≥ n̂·s_K(−n̂) to roundoff.
  if (simplex.size() == 3 && nu_length - lower_bound > distance_roundoff(magnitude))
    out.support_calls += sharpen_by_triangle_plane(k_set, simplex.y[0], simplex.y[1], simplex.y[2],
                                                   nearest, magnitude, out);
  const S proven = out.lower_bound;
  if (proven > cutoff + distance_roundoff(magnitude))
    out.termination = Termination::beyond_cutoff;
  else if (settled_below >= 0 && nearest.nu_norm2 <= settled_below * settled_below)
    out.termination = Termination::contact;
  else
    out.termination =
        out.gap <= d2_tolerance ? Termination::tolerance : Termination::roundoff_floor;
  return true;
}

}  // namespace nearpoint::detail
