// SPDX-License-Identifier: Apache-2.0
#include "evaluation.hpp"

#include <algorithm>
#include <cmath>

namespace nearpoint::server {
namespace {

/// The report of the padded objects from that of the unpadded ones (see
/// nearpoint.v1.SceneObject.padding): for convex objects inflated by balls of radii r_A and
/// r_B, d(A ⊕ r_A, B ⊕ r_B) = (d − r_A − r_B)⁺ (the paper's eq. 5–8), and the signed distance
/// drops by the same p = r_A + r_B. The verdict follows from the padded signed distance's
/// interval as the engine's does: separated above 0, intersecting below 0 (or the cores proven
/// overlapping), touching when it contains 0.
void apply_padding(const SceneDefinition& scene, const ScenePair& pair,
                   const ResolvedOptions& options, model::PairReport& out) {
  const double p = pair.padding;
  out.distance_lower_bound = std::max(0.0, out.distance_lower_bound - p);
  if (out.status == model::PairStatus::beyond_cutoff ||
      out.status == model::PairStatus::engine_error)
    return;
  const double d = out.distance;
  if (out.status == model::PairStatus::iteration_limit) {
    out.distance = std::max(0.0, d - p);
    return;
  }
  const bool self = scene.objects[pair.object_a].body >= 0 &&
                    scene.objects[pair.object_a].body == scene.objects[pair.object_b].body;
  const double pad_a =
      self ? scene.objects[pair.object_a].self_padding : scene.objects[pair.object_a].padding;
  const bool cores_apart = out.status == model::PairStatus::separated;
  // The unpadded signed distance's interval: the engine's with depth, else the distance's.
  const double upper = out.has_signed_distance ? out.signed_distance_upper : d + out.error_bound;
  const double lower = out.has_signed_distance ? out.signed_distance_lower : d - out.error_bound;
  if (out.has_signed_distance) {
    out.signed_distance -= p;
    out.signed_distance_lower -= p;
    out.signed_distance_upper -= p;
  }
  if (out.has_penetration_depth) {
    // The padded depth is (p − φ)⁺ over the same interval; witnesses move onto the padded
    // surfaces along the direction (each towards the other object's inside).
    out.depth = std::max(0.0, -out.signed_distance);
    out.depth_lower = std::max(0.0, p - upper);
    out.depth_upper = std::max(0.0, p - lower);
    out.depth = std::clamp(out.depth, out.depth_lower, out.depth_upper);
    if (out.depth_direction.isZero() && out.has_near_points) out.depth_direction = out.normal;
    out.depth_point_a += pad_a * out.depth_direction;
    out.depth_point_b -= (p - pad_a) * out.depth_direction;
  }
  if (cores_apart && lower - p > 0) {  // the padded objects are apart, proven
    out.distance = d - p;
    if (out.has_near_points) {
      // On the padded surfaces: each point moves towards the other by its object's padding.
      out.point_a += pad_a * out.normal;
      out.point_b -= (p - pad_a) * out.normal;
    }
    return;
  }
  // The padded objects are in contact: proven overlapping when the cores overlap, proven, or
  // the padded interval lies below 0; otherwise within the bound of touching.
  out.status = out.status == model::PairStatus::intersecting || upper - p < 0
                   ? model::PairStatus::intersecting
                   : model::PairStatus::touching;
  // A touching pair's estimate stays what it is (within error_bound of the truth); overlap is 0.
  out.distance = std::max(0.0, d - p);
  out.distance_lower_bound = 0;
  // Gradients are reported for separated pairs only, unless the signed distance carries them.
  if (!out.has_signed_distance) out.has_gradient = false;
  if (options.engine.penetration_bound) {
    out.penetration_bound = cores_apart ? std::max(0.0, p - d) : out.penetration_bound + p;
    out.has_penetration_bound = true;
  }
}

model::DepthTermination depth_termination(DepthTermination termination) {
  switch (termination) {
    case DepthTermination::closed_form:
      return model::DepthTermination::closed_form;
    case DepthTermination::tolerance:
      return model::DepthTermination::tolerance;
    case DepthTermination::iteration_limit:
      return model::DepthTermination::iteration_limit;
    case DepthTermination::degenerate:
      return model::DepthTermination::degenerate;
  }
  return model::DepthTermination::unknown;
}

}  // namespace

model::PairStatus pair_status(const DistanceResult<double>& result) {
  switch (result.status) {
    case Status::invalid_input:
      return model::PairStatus::engine_error;
    case Status::iteration_limit:
      return model::PairStatus::iteration_limit;
    case Status::intersecting:
      return model::PairStatus::intersecting;
    case Status::touching:
      return model::PairStatus::touching;
    case Status::separated:
      return result.beyond_cutoff() ? model::PairStatus::beyond_cutoff
                                    : model::PairStatus::separated;
  }
  return model::PairStatus::engine_error;  // a value no engine produces
}

void evaluate_pair(const SceneDefinition& scene, const ScenePair& pair,
                   const std::vector<Pose<double>>& poses, const ResolvedOptions& options,
                   std::span<SimplexCache> caches, model::PairReport& out) {
  out = model::PairReport{};
  out.object_a = pair.object_a;
  out.object_b = pair.object_b;
  const StoredGeometry& geometry_a = *scene.objects[pair.object_a].geometry;
  const StoredGeometry& geometry_b = *scene.objects[pair.object_b].geometry;
  const Pose<double>& pose_a = poses[pair.object_a];
  const Pose<double>& pose_b = poses[pair.object_b];

  // Padding: the engine answers for the unpadded objects, under the cutoff widened by it.
  const double padding = pair.padding;
  DistanceOptions<double> engine = options.engine;
  if (padding > 0) engine.distance_cutoff += padding;
  const CompoundResult<double> result =
      distance(geometry_a.compound, pose_a, geometry_b.compound, pose_b, engine,
               options.warm_start ? caches : std::span<SimplexCache>{});
  const DistanceResult<double>& nearest = result.nearest;
  out.piece_pairs_evaluated = static_cast<std::uint32_t>(result.pairs_evaluated);
  out.piece_a = static_cast<std::uint32_t>(std::max(0, result.piece_a));
  out.piece_b = static_cast<std::uint32_t>(std::max(0, result.piece_b));
  out.iterations = static_cast<std::uint32_t>(std::max(0, nearest.iterations));
  out.warm_started = nearest.warm_started;
  out.error_bound = nearest.error_bound;
  out.status = pair_status(nearest);
  if (out.status == model::PairStatus::engine_error) {
    out.engine_message = nearest.message ? nearest.message : "invalid input";
    return;
  }
  // Beyond the cutoff the engine's distance is itself the certified lower bound.
  out.distance_lower_bound = nearest.beyond_cutoff()
                                 ? nearest.distance
                                 : std::max(0.0, nearest.distance - nearest.error_bound);
  if (out.status == model::PairStatus::beyond_cutoff) {  // only the lower bound is meaningful
    // With several piece pairs the engine's `nearest` is one of them, whose bound need not hold
    // for the others (a piece its bounding spheres put beyond the cutoff may still be nearer
    // than it): the cutoff, which every piece pair was proven beyond, is the bound for them all.
    if (result.pairs_evaluated + result.pairs_pruned > 1)
      out.distance_lower_bound = std::min(out.distance_lower_bound, engine.distance_cutoff);
    if (padding > 0) apply_padding(scene, pair, options, out);
    return;
  }

  out.distance = nearest.distance;
  if (nearest.has_near_points) {
    out.has_near_points = true;
    out.point_a = nearest.point_a;
    out.point_b = nearest.point_b;
    out.normal = nearest.normal;
  }
  if (nearest.has_penetration_bound) {
    out.has_penetration_bound = true;
    out.penetration_bound = nearest.penetration_bound;
  }
  if (nearest.has_gradient) {
    out.has_gradient = true;
    out.gradient_a = nearest.gradient_a;
    out.gradient_b = nearest.gradient_b;
  }
  if (nearest.has_signed_distance) {
    out.has_signed_distance = true;
    out.signed_distance = nearest.signed_distance;
    out.signed_distance_lower = nearest.signed_distance_lower;
    out.signed_distance_upper = nearest.signed_distance_upper;
  }
  if (nearest.has_penetration_depth) {
    out.has_penetration_depth = true;
    out.depth = nearest.depth;
    out.depth_lower = nearest.depth_lower;
    out.depth_upper = nearest.depth_upper;
    out.depth_point_a = nearest.depth_point_a;
    out.depth_point_b = nearest.depth_point_b;
    out.depth_direction = nearest.depth_direction;
    out.depth_termination = depth_termination(nearest.depth_termination);
    out.depth_iterations = static_cast<std::uint32_t>(std::max(0, nearest.depth_iterations));
  }
  if (padding > 0) apply_padding(scene, pair, options, out);
}

}  // namespace nearpoint::server
