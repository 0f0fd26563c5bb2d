// SPDX-License-Identifier: Apache-2.0
#include "incremental.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace nearpoint::server {
namespace {

/// Bitwise, so that "not moved" never depends on a tolerance: a client that resends the same
/// pose gets the same answer it got, and one that nudges a pose by an ulp gets it recomputed.
bool same_pose(const Pose<double>& a, const Pose<double>& b) {
  return std::memcmp(a.rotation.data(), b.rotation.data(), sizeof(double) * 9) == 0 &&
         std::memcmp(a.translation.data(), b.translation.data(), sizeof(double) * 3) == 0;
}

/// Every field of ResolvedOptions (and of DistanceOptions) that changes a pair's result: a result
/// is reused only under the options that produced it. A field added to either struct must be
/// considered here. (report_mode and change_tolerance only choose which results are sent: not
/// compared.)
bool same_options(const ResolvedOptions& a, const ResolvedOptions& b) {
  const DistanceOptions<double>& x = a.engine;
  const DistanceOptions<double>& y = b.engine;
  auto same = [](double u, double v) { return std::memcmp(&u, &v, sizeof u) == 0; };
  return a.warm_start == b.warm_start && same(x.epsilon, y.epsilon) &&
         x.max_iterations == y.max_iterations && x.origin_shift == y.origin_shift &&
         x.subalgorithm == y.subalgorithm && x.cold_start == y.cold_start &&
         same(x.distance_cutoff, y.distance_cutoff) && x.near_points == y.near_points &&
         x.penetration_bound == y.penetration_bound && x.gradient == y.gradient &&
         x.penetration_depth == y.penetration_depth && same(x.depth_tolerance, y.depth_tolerance) &&
         x.depth_max_iterations == y.depth_max_iterations;
}

void report_pruned(const ScenePair& pair, double lower_bound, model::PairReport& out) {
  out = model::PairReport{};
  out.object_a = pair.object_a;
  out.object_b = pair.object_b;
  out.status = model::PairStatus::beyond_cutoff;
  out.distance_lower_bound = lower_bound;
}

void set_near(IncrementalState& state, std::uint32_t pair, bool near) {
  std::uint32_t& position = state.near_position[pair];
  const bool listed = position != IncrementalState::kNotNear;
  if (near == listed) return;
  if (near) {
    position = std::uint32_t(state.near_pairs.size());
    state.near_pairs.push_back(pair);
  } else {  // swap with the last and drop it
    const std::uint32_t last = state.near_pairs.back();
    state.near_pairs[position] = last;
    state.near_position[last] = position;
    state.near_pairs.pop_back();
    position = IncrementalState::kNotNear;
  }
}

}  // namespace

bool within_cutoff(const model::PairReport& pair, double cutoff) {
  // The engine may converge before a support plane proves the cutoff: then the pair is separated
  // with a distance beyond it, and is left out as well. Problems (iteration limit, engine error)
  // are always reported.
  return pair.status != model::PairStatus::beyond_cutoff &&
         !(pair.status == model::PairStatus::separated && pair.distance > cutoff);
}

void index_object_pairs(SceneDefinition& scene) {
  const std::size_t n = scene.objects.size();
  scene.object_pairs_begin.assign(n + 1, 0);
  for (const ScenePair& pair : scene.pairs) {
    ++scene.object_pairs_begin[pair.object_a + 1];
    ++scene.object_pairs_begin[pair.object_b + 1];
  }
  for (std::size_t i = 0; i < n; ++i)
    scene.object_pairs_begin[i + 1] += scene.object_pairs_begin[i];
  scene.object_pairs.resize(scene.object_pairs_begin[n]);
  std::vector<std::uint32_t> fill(scene.object_pairs_begin.begin(),
                                  scene.object_pairs_begin.end() - 1);
  for (std::uint32_t p = 0; p < scene.pairs.size(); ++p) {
    scene.object_pairs[fill[scene.pairs[p].object_a]++] = p;
    scene.object_pairs[fill[scene.pairs[p].object_b]++] = p;
  }
}

void plan_evaluation(const SceneDefinition& scene, const std::vector<Pose<double>>& poses,
                     const ResolvedOptions& options, IncrementalState& state,
                     std::vector<std::uint32_t>& evaluate, model::ReportCounts& counts) {
  const std::size_t n = scene.objects.size();
  const bool first = !state.valid;
  const bool everything = first || !same_options(state.options, options);
  if (first) {
    state.pairs.assign(scene.pairs.size(), model::PairReport{});
    state.pruned_pairs.clear();
    state.pruned_listed.assign(scene.pairs.size(), 0);
    state.pruned_bound.assign(scene.pairs.size(), std::numeric_limits<double>::quiet_NaN());
    state.near_pairs.clear();
    state.near_position.assign(scene.pairs.size(), IncrementalState::kNotNear);
    state.broad_phase.reset(n);
    state.near_stamp.assign(n, 0);
  }
  state.moved.assign(n, 0);
  std::size_t moved_count = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    // Boxes follow the poses even when the options alone changed nothing, so that they are
    // always those of `poses`.
    const bool moved = first || !same_pose(poses[i], state.poses[i]);
    if (moved) {
      const SceneObject& object = scene.objects[i];
      state.broad_phase.set(
          i, world_box(*object.geometry, poses[i], std::max(object.padding, object.self_padding)));
    }
    state.moved[i] = moved || everything;
    moved_count += state.moved[i];
  }
  state.broad_phase.sort();

  evaluate.clear();
  state.pruned_now.clear();
  const bool watching = state.watches != nullptr;
  counts = model::ReportCounts{};
  const double cutoff = options.engine.distance_cutoff;
  const bool prune = std::isfinite(cutoff);
  std::size_t touched = 0;  // pairs with a moved object
  for (std::uint32_t a = 0; a < n && moved_count > 0; ++a) {
    if (!state.moved[a]) continue;
    const Aabb& box_a = state.broad_phase.box(a);
    // The objects near `a` get this round's stamp; any other partner is beyond the cutoff.
    if (prune && ++state.stamp == 0) {  // wrapped: clear the old stamps
      std::fill(state.near_stamp.begin(), state.near_stamp.end(), 0);
      state.stamp = 1;
    }
    if (prune)
      state.broad_phase.query(box_a, cutoff,
                              [&](std::uint32_t j) { state.near_stamp[j] = state.stamp; });
    for (std::uint32_t k = scene.object_pairs_begin[a]; k < scene.object_pairs_begin[a + 1]; ++k) {
      const std::uint32_t p = scene.object_pairs[k];
      const ScenePair& pair = scene.pairs[p];
      const std::uint32_t b = pair.object_a == a ? pair.object_b : pair.object_a;
      if (state.moved[b] && b < a) continue;  // done from b
      ++touched;
      if (!prune) {
        evaluate.push_back(p);
        state.pruned_bound[p] = std::numeric_limits<double>::quiet_NaN();  // the engine writes it
        continue;
      }
      // A partner the sweep did not find is beyond the cutoff on some axis; one it found may
      // still be beyond it diagonally. Either way the boxes' gap is the proven lower bound.
      const double gap = box_gap(box_a, state.broad_phase.box(b));
      if (state.near_stamp[b] == state.stamp && !(gap > cutoff)) {
        evaluate.push_back(p);
        state.pruned_bound[p] = std::numeric_limits<double>::quiet_NaN();  // the engine writes it
      } else {
        if (!state.pruned_listed[p]) {
          state.pruned_listed[p] = 1;
          state.pruned_pairs.push_back(p);
        }
        state.pruned_bound[p] = gap;
        if (watching) state.pruned_now.push_back(p);
        set_near(state, p, false);
        ++counts.pairs_pruned;
      }
    }
  }
  counts.pairs_evaluated = std::uint32_t(evaluate.size());
  counts.pairs_unmoved = std::uint32_t(scene.pairs.size() - touched);
}

void finish_evaluation(std::vector<Pose<double>> poses, const ResolvedOptions& options,
                       const std::vector<std::uint32_t>& evaluated, IncrementalState& state) {
  for (const std::uint32_t p : evaluated)
    set_near(state, p, within_cutoff(state.pairs[p], options.engine.distance_cutoff));
  state.poses = std::move(poses);
  state.options = options;
  state.valid = true;
}

namespace {

/// Writes the pruned pairs' entries now that a report needs every pair. A listed pair that went
/// to the engine since has a NaN bound: its entry is already the engine's.
void write_pruned(const SceneDefinition& scene, IncrementalState& state) {
  for (const std::uint32_t p : state.pruned_pairs) {
    const double bound = state.pruned_bound[p];
    if (!std::isnan(bound)) report_pruned(scene.pairs[p], bound, state.pairs[p]);
    state.pruned_bound[p] = std::numeric_limits<double>::quiet_NaN();
    state.pruned_listed[p] = 0;
  }
  state.pruned_pairs.clear();
}

/// Whether pair `p` is nearer than pair `q` (ties: the earlier pair), so that the choice never
/// depends on the order of the near list.
bool nearer(const IncrementalState& state, std::uint32_t p, std::uint32_t q) {
  const double dp = nearness(state.pairs[p]);
  const double dq = nearness(state.pairs[q]);
  return dp < dq || (dp == dq && p < q);
}

}  // namespace

double nearness(const model::PairReport& pair) {
  if (pair.status == model::PairStatus::engine_error) return 0;
  if (model::in_contact(pair.status))
    // With the depth mode the deeper pair is the nearer one; without, contact ranks as 0.
    return pair.has_signed_distance ? std::min(0.0, pair.signed_distance) : 0;
  return pair.distance;
}

void collect_report(const SceneDefinition& scene, IncrementalState& state,
                    const ResolvedOptions& options, bool state_dies,
                    std::vector<model::PairReport>& out) {
  const model::ReportMode mode = options.report_mode;
  // Any other mode shows the client values the changed baseline does not hold.
  if (mode != model::ReportMode::changed) state.sent_valid = false;
  out.clear();
  switch (mode) {
    case model::ReportMode::within_cutoff: {
      std::vector<std::uint32_t> order = state.near_pairs;
      std::sort(order.begin(), order.end());  // the scene's pair order, as in all_pairs
      out.reserve(order.size());
      for (const std::uint32_t p : order) out.push_back(state.pairs[p]);
      return;
    }
    case model::ReportMode::nearest_per_object: {
      // The candidates are the near pairs (those within_cutoff would report): pairs the broad
      // phase pruned are beyond the cutoff, so the answer is the same with or without it.
      constexpr std::uint32_t kNone = IncrementalState::kNotNear;
      std::vector<std::uint32_t> best(scene.objects.size(), kNone);
      for (const std::uint32_t p : state.near_pairs)
        for (const std::uint32_t object : {scene.pairs[p].object_a, scene.pairs[p].object_b})
          if (best[object] == kNone || nearer(state, p, best[object])) best[object] = p;
      std::vector<std::uint32_t> chosen;
      for (const std::uint32_t p : best)
        if (p != kNone) chosen.push_back(p);
      std::sort(chosen.begin(), chosen.end());
      chosen.erase(std::unique(chosen.begin(), chosen.end()), chosen.end());
      out.reserve(chosen.size());
      for (const std::uint32_t p : chosen) out.push_back(state.pairs[p]);
      return;
    }
    case model::ReportMode::global_minimum: {
      if (state.near_pairs.empty()) return;
      std::uint32_t best = state.near_pairs.front();
      for (const std::uint32_t p : state.near_pairs)
        if (nearer(state, p, best)) best = p;
      out.push_back(state.pairs[best]);
      return;
    }
    case model::ReportMode::changed: {
      // Every pair is compared: a pair's result changes only when it is evaluated or pruned, but
      // a scan is simpler to trust than a second dirty list, and costs no engine call.
      write_pruned(scene, state);
      const std::size_t count = state.pairs.size();
      const bool first = !state.sent_valid;
      if (first) {
        state.sent_status.assign(count, model::PairStatus::engine_error);
        state.sent_distance.assign(count, 0);
      }
      const double tolerance = options.change_tolerance;
      for (std::size_t p = 0; p < count; ++p) {
        const model::PairReport& pair = state.pairs[p];
        // A BEYOND_CUTOFF pair's lower bound moves with every pose: only its status counts.
        // With the depth mode the signed distance is what moves inside contact.
        const double value = pair.has_signed_distance ? pair.signed_distance : pair.distance;
        const bool changed = first || pair.status != state.sent_status[p] ||
                             (pair.status != model::PairStatus::beyond_cutoff &&
                              !(std::abs(value - state.sent_distance[p]) <= tolerance));
        if (!changed) continue;
        out.push_back(pair);
        state.sent_status[p] = pair.status;
        state.sent_distance[p] = value;
      }
      state.sent_valid = true;
      return;
    }
    default:  // all_pairs
      write_pruned(scene, state);
      if (state_dies)
        out = std::move(state.pairs);
      else
        out = state.pairs;
      return;
  }
}

}  // namespace nearpoint::server
