// SPDX-License-Identifier: Apache-2.0
#include "evaluation.hpp"

#include <algorithm>
#include <cmath>

namespace nearpoint::server {
namespace {

/// The report of the padded objects from that of the unpadded ones (see
/// nearpoint.v1.SceneObject.padding): for convex objects inflated by balls of radii r_A and
/// r_B, d(A ⊕ r_A, B ⊕ r_B) = (d − r_A − r_B)⁺ (the paper's eq. 5–8), and the signed distance
/// drops by the same p = r_A + r_B.
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
  if (out.status == model::PairStatus::separated && d > p) {
    out.distance = d - p;
    if (out.has_near_points) {
      // On the padded surfaces: each point moves towards the other by its object's padding.
      const bool self = scene.objects[pair.object_a].body >= 0 &&
                        scene.objects[pair.object_a].body == scene.objects[pair.object_b].body;
      const double pad_a =
          self ? scene.objects[pair.object_a].self_padding : scene.objects[pair.object_a].padding;
      out.point_a += pad_a * out.normal;
      out.point_b -= (p - pad_a) * out.normal;
    }
    return;
  }
  // The padded objects intersect (touching included).
  const bool cores_apart = out.status == model::PairStatus::separated;
  out.status = model::PairStatus::intersecting;
  out.distance = 0;
  out.distance_lower_bound = 0;
  out.has_gradient = false;  // gradients are reported for separated pairs only
  if (options.engine.penetration_bound) {
    out.penetration_bound = cores_apart ? p - d : out.penetration_bound + p;
    out.has_penetration_bound = true;
  }
}

}  // namespace

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
  switch (nearest.status) {
    case Status::invalid_input:
      out.status = model::PairStatus::engine_error;
      out.engine_message = nearest.message ? nearest.message : "invalid input";
      return;
    case Status::iteration_limit:
      out.status = model::PairStatus::iteration_limit;
      break;
    case Status::intersecting:
    case Status::touching:  // until the wire has its own word for it
      out.status = model::PairStatus::intersecting;
      break;
    case Status::separated:
      out.status =
          nearest.beyond_cutoff() ? model::PairStatus::beyond_cutoff : model::PairStatus::separated;
      break;
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
  if (padding > 0) apply_padding(scene, pair, options, out);
}

}  // namespace nearpoint::server
