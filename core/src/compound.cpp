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
#include <memory>

namespace nearpoint {

namespace {
// A bound on ‖R‖₂ from the rotation's squared defect ‖RᵀR − I‖_F²: ‖R‖₂² = λ_max(RᵀR) ≤
// 1 + ‖RᵀR − I‖_F, and √(1 + x) ≤ 1 + x/2 (8ε more for the defect's own rounding). A piece is
// posed by R exactly as given, so its bounding sphere's radius grows by this factor: a segment
// 5e173 long under rotations with defects of 1e-8 had a bounding-sphere gap of +1.3e165, and the
// piece that held the answer was pruned (found by fuzz_engine).
// A rotation computed in the working precision (defect ≤ 8ε) takes the branch without the square
// root, which cost a measurable part of a warm compound query.
template <class S>
S stretch_bound(S defect2) {
  constexpr S tight = S(8) * std::numeric_limits<S>::epsilon();
  if (defect2 <= tight * tight) [[likely]]
    return S(1) + tight;  // √defect2 ≤ tight
  using std::sqrt;
  return S(1) + (sqrt(defect2) + tight) / S(2);
}
}  // namespace

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
    radii_.push_back((core_extent(piece.shape) + piece.shape.radius) *
                         stretch_bound(detail::rotation_defect2(piece.offset.rotation)) +
                     S(8) * std::numeric_limits<S>::epsilon() *
                         (piece.offset.translation.cwiseAbs().sum() + center.cwiseAbs().sum()));
    at_origin_.push_back(piece.offset.rotation == Mat3<S>::Identity() &&
                         piece.offset.translation == Vec3<S>::Zero());
  }
  invalid_reason_ = nullptr;
}

namespace {

/// One compound query, split along its steps: the piece pairs' bounding-sphere gaps, the nearest
/// pair's evaluation, the search over the other pairs, the bound widened to every evaluated
/// pair's lower end, and the answer moved back to the world. Lives on the stack of `distance`.
template <class S>
class CompoundQuery {
 public:
  CompoundQuery(const Compound<S>& a, const Pose<S>& pose_a, const Compound<S>& b,
                const Pose<S>& pose_b, const DistanceOptions<S>& options,
                std::span<SimplexCache> caches, S defect2_a, CompoundResult<S>& out)
      : a_(a),
        b_(b),
        pose_a_(pose_a),
        pose_b_(pose_b),
        options_(options),
        caches_(caches),
        defect2_a_(defect2_a),
        out_(out) {
    // The world moved to A's position: the piece poses are composed from (R_A, 0) and
    // (R_B, p_B − p_A), as the single-shape query places B relative to A, so that objects far
    // from the origin do not round their pieces' placement to the ulps of their world coordinates
    // (two unit spheres at x ≈ 1e9, one 5e-8 nearer: composed in the world frame both sat at the
    // same rounded place and the nearer one was pruned). A translation of the whole scene changes
    // no distance; near points are moved back at the end. The object whose piece sits at its
    // origin is queried on the caller's poses themselves: exactly the single-shape query.
    stretch_a_ = stretch_bound(defect2_a);
    stretch_b_ = stretch_bound(detail::rotation_defect2(pose_b.rotation));
    frame_a_.rotation = pose_a.rotation;
    frame_b_.rotation = pose_b.rotation;
    frame_b_.translation = pose_b.translation - pose_a.translation;
    // Pieces are evaluated without the gradient (it refers to the whole objects, see finish).
    piece_options_ = options;
    piece_options_.gradient = false;
    piece_options_.near_points = options.near_points || options.gradient;
  }

  void run() {
    const auto [first_i, first_j] = nearest_spheres();
    nearest_in_world_ = evaluate(first_i, first_j, out_.nearest);
    out_.piece_a = int(first_i);
    out_.piece_b = int(first_j);
    if (out_.nearest.status == Status::invalid_input) return;
    if (!search_other_pairs(first_i, first_j)) return;
    widen_to_lowest();
    finish();
  }

 private:
  // For the usual few pieces the gaps and the caches' former contents are kept on the stack.
  static constexpr std::size_t kStackPairs = 64;

  std::size_t pair_count() const { return a_.size() * b_.size(); }
  bool keep_gaps() const { return pair_count() <= kStackPairs; }

  // The lowest distance an evaluated pair's interval [d − e, d + e] allows (a beyond-cutoff
  // answer's lower end is its distance itself: DistanceResult::distance).
  static S lower_end(const DistanceResult<S>& r) {
    return r.beyond_cutoff() ? r.distance : r.distance - r.error_bound;
  }

  // Lower bound on a piece pair's distance from its bounding spheres (eq. 2–4 need every pair
  // only in principle: a pair whose spheres are farther apart than the best distance cannot win).
  // The computed gap errs by a few ulps of the magnitudes that enter it, kept in gap_roundoff_:
  // pairs are pruned only when it exceeds the best distance by more than that and more than the
  // best's own error bound (so a pair is skipped only when it is certainly not nearer).
  S compute_gap(std::size_t i, std::size_t j) {
    const Vec3<S> ca = detail::apply_pose(frame_a_, a_.sphere_center(i));
    const Vec3<S> cb = detail::apply_pose(frame_b_, b_.sphere_center(j));
    const S radius_a = a_.sphere_radius(i) * stretch_a_,
            radius_b = b_.sphere_radius(j) * stretch_b_;
    const S magnitude = ca.cwiseAbs().sum() + cb.cwiseAbs().sum() + radius_a + radius_b +
                        frame_b_.translation.cwiseAbs().sum() +
                        a_.sphere_center(i).cwiseAbs().sum() + b_.sphere_center(j).cwiseAbs().sum();
    gap_roundoff_ = std::max(gap_roundoff_, S(16) * std::numeric_limits<S>::epsilon() * magnitude);
    // Scaled before squaring: centres beyond √max apart overflowed |cb − ca|² to inf, and an
    // infinite gap pruned a pair that was in fact the nearest (found by fuzz_engine in float).
    return (cb - ca).stableNorm() - radius_a - radius_b;
  }
  S sphere_gap(std::size_t i, std::size_t j) {
    return keep_gaps() ? gaps_[i * b_.size() + j] : compute_gap(i, j);
  }

  // The pair whose spheres are nearest: it usually holds the answer, so the bound that prunes
  // the others is tight from the start (and no list needs sorting or allocating).
  std::pair<std::size_t, std::size_t> nearest_spheres() {
    std::size_t first_i = 0, first_j = 0;
    if (pair_count() <= 1) return {first_i, first_j};
    S first_gap = std::numeric_limits<S>::infinity();
    for (std::size_t i = 0; i < a_.size(); ++i)
      for (std::size_t j = 0; j < b_.size(); ++j) {
        const S gap = compute_gap(i, j);
        if (keep_gaps()) gaps_[i * b_.size() + j] = gap;
        if (gap < first_gap || (i == 0 && j == 0)) {
          first_gap = gap;
          first_i = i;
          first_j = j;
        }
      }
    return {first_i, first_j};
  }

  // A refused query leaves the caches as they were: the evaluated pairs' former contents are
  // kept (beyond kStackPairs evaluated pairs, rare since pruning keeps few, those caches are left
  // as cold starts).
  void save_cache(std::size_t index) {
    if (saved_count_ < kStackPairs)
      std::construct_at(&saved_[saved_count_++].saved, Saved{index, caches_[index]});
    else
      saved_all_ = false;
  }
  void restore_caches() {
    if (!saved_all_)
      for (SimplexCache& cache : caches_) cache = SimplexCache{};
    for (std::size_t n = 0; n < saved_count_; ++n)
      caches_[saved_[n].saved.index] = saved_[n].saved.cache;
  }

  // The lengths whose ulps composing a piece's pose rounds by: |t_offset| and |z̄| (1-norms).
  static S placement_size(const Piece<S>& piece) {
    return piece.offset.translation.cwiseAbs().sum() + core_center(piece.shape).cwiseAbs().sum();
  }

  // Pair (i, j) into `into`, written in place (a returned result was a 400-byte copy per query).
  // Returns whether its near points are in the world (a pair of pieces at their objects' origins,
  // queried on the caller's poses) rather than relative to A's position (composed pieces).
  bool evaluate(std::size_t i, std::size_t j, DistanceResult<S>& into) {
    const std::size_t index = i * b_.size() + j;
    SimplexCache* cache = caches_.empty() ? nullptr : &caches_[index];
    if (cache) save_cache(index);
    ++out_.pairs_evaluated;
    if (a_.at_origin(i) && b_.at_origin(j)) {
      detail::distance_with_valid_poses(a_.piece(i).shape, pose_a_, b_.piece(j).shape, pose_b_,
                                        piece_options_, cache, into, defect2_a_);
      count_work(into);
      return true;
    }
    // Pieces placed relative to A's position, from the poses rounded there: p_B − p_A by an ulp
    // of itself, and a composed offset's R·t_offset + t by ulps of both translations, its
    // R·R_offset moving the piece's points by ulps of their local size (|z̄| plus the extent,
    // which D(K) holds). Those lengths enter the query's working magnitude, so that its bound
    // covers the pieces posed exactly. Poses composed from validated ones are rigid to roundoff:
    // no need to check them again.
    const Pose<S>* piece_pose_a = &frame_a_;
    const Pose<S>* piece_pose_b = &frame_b_;
    S placement = S(2) * frame_b_.translation.cwiseAbs().sum();
    const auto composed = [&](const Pose<S>& frame, const Piece<S>& piece, Pose<S>& placed) {
      placed = frame.compose(piece.offset);
      // Among subnormals the composition rounds by an absolute half unit per operation, not by
      // ulps of its terms (float pieces 3e-45 from their origins came out 3.1e-45 off against
      // a bound of 2.8e-45; found by fuzz_engine): denorm_min/ε, whose few ulps cover it.
      placement += S(2) * placement_size(piece) +
                   std::numeric_limits<S>::denorm_min() / std::numeric_limits<S>::epsilon();
      return &placed;
    };
    if (!a_.at_origin(i)) piece_pose_a = composed(frame_a_, a_.piece(i), placed_a_);
    if (!b_.at_origin(j)) piece_pose_b = composed(frame_b_, b_.piece(j), placed_b_);
    detail::distance_with_valid_poses(a_.piece(i).shape, *piece_pose_a, b_.piece(j).shape,
                                      *piece_pose_b, piece_options_, cache, into,
                                      detail::rotation_defect2(piece_pose_a->rotation), placement);
    count_work(into);
    return false;
  }
  void count_work(const DistanceResult<S>& r) {
    out_.support_calls += r.support_calls;
    out_.subalgorithm_runs += r.subalgorithm_runs;
  }

  // Every pair but the first, pruned by its spheres' gap or stopped once proven beyond the best.
  // Returns false when a pair was refused (the answer is then that refusal).
  bool search_other_pairs(std::size_t first_i, std::size_t first_j) {
    // The objects' distance is the least true distance over the pairs, so the answer's bound must
    // reach down to the lowest lower end: the nearest computed distance is not always the nearest
    // pair when another pair's bound is wide (a huge flat piece: e ≈ √ε·D), and reporting the
    // first with its own tight bound was wrong by up to the other's width (found by fuzz_engine:
    // 3.7e-4 ± 1.8e-15 where a pair with 2.2e-2 ± 2.2e-2 was truly 2.8e-5 away). Pairs proven
    // beyond the best, or pruned, lie above every evaluated pair's lower end and cannot lower it.
    lowest_ = lower_end(out_.nearest);
    const bool want_penetration = options_.penetration_bound;
    // With the depth: every pair that may intersect is evaluated, and the answer is the deepest
    // (the least signed distance, as Drake answers for geometry sets).
    const bool want_depth = options_.penetration_depth;
    if (want_depth) note_signed_distance(out_.nearest);
    for (std::size_t i = 0; i < a_.size(); ++i) {
      for (std::size_t j = 0; j < b_.size(); ++j) {
        if (i == first_i && j == first_j) continue;
        const S gap = sphere_gap(i, j) - gap_roundoff_;
        const S best = out_.nearest.distance;
        // With intersecting pieces, keep evaluating pairs that may also intersect: the object's
        // penetration bound is the largest d⁻ among them (paper, Section VIII).
        // NaN-safe on purpose: a gap that is not a number (a piece whose bounding sphere
        // overflows) proves nothing, and the pair is evaluated (and refused, if it must be).
        const bool may_matter = !(gap >= best + out_.nearest.error_bound) ||
                                ((want_penetration || want_depth) && best == 0 && gap <= 0);
        if ((!may_matter || gap > options_.distance_cutoff) && !may_be_refused(gap)) {
          // Pruned by the cutoff, the pair is proven no nearer than its gap, which may still lie
          // below the best answer's lower end: the objects' distance is the least over pairs.
          if (may_matter) lowest_ = std::min(lowest_, gap);
          ++out_.pairs_pruned;
          continue;
        }
        // Only a distance below the best can change the answer: past it the piece pair may stop
        // as soon as a support plane proves so, often at its first support point.
        piece_options_.distance_cutoff = std::min(options_.distance_cutoff, best);
        DistanceResult<S> r;
        const bool r_in_world = evaluate(i, j, r);
        // Refused pairs refuse the objects' query. Every pair that could be refused is evaluated
        // (may_be_refused), whatever the best so far: whether a query is refused does not depend
        // on the warm start or on the order of the pairs.
        if (r.status == Status::invalid_input) {
          out_.nearest = r;
          restore_caches();
          return false;
        }
        if (r.beyond_cutoff() && !(options_.distance_cutoff <= best)) {
          ++out_.pairs_stopped_at_best;
          continue;  // proven farther than the best: it cannot be the answer
        }
        lowest_ = std::min(lowest_, lower_end(r));
        const S previous_penetration =
            out_.nearest.has_penetration_bound ? out_.nearest.penetration_bound : S(0);
        if (want_depth) note_signed_distance(r);
        const bool deeper = want_depth && r.in_contact() && out_.nearest.in_contact() &&
                            r.has_signed_distance && out_.nearest.has_signed_distance &&
                            r.signed_distance < out_.nearest.signed_distance;
        // At equal distance (0) a proven overlap outranks a touch, and a touch a pair that was
        // not decided (so that the objects' verdict is the strongest one proven).
        if (r.distance < best || deeper ||
            (r.distance == best && contact_rank(r.status) > contact_rank(out_.nearest.status))) {
          out_.nearest = r;
          nearest_in_world_ = r_in_world;
          out_.piece_a = int(i);
          out_.piece_b = int(j);
        }
        if (want_penetration && out_.nearest.in_contact()) {
          const S candidate = r.has_penetration_bound ? r.penetration_bound : S(0);
          out_.nearest.has_penetration_bound = true;
          out_.nearest.penetration_bound =
              std::max({previous_penetration, candidate, out_.nearest.penetration_bound});
        }
      }
    }
    return true;
  }

  // Whether a pair with this sphere gap could be refused, so that it must be evaluated even
  // when its gap prunes it: a warm start that made the best distance smaller (or larger) must not
  // change which pairs are looked at for refusal (found by fuzz_engine: a float compound refused
  // warm and answered cold). A pair is refused when its D(K) is below 2^-kMeasurableSpread of its
  // working magnitude M; M − D(K) is the placement that evaluate() passes (2|p_B − p_A| and twice
  // each composed piece's |t_offset| + |z̄|), the centroids and relative translation (without the
  // origin shift) and the compensation of far centroids, all within the spheres' magnitudes
  // (gap_roundoff_ / 16ε) plus twice the placement. D(K) is at least the pair's distance, which
  // is at least the gap: a gap above that fraction of those lengths cannot be refused. A working
  // magnitude near the largest number (refused as too large) is evaluated too.
  bool may_be_refused(S gap) {
    constexpr S epsilon = std::numeric_limits<S>::epsilon();
    if (!(placement_sizes_ >= 0)) {
      const auto largest = [](const Compound<S>& c) {
        S size = 0;
        for (std::size_t i = 0; i < c.size(); ++i)
          size = std::max(size, placement_size(c.piece(i)));
        return size;
      };
      placement_sizes_ =
          S(4) * (frame_b_.translation.cwiseAbs().sum() + largest(a_) + largest(b_)) +
          S(4) * std::numeric_limits<S>::denorm_min() / epsilon;
    }
    const S lengths = S(2) * placement_sizes_ + gap_roundoff_ / (S(16) * epsilon);
    if (!(lengths <= std::numeric_limits<S>::max() / S(1024))) return true;
    // 2^-(spread − 2): a margin of 4 for the rounding of D(K), M and the gap.
    return !(gap > std::ldexp(lengths, -(detail::kMeasurableSpread<S> - 2)));
  }

  static int contact_rank(Status status) {
    return status == Status::intersecting ? 2 : status == Status::touching ? 1 : 0;
  }

  // The least signed distance over the evaluated pairs, bracketed: each end is the least of the
  // pairs' ends. (Pairs pruned or proven beyond the best are apart, φ > 0, and cannot lower it
  // once a pair intersects.)
  void note_signed_distance(const DistanceResult<S>& r) {
    if (!r.has_signed_distance) return;
    signed_lower_ = std::min(signed_lower_, r.signed_distance_lower);
    signed_upper_ = std::min(signed_upper_, r.signed_distance_upper);
  }

  // Only another pair's lower end below the answer's own widens it (a single pair's answer
  // stays exactly the single query's). Distances are ≥ 0: a lower end below 0 widens the bound
  // only to the distance itself. Two ulps cover the rounding of d − e and of this difference.
  void widen_to_lowest() {
    DistanceResult<S>& nearest = out_.nearest;
    constexpr S two_ulps = 2 * std::numeric_limits<S>::epsilon();
    if (nearest.beyond_cutoff()) {
      // Beyond the cutoff the answer is the objects' certified lower bound, the least over the
      // pairs', with the interval up to the best pair's upper end.
      if (!(lowest_ < nearest.distance)) return;
      const S upper = nearest.distance + nearest.error_bound;
      const S floor = std::max(S(0), lowest_);
      nearest.distance = floor;
      nearest.error_bound = (upper - floor) + two_ulps * (upper + floor);
      if (!(floor > 0)) {  // no longer proven apart: too close to tell from touching
        nearest.status = Status::touching;
        nearest.termination = Termination::numerical_limit;
      }
    } else if (lowest_ < nearest.distance - nearest.error_bound) {
      const S floor = std::max(S(0), lowest_);
      const S reach = (nearest.distance - floor) + two_ulps * (nearest.distance + floor);
      nearest.error_bound = std::max(nearest.error_bound, reach);
    }
  }

  // The gradient of the objects' distance, and the near points back from A's position to the
  // world; an answer that overflows there is refused, as the single-shape query does.
  void finish() {
    DistanceResult<S>& nearest = out_.nearest;
    if (options_.penetration_depth && nearest.has_signed_distance) {
      if (nearest.in_contact()) {
        // The deepest pair's depth, bracketed over all pairs (see CompoundResult).
        nearest.signed_distance_lower = std::min(nearest.signed_distance_lower, signed_lower_);
        nearest.signed_distance_upper = std::min(nearest.signed_distance_upper, signed_upper_);
        nearest.signed_distance = std::clamp(nearest.signed_distance, nearest.signed_distance_lower,
                                             nearest.signed_distance_upper);
        nearest.depth_lower = std::max(S(0), -nearest.signed_distance_upper);
        nearest.depth_upper = std::max(S(0), -nearest.signed_distance_lower);
        nearest.depth = std::clamp(std::max(S(0), -nearest.signed_distance), nearest.depth_lower,
                                   nearest.depth_upper);
        if (nearest.signed_distance_upper < 0) nearest.status = Status::intersecting;
      } else if (nearest.status == Status::separated) {
        // The objects' distance with its (possibly widened) bound.
        nearest.signed_distance = nearest.distance;
        nearest.signed_distance_lower = std::max(S(0), nearest.distance - nearest.error_bound);
        nearest.signed_distance_upper = nearest.distance + nearest.error_bound;
      }
      const Pose<S>& origin_a = nearest_in_world_ ? pose_a_ : frame_a_;
      const Pose<S>& origin_b = nearest_in_world_ ? pose_b_ : frame_b_;
      if (options_.gradient && nearest.in_contact() && nearest.has_penetration_depth) {
        distance_gradient(nearest.depth_point_a, nearest.depth_point_b, nearest.depth_direction,
                          origin_a.translation, origin_b.translation, nearest.gradient_a,
                          nearest.gradient_b);
        nearest.has_gradient = true;
      }
      if (!nearest_in_world_) {
        nearest.depth_point_a += pose_a_.translation;
        nearest.depth_point_b += pose_a_.translation;
      }
    }
    if (options_.gradient && nearest.status == Status::separated && !nearest.beyond_cutoff()) {
      const Pose<S>& origin_a = nearest_in_world_ ? pose_a_ : frame_a_;
      const Pose<S>& origin_b = nearest_in_world_ ? pose_b_ : frame_b_;
      distance_gradient(nearest.point_a, nearest.point_b, nearest.normal, origin_a.translation,
                        origin_b.translation, nearest.gradient_a, nearest.gradient_b);
      nearest.has_gradient = true;
    }
    if (nearest.has_near_points && !nearest_in_world_) {
      nearest.point_a += pose_a_.translation;
      nearest.point_b += pose_a_.translation;
    }
    // Beside a position near the largest number a near point can overflow (found by fuzz_engine:
    // compounds at 1.8e308 answered near points of inf); the gradient's moments are positions
    // crossed with the normal and overflow too (a piece offset of 1.8e308).
    const bool points_overflow = nearest.has_near_points && options_.near_points &&
                                 !(nearest.point_a.allFinite() && nearest.point_b.allFinite());
    const bool gradient_overflows =
        nearest.has_gradient && !(nearest.gradient_a.allFinite() && nearest.gradient_b.allFinite());
    if (points_overflow || gradient_overflows) {
      detail::set_invalid(nearest, "the answer is too large to represent in this precision");
      restore_caches();
      return;
    }
    if (!options_.near_points) nearest.has_near_points = false;
  }

  struct Saved {
    std::size_t index;
    SimplexCache cache;
  };
  /// Storage for one Saved, left uninitialised: entries [0, saved_count_) are constructed by
  /// save_cache before anything reads them. Default-initialising all kStackPairs of them (3 kB,
  /// SimplexCache's member initialisers) cost every query more than its usual one or two saves:
  /// ~40 % of distance()'s own time on 20–100-vertex polytopes with warm starts.
  union SavedSlot {
    SavedSlot() {}
    Saved saved;
  };

  const Compound<S>& a_;
  const Compound<S>& b_;
  const Pose<S>& pose_a_;
  const Pose<S>& pose_b_;
  const DistanceOptions<S>& options_;
  std::span<SimplexCache> caches_;
  const S defect2_a_;  // ‖R_AᵀR_A − I‖_F², for pieces queried on the caller's poses
  CompoundResult<S>& out_;
  Pose<S> frame_a_, frame_b_;    // the objects' poses with the world moved to A's position
  Pose<S> placed_a_, placed_b_;  // composed piece poses (storage for evaluate)
  DistanceOptions<S> piece_options_;
  bool nearest_in_world_ = false;  // the frame of the best answer's near points
  S gap_roundoff_ = 0;
  S placement_sizes_ = -1;  // computed by may_be_refused when first needed
  S lowest_ = 0;
  S stretch_a_ = 1, stretch_b_ = 1;  // bounds on ‖R_A‖₂, ‖R_B‖₂ (stretch_bound)
  S signed_lower_ = std::numeric_limits<S>::infinity();
  S signed_upper_ = std::numeric_limits<S>::infinity();
  S gaps_[kStackPairs];
  SavedSlot saved_[kStackPairs];
  std::size_t saved_count_ = 0;
  bool saved_all_ = true;
};

}  // namespace

template <class S>
CompoundResult<S> distance(const Compound<S>& a, const Pose<S>& pose_a, const Compound<S>& b,
                           const Pose<S>& pose_b, const DistanceOptions<S>& options,
                           std::span<SimplexCache> caches) {
  CompoundResult<S> out;
  const char* why = a.invalid_reason() ? a.invalid_reason() : b.invalid_reason();
  S defect2_a = 0;
  if (!why) why = detail::invalid_poses_reason(pose_a, pose_b, &defect2_a);
  if (!why && !caches.empty() && caches.size() != a.size() * b.size())
    why = "compound query: caches must be empty or hold one cache per piece pair";
  if (why) {
    detail::set_invalid(out.nearest, why);
    return out;
  }
  CompoundQuery<S>(a, pose_a, b, pose_b, options, caches, defect2_a, out).run();
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
