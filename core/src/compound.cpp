// SPDX-License-Identifier: Apache-2.0
// Objects as unions of convex pieces (paper Section II, eq. 2–4): the distance is the least over
// piece pairs, found by evaluating the pairs whose bounding spheres may beat the best so far.
// E. G. Gilbert, D. W. Johnson, S. S. Keerthi, "A Fast Procedure for Computing the Distance Between
// Complex Objects in Three-Dimensional Space", IEEE Journal of Robotics and Automation 4(2), 1988
// (equations as numbered there; docs/design.md has the paper by section).
//
// Where it departs from the paper: pairs are pruned by bounding spheres (with a rounding margin)
// and stopped as soon as a support plane proves them beyond the best; the answer's bound covers
// every evaluated pair's interval and the rounding of composing the pieces' poses.
#include "nearpoint/compound.hpp"

#include "distance_internal.hpp"

#include <algorithm>
#include <limits>

namespace nearpoint {

template <class S>
Compound<S>::Compound(std::vector<Piece<S>> pieces) : pieces_(std::move(pieces)) {
  if (pieces_.empty()) return;  // keeps "compound has no pieces"
  centers_.reserve(pieces_.size());
  radii_.reserve(pieces_.size());
  for (const Piece<S>& piece : pieces_) {
    if (const char* why = nearpoint::invalid_reason(piece.shape)) {
      invalid_reason_ = why;
      return;
    }
    if (detail::invalid_pose_reason(piece.offset)) {
      invalid_reason_ =
          "compound piece offset is not a rigid transformation (non-finite, not "
          "orthonormal, or a reflection)";
      return;
    }
    // A sphere about the piece's centre z̄ with its extent and radius bounds the rounded piece,
    // once widened by the rounding of placing z̄ in the body frame (ulps of the offset's
    // translation and of z̄ itself: a piece modelled far from its own origin).
    const Vec3<S> center = core_center(piece.shape);
    centers_.push_back(piece.offset.apply(center));
    radii_.push_back(core_extent(piece.shape) + piece.shape.radius +
                     S(8) * std::numeric_limits<S>::epsilon() *
                         (piece.offset.translation.cwiseAbs().sum() + center.cwiseAbs().sum()));
    at_origin_.push_back(piece.offset.rotation == Mat3<S>::Identity() &&
                         piece.offset.translation == Vec3<S>::Zero());
  }
  invalid_reason_ = nullptr;
}

template <class S>
CompoundResult<S> distance(const Compound<S>& a, const Pose<S>& pose_a, const Compound<S>& b,
                           const Pose<S>& pose_b, const DistanceOptions<S>& options,
                           std::span<SimplexCache> caches) {
  CompoundResult<S> out;
  const char* why = a.invalid_reason() ? a.invalid_reason() : b.invalid_reason();
  S defect2_a = 0;  // ‖R_AᵀR_A − I‖_F², for pieces queried on the caller's poses
  if (!why) why = detail::invalid_poses_reason(pose_a, pose_b, &defect2_a);
  if (!why && !caches.empty() && caches.size() != a.size() * b.size())
    why = "compound query: caches must be empty or hold one cache per piece pair";
  if (why) {
    detail::set_invalid(out.nearest, why);
    return out;
  }

  // The world moved to A's position: the piece poses are composed from (R_A, 0) and
  // (R_B, p_B − p_A), as the single-shape query places B relative to A, so that objects far from
  // the origin do not round their pieces' placement to the ulps of their world coordinates (two
  // unit spheres at x ≈ 1e9, one 5e-8 nearer: composed in the world frame both sat at the same
  // rounded place and the nearer one was pruned). A translation of the whole scene changes no
  // distance; near points are moved back at the end. The object whose piece sits at its origin is
  // queried on the caller's poses themselves: exactly the single-shape query.
  Pose<S> frame_a, frame_b;
  frame_a.rotation = pose_a.rotation;
  frame_b.rotation = pose_b.rotation;
  frame_b.translation = pose_b.translation - pose_a.translation;
  // Which frame the best answer's near points are in: the world (a pair of pieces at their
  // objects' origins, queried on the caller's poses) or A's position (composed pieces).
  bool nearest_in_world = false;

  // Pieces are evaluated without the gradient (it refers to the whole objects, see below).
  DistanceOptions<S> piece_options = options;
  piece_options.gradient = false;
  piece_options.near_points = options.near_points || options.gradient;

  // Lower bound on a piece pair's distance from its bounding spheres (eq. 2–4 need every pair
  // only in principle: a pair whose spheres are farther apart than the best distance cannot win).
  // The sphere centres go to world frame once per query; for the usual few pieces the gaps are
  // kept on the stack so the pruning pass below does not recompute them.
  constexpr std::size_t kStackPairs = 64;
  const std::size_t pair_count = a.size() * b.size();
  const bool keep_gaps = pair_count <= kStackPairs;
  S gaps[kStackPairs];
  // The computed gap errs by a few ulps of the magnitudes that enter it; pairs are pruned only
  // when it exceeds the best distance by more than that and more than the best's own error bound
  // (so a pair is skipped only when it is certainly not nearer).
  S gap_roundoff = 0;
  auto compute_gap = [&](std::size_t i, std::size_t j) {
    const Vec3<S> ca = detail::apply_pose(frame_a, a.sphere_center(i));
    const Vec3<S> cb = detail::apply_pose(frame_b, b.sphere_center(j));
    const S magnitude = ca.cwiseAbs().sum() + cb.cwiseAbs().sum() + a.sphere_radius(i) +
                        b.sphere_radius(j) + frame_b.translation.cwiseAbs().sum() +
                        a.sphere_center(i).cwiseAbs().sum() + b.sphere_center(j).cwiseAbs().sum();
    gap_roundoff = std::max(gap_roundoff, S(16) * std::numeric_limits<S>::epsilon() * magnitude);
    // Scaled before squaring: centres beyond √max apart overflowed |cb − ca|² to inf, and an
    // infinite gap pruned a pair that was in fact the nearest (found by fuzz_engine in float).
    return (cb - ca).stableNorm() - a.sphere_radius(i) - b.sphere_radius(j);
  };
  auto sphere_gap = [&](std::size_t i, std::size_t j) {
    return keep_gaps ? gaps[i * b.size() + j] : compute_gap(i, j);
  };
  // A piece's pose is the object's when it sits at the object's origin (single-piece obstacles,
  // say); otherwise the two are composed here. Poses composed from validated ones are rigid to
  // roundoff: no need to check them again. The answer is written straight into `into` (the
  // object's result for the first pair): a returned result was a 400-byte copy per query.
  Pose<S> placed_a, placed_b;
  // The caches as they were, for the pairs evaluated so far: a refused query leaves them so
  // (restore_caches). Beyond kStackPairs evaluated pairs (rare: pruning keeps few), a refusal
  // leaves those caches as cold starts.
  struct Saved {
    std::size_t index;
    SimplexCache cache;
  };
  Saved saved[kStackPairs];
  std::size_t saved_count = 0;
  bool saved_all = true;
  auto restore_caches = [&] {
    if (!saved_all)
      for (SimplexCache& cache : caches) cache = SimplexCache{};
    for (std::size_t n = 0; n < saved_count; ++n) caches[saved[n].index] = saved[n].cache;
  };
  auto evaluate = [&](std::size_t i, std::size_t j, DistanceResult<S>& into) {
    SimplexCache* cache = caches.empty() ? nullptr : &caches[i * b.size() + j];
    if (cache) {
      if (saved_count < kStackPairs)
        saved[saved_count++] = {i * b.size() + j, *cache};
      else
        saved_all = false;
    }
    ++out.pairs_evaluated;
    if (a.at_origin(i) && b.at_origin(j)) {
      detail::distance_with_valid_poses(a.piece(i).shape, pose_a, b.piece(j).shape, pose_b,
                                        piece_options, cache, into, defect2_a);
      out.support_calls += into.support_calls;
      out.subalgorithm_runs += into.subalgorithm_runs;
      return true;  // near points in the world
    }
    // Pieces placed relative to A's position, from the poses rounded there: p_B − p_A by an ulp
    // of itself, and a composed offset's R·t_offset + t by ulps of both translations, its
    // R·R_offset moving the piece's points by ulps of their local size (|z̄| plus the extent, which
    // D(K) holds). Those lengths enter the query's working magnitude, so that its bound covers the
    // pieces posed exactly.
    const Pose<S>* piece_pose_a = &frame_a;
    const Pose<S>* piece_pose_b = &frame_b;
    S placement = S(2) * frame_b.translation.cwiseAbs().sum();
    const auto composed = [&](const Pose<S>& frame, const Piece<S>& piece, Pose<S>& placed) {
      placed = frame.compose(piece.offset);
      placement += S(2) * (piece.offset.translation.cwiseAbs().sum() +
                           core_center(piece.shape).cwiseAbs().sum());
      return &placed;
    };
    if (!a.at_origin(i)) piece_pose_a = composed(frame_a, a.piece(i), placed_a);
    if (!b.at_origin(j)) piece_pose_b = composed(frame_b, b.piece(j), placed_b);
    detail::distance_with_valid_poses(a.piece(i).shape, *piece_pose_a, b.piece(j).shape,
                                      *piece_pose_b, piece_options, cache, into,
                                      detail::rotation_defect2(piece_pose_a->rotation), placement);
    out.support_calls += into.support_calls;
    out.subalgorithm_runs += into.subalgorithm_runs;
    return false;  // near points relative to A's position
  };

  // Start with the pair whose spheres are nearest: it usually holds the answer, so the bound
  // that prunes the others is tight from the start (and no list needs sorting or allocating).
  std::size_t first_i = 0, first_j = 0;
  S first_gap = std::numeric_limits<S>::infinity();
  if (pair_count > 1) {
    for (std::size_t i = 0; i < a.size(); ++i)
      for (std::size_t j = 0; j < b.size(); ++j) {
        const S gap = compute_gap(i, j);
        if (keep_gaps) gaps[i * b.size() + j] = gap;
        if (gap < first_gap || (i == 0 && j == 0)) {
          first_gap = gap;
          first_i = i;
          first_j = j;
        }
      }
  }
  nearest_in_world = evaluate(first_i, first_j, out.nearest);
  out.piece_a = int(first_i);
  out.piece_b = int(first_j);
  if (out.nearest.status == Status::invalid_input) return out;
  // The lowest distance any evaluated pair's interval [d − e, d + e] allows. The objects'
  // distance is the least true distance over the pairs, so the answer's bound must reach down to
  // it: the nearest computed distance is not always the nearest pair when another pair's bound
  // is wide (a huge flat piece: e ≈ √ε·D), and reporting the first with its own tight bound was
  // wrong by up to the other's width (found by fuzz_engine: 3.7e-4 ± 1.8e-15 where a pair with
  // 2.2e-2 ± 2.2e-2 was truly 2.8e-5 away). Pairs proven beyond the best, or pruned, lie above
  // every evaluated pair's lower end and cannot lower it.
  // A beyond-cutoff answer's lower end is its distance itself (DistanceResult::distance).
  const auto lower_end = [](const DistanceResult<S>& r) {
    return r.beyond_cutoff() ? r.distance : r.distance - r.error_bound;
  };
  S lowest = lower_end(out.nearest);

  const bool want_penetration = options.penetration_bound;
  for (std::size_t i = 0; i < a.size(); ++i) {
    for (std::size_t j = 0; j < b.size(); ++j) {
      if (i == first_i && j == first_j) continue;
      const S gap = sphere_gap(i, j) - gap_roundoff;
      const S best = out.nearest.distance;
      // With intersecting pieces, keep evaluating pairs that may also intersect: the object's
      // penetration bound is the largest d⁻ among them (paper, Section VIII).
      // NaN-safe on purpose: a gap that is not a number (a piece whose bounding sphere
      // overflows) proves nothing, and the pair is evaluated (and refused, if it must be).
      const bool may_matter =
          !(gap >= best + out.nearest.error_bound) || (want_penetration && best == 0 && gap <= 0);
      if (!may_matter || gap > options.distance_cutoff) {
        // Pruned by the cutoff, the pair is proven no nearer than its gap, which may still lie
        // below the best answer's lower end: the objects' distance is the least over pairs.
        if (may_matter) lowest = std::min(lowest, gap);
        ++out.pairs_pruned;
        continue;
      }
      // Only a distance below the best can change the answer: past it the piece pair may stop
      // as soon as a support plane proves so, often at its first support point.
      piece_options.distance_cutoff = std::min(options.distance_cutoff, best);
      DistanceResult<S> r;
      const bool r_in_world = evaluate(i, j, r);
      if (r.status == Status::invalid_input) {
        out.nearest = r;
        restore_caches();
        return out;
      }
      if (r.beyond_cutoff() && !(options.distance_cutoff <= best)) {
        ++out.pairs_stopped_at_best;
        continue;  // proven farther than the best: it cannot be the answer
      }
      lowest = std::min(lowest, lower_end(r));
      const S previous_penetration =
          out.nearest.has_penetration_bound ? out.nearest.penetration_bound : S(0);
      if (r.distance < best || (r.distance == best && r.status == Status::intersecting &&
                                out.nearest.status != Status::intersecting)) {
        out.nearest = r;
        nearest_in_world = r_in_world;
        out.piece_a = int(i);
        out.piece_b = int(j);
      }
      if (want_penetration && out.nearest.status == Status::intersecting) {
        const S candidate = r.has_penetration_bound ? r.penetration_bound : S(0);
        out.nearest.has_penetration_bound = true;
        out.nearest.penetration_bound =
            std::max({previous_penetration, candidate, out.nearest.penetration_bound});
      }
    }
  }

  // Only another pair's lower end below the answer's own widens it (a single pair's answer
  // stays exactly the single query's). Distances are ≥ 0: a lower end below 0 widens the bound
  // only to the distance itself. Two ulps cover the rounding of d − e and of this difference.
  if (out.nearest.beyond_cutoff()) {
    // Beyond the cutoff the answer is the objects' certified lower bound, the least over the
    // pairs', with the interval up to the best pair's upper end (two ulps for the roundings).
    if (lowest < out.nearest.distance) {
      const S upper = out.nearest.distance + out.nearest.error_bound;
      const S floor = std::max(S(0), lowest);
      out.nearest.distance = floor;
      out.nearest.error_bound =
          (upper - floor) + 2 * std::numeric_limits<S>::epsilon() * (upper + floor);
      if (!(floor > 0)) {  // no longer proven apart: too close to tell from touching
        out.nearest.status = Status::intersecting;
        out.nearest.termination = Termination::numerical_limit;
      }
    }
  } else if (lowest < out.nearest.distance - out.nearest.error_bound) {
    const S floor = std::max(S(0), lowest);
    const S reach = (out.nearest.distance - floor) +
                    2 * std::numeric_limits<S>::epsilon() * (out.nearest.distance + floor);
    out.nearest.error_bound = std::max(out.nearest.error_bound, reach);
  }

  if (options.gradient && out.nearest.status == Status::separated && !out.nearest.beyond_cutoff()) {
    const Pose<S>& origin_a = nearest_in_world ? pose_a : frame_a;
    const Pose<S>& origin_b = nearest_in_world ? pose_b : frame_b;
    distance_gradient(out.nearest.point_a, out.nearest.point_b, out.nearest.normal,
                      origin_a.translation, origin_b.translation, out.nearest.gradient_a,
                      out.nearest.gradient_b);
    out.nearest.has_gradient = true;
  }
  // Near points back from A's position to the world.
  if (out.nearest.has_near_points) {
    if (!nearest_in_world) {
      out.nearest.point_a += pose_a.translation;
      out.nearest.point_b += pose_a.translation;
    }
    // Beside a position near the largest number a near point can overflow (found by fuzz_engine:
    // compounds at 1.8e308 answered near points of inf): refuse, as the single-shape query does,
    // rather than answer a number that is not one.
    if (options.near_points &&
        !(out.nearest.point_a.allFinite() && out.nearest.point_b.allFinite())) {
      detail::set_invalid(out.nearest, "the answer is too large to represent in this precision");
      restore_caches();
      return out;
    }
  }
  // The gradient's moments are positions crossed with the normal: with pieces placed near the
  // largest number they overflow too (found by fuzz_engine: a piece offset of 1.8e308).
  if (out.nearest.has_gradient &&
      !(out.nearest.gradient_a.allFinite() && out.nearest.gradient_b.allFinite())) {
    detail::set_invalid(out.nearest, "the answer is too large to represent in this precision");
    restore_caches();
    return out;
  }
  if (!options.near_points) out.nearest.has_near_points = false;
  return out;
}

template class Compound<double>;
template class Compound<float>;
template CompoundResult<double> distance(const Compound<double>&, const Pose<double>&,
                                         const Compound<double>&, const Pose<double>&,
                                         const DistanceOptions<double>&, std::span<SimplexCache>);
template CompoundResult<float> distance(const Compound<float>&, const Pose<float>&,
                                        const Compound<float>&, const Pose<float>&,
                                        const DistanceOptions<float>&, std::span<SimplexCache>);

}  // namespace nearpoint
