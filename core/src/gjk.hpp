// The paper's Numerical Algorithm (Section VI, steps 1–6) on K = A − B, for two concrete shapes.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "johnson.hpp"
#include "nearpoint/distance.hpp"
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
    on_a = a.support(eta, ia);
    on_b = rotation * b.support(-(rotation.transpose() * eta), ib);
    y = difference(on_a, on_b);
  }

  Vec3<S> difference(const Vec3<S>& on_a, const Vec3<S>& on_b) const {
    if (origin_shift) return on_a - on_b - offset;
    // Without eq. (34): the points in A's frame as given, subtracted as they are.
    return (on_a + a_center) - (on_b + b_center_rel);
  }

  bool vertex_pair(std::int32_t ia, std::int32_t ib, Vec3<S>& y, Vec3<S>& on_a,
                   Vec3<S>& on_b) const {
    Vec3<S> local_b;
    if (ia < 0 || ib < 0 || !a.vertex(ia, on_a) || !b.vertex(ib, local_b)) return false;
    on_b = rotation * local_b;
    y = difference(on_a, on_b);
    return true;
  }
};

/// What the loop hands back to the query: the final simplex and ν, and how the run ended.
template <class S>
struct LoopOutcome {
  Simplex<S> simplex;
  Nearest<S> nearest;
  S gap = 0;
  S lower_bound = 0;  // ν·s_K(−ν)/|ν|: a certified lower bound on |ν(K)| (support plane)
  int iterations = 0;
  bool converged = false;
  bool capped = false;
  bool beyond_cutoff = false;
  bool warm_started = false;
  FinishedBy finished_by = FinishedBy::distance_subalgorithm;
};

/// Runs steps 1–6. `d2_tolerance` is ε·D(K)² of eq. (35); `cutoff` is on the core distance.
template <class S, class K>
void run_numerical_algorithm(const K& k_set, S d2_tolerance, int max_iterations, S cutoff,
                             const SimplexCache* cache, LoopOutcome<S>& out) {
  Simplex<S>& simplex = out.simplex;
  Nearest<S>& nearest = out.nearest;
  Vec3<S> y, on_a, on_b;
  std::int32_t ia = 0, ib = 0;

  // Step 1: V_0. Warm start from the cached vertex pairs (Section VIII) or the single-point
  // initialisation V_0 = {s_K(−z̄₁ + z̄₂)} (Section VI); in our frame −z̄₁ + z̄₂ = δ.
  if (cache && cache->count > 0 && cache->count <= 4) {
    for (int i = 0; i < cache->count; ++i) {
      bool duplicate = false;
      for (int j = 0; j < i; ++j)
        duplicate |=
            cache->index_a[j] == cache->index_a[i] && cache->index_b[j] == cache->index_b[i];
      if (duplicate) continue;
      if (k_set.vertex_pair(cache->index_a[i], cache->index_b[i], y, on_a, on_b))
        simplex.add(y, on_a, on_b, cache->index_a[i], cache->index_b[i]);
    }
    out.warm_started = simplex.used != 0;
  }
  if (simplex.used == 0) {
    Vec3<S> direction = k_set.offset;
    if (!(direction.squaredNorm() > 0)) direction = Vec3<S>(1, 0, 0);  // concentric: any will do
    k_set.support(direction, y, on_a, on_b, ia, ib);
    simplex.add(y, on_a, on_b, ia, ib);
  }
  simplex.newest = -1;  // V_0 has no "newest" point: try its subsets largest first

  unsigned order[15];
  Vec3<S> w = Vec3<S>::Zero();
  bool backup = false;
  S previous_norm2 = std::numeric_limits<S>::infinity();
  int k = 0;

  // Step 2 for V_0.
  {
    const int n = subset_order(simplex, w, order);
    if (!distance_subalgorithm(simplex, order, n, nearest)) {
      backup_procedure(simplex, nearest);
      backup = true;
    }
  }
  for (;;) {
    // Step 3: the stopping rule (35), g(ν_k) ≤ ε·D(K)².
    S gap = 0;
    if (nearest.nu_norm2 > 0) {
      k_set.support(-nearest.nu, w, on_a, on_b, ia, ib);
      const S nu_dot_w = nearest.nu.dot(w);
      gap = nearest.nu_norm2 - nu_dot_w;  // g = |ν|² + h_K(−ν), h_K(−ν) = −ν·w   (25)
      using std::sqrt;
      out.lower_bound = std::max(S(0), nu_dot_w / sqrt(nearest.nu_norm2));
    } else {
      out.lower_bound = 0;  // ν = 0: the origin is in K, g = 0
    }
    out.gap = std::max(S(0), gap);
    if (gap <= d2_tolerance) {
      out.converged = true;  // eq. (35): "converged"
      break;
    }
    if (out.lower_bound > cutoff) {
      out.beyond_cutoff = true;  // the support plane proves the distance exceeds the cutoff
      break;
    }
    // Step 4: descend with V_{k+1} = V̂_k ∪ {s_K(−ν_k)} while |ν| strictly decreases (26).
    if ((k == 0 || nearest.nu_norm2 < previous_norm2) && std::popcount(nearest.subset) <= 3) {
      if (k >= max_iterations) {
        out.capped = true;  // the cap, not convergence: the status will say so
        break;
      }
      previous_norm2 = nearest.nu_norm2;
      simplex.keep(nearest.subset);
      simplex.add(w, on_a, on_b, ia, ib);
      ++k;
      const int n = subset_order(simplex, w, order);
      backup = false;
      if (!distance_subalgorithm(simplex, order, n, nearest)) {
        backup_procedure(simplex, nearest);
        backup = true;
      }
      continue;
    }
    // Step 5: no descent although the Backup Procedure was used: the numerical limit is reached
    // before the tolerance (35). Stop with the best representation found ("not converged").
    if (backup) break;
    // Step 6: recompute ν_k on V_k with the Backup Procedure and test (35) again.
    backup_procedure(simplex, nearest);
    backup = true;
  }
  out.iterations = k;
  out.finished_by = backup ? FinishedBy::backup_procedure : FinishedBy::distance_subalgorithm;
}

}  // namespace nearpoint::detail
