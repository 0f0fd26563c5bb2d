#include "evaluation.hpp"

#include <algorithm>
#include <cmath>

namespace nearpoint::server {

void evaluate_pair(const SceneDefinition& scene, const ScenePair& pair,
                   const std::vector<Pose<double>>& poses, const ResolvedOptions& options,
                   std::span<SimplexCache> caches, PairReport& out) {
  out = PairReport{};
  out.object_a = pair.object_a;
  out.object_b = pair.object_b;
  const StoredGeometry& geometry_a = *scene.objects[pair.object_a].geometry;
  const StoredGeometry& geometry_b = *scene.objects[pair.object_b].geometry;
  const Pose<double>& pose_a = poses[pair.object_a];
  const Pose<double>& pose_b = poses[pair.object_b];

  const CompoundResult<double> result =
      distance(geometry_a.compound, pose_a, geometry_b.compound, pose_b, options.engine,
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
      out.status = PairStatus::engine_error;
      out.engine_message = nearest.message ? nearest.message : "invalid input";
      return;
    case Status::iteration_limit:
      out.status = PairStatus::iteration_limit;
      break;
    case Status::intersecting:
      out.status = PairStatus::intersecting;
      break;
    case Status::separated:
      out.status = nearest.beyond_cutoff() ? PairStatus::beyond_cutoff : PairStatus::separated;
      break;
  }
  out.distance_lower_bound = std::max(0.0, nearest.distance - nearest.error_bound);
  if (out.status == PairStatus::beyond_cutoff) return;  // only the lower bound is meaningful

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
}

}  // namespace nearpoint::server
