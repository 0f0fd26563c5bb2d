// SPDX-License-Identifier: Apache-2.0
// Only what changed causes work: which pairs of one evaluation reach the engine.
//
// A pose stream keeps the poses, options and pair results of its previous evaluation. A pair of
// two objects whose poses did not change (bitwise) under the same options keeps its previous
// result ("unmoved"); a pair involving a moved object is handed to the engine unless the broad
// phase proves it beyond the query's cutoff ("pruned", reported BEYOND_CUTOFF with the proven
// lower bound); the rest are "evaluated". A unary query is a stream's first evaluation: every
// object counts as moved.
#pragma once

#include <cstdint>
#include <vector>

#include "broad_phase.hpp"
#include "nearpoint/server/scene_service.hpp"
#include "thresholds.hpp"

namespace nearpoint::server {

/// The state one pose stream carries from one evaluation to the next. Read and written only by
/// the stream's single running evaluation.
struct IncrementalState {
  /// True once `poses`, `options` and `pairs` hold a finished evaluation.
  bool valid = false;
  std::vector<Pose<double>> poses;
  ResolvedOptions options;
  /// The latest result of every selected pair, in the scene's pair order, except the pairs listed
  /// in `pruned_pairs`: those were pruned since and their entries are written (from
  /// `pruned_bound`) only when a report shows them, so that a moved object's far partners cost a
  /// double each per update, not a 250-byte PairReport.
  std::vector<model::PairReport> pairs;
  std::vector<std::uint32_t> pruned_pairs;
  /// Per pair: whether it is in `pruned_pairs` (listed once however often it is pruned), and the
  /// boxes' gap when its entry is still to be written, else NaN.
  std::vector<char> pruned_listed;
  std::vector<double> pruned_bound;
  SweepAndPrune broad_phase;
  /// The pairs whose latest result is `within_cutoff`, unordered, and each pair's position in
  /// that list (kNotNear: absent). Kept up to date as results change, so that a within-cutoff
  /// report costs the near pairs, not the scene.
  static constexpr std::uint32_t kNotNear = 0xFFFFFFFFu;
  std::vector<std::uint32_t> near_pairs;
  std::vector<std::uint32_t> near_position;
  /// REPORT_MODE_CHANGED's baseline: each pair's status and distance as this stream last
  /// reported them. Valid only while every report since the baseline was taken was a changed
  /// one (another mode's report shows the client other values: the next changed report then
  /// carries every pair).
  bool sent_valid = false;
  std::vector<model::PairStatus> sent_status;
  std::vector<double> sent_distance;
  /// The stream's thresholds (null: none) and, per watch, whether its pair is inside.
  std::shared_ptr<const WatchSet> watches;
  std::vector<char> inside;
  /// With watches: the pairs the latest plan pruned (their watches see the boxes' gap).
  std::vector<std::uint32_t> pruned_now;
  // Scratch space, kept to avoid allocating per update.
  std::vector<char> moved;
  std::vector<std::uint32_t> near_stamp;
  std::uint32_t stamp = 0;
};

/// Whether REPORT_MODE_WITHIN_CUTOFF reports `pair`: not BEYOND_CUTOFF, and not SEPARATED by more
/// than `cutoff`.
bool within_cutoff(const model::PairReport& pair, double cutoff);

/// Fills the scene's pair index (each object's pairs, `SceneDefinition::object_pairs`).
void index_object_pairs(SceneDefinition& scene);

/// Plans the evaluation of `scene` at `poses` under `options`: updates the broad phase, writes the
/// reports of pruned and unmoved pairs into `state.pairs`, lists the pairs the engine must run in
/// `evaluate` and counts all three in `counts`. No geometry beyond boxes.
void plan_evaluation(const SceneDefinition& scene, const std::vector<Pose<double>>& poses,
                     const ResolvedOptions& options, IncrementalState& state,
                     std::vector<std::uint32_t>& evaluate, model::ReportCounts& counts);

/// Records a finished evaluation as the state the next one starts from; `evaluated` are the
/// pairs the engine ran (their results now in `state.pairs`).
void finish_evaluation(std::vector<Pose<double>> poses, const ResolvedOptions& options,
                       const std::vector<std::uint32_t>& evaluated, IncrementalState& state);

/// How near a pair is, for REPORT_MODE_NEAREST_PER_OBJECT and REPORT_MODE_GLOBAL_MINIMUM:
/// INTERSECTING, TOUCHING and ENGINE_ERROR pairs rank as 0 (a failed pair is not proven far), the
/// rest by `distance`; with the depth mode, pairs in contact rank by their signed distance (the
/// deeper, the nearer). Only meaningful for pairs `within_cutoff`.
double nearness(const model::PairReport& pair);

/// The one place that selects a report's pairs from the stream's per-pair results, under
/// `options.report_mode`, in the scene's pair order (see nearpoint.v1.ReportMode): every pair's
/// latest result (all_pairs); those `within_cutoff`; each object's nearest pair among those
/// (nearest_per_object); the nearest of them (global_minimum); or those changed since the
/// stream's previous report (changed, which updates the baseline). `state_dies`: the state is
/// not used again (a query's), so its results may be moved out instead of copied.
void collect_report(const SceneDefinition& scene, IncrementalState& state,
                    const ResolvedOptions& options, bool state_dies,
                    std::vector<model::PairReport>& out);

}  // namespace nearpoint::server
