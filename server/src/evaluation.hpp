// SPDX-License-Identifier: Apache-2.0
// One object pair of one update through the engine (the broad phase, in incremental.cpp, decided
// that it needs to be).
#pragma once

#include <span>

#include "nearpoint/server/scene_service.hpp"

namespace nearpoint::server {

/// The report's status for an engine result: the engine's verdict word for word (touching
/// included), beyond_cutoff for a separated result proven beyond the cutoff, engine_error for
/// unusable input.
model::PairStatus pair_status(const DistanceResult<double>& result);

/// Evaluates `pair` of `scene` at `poses` (world frame, scene object order) into `out`.
/// `caches` is the pair's warm-start slice (read and updated), or empty for a cold start.
void evaluate_pair(const SceneDefinition& scene, const ScenePair& pair,
                   const std::vector<Pose<double>>& poses, const ResolvedOptions& options,
                   std::span<SimplexCache> caches, model::PairReport& out);

}  // namespace nearpoint::server
