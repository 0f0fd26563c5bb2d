// SPDX-License-Identifier: Apache-2.0
#include "thresholds.hpp"

#include <algorithm>
#include <cmath>
#include <tuple>

#include "report_size.hpp"
#include "validation.hpp"

namespace nearpoint::server {

Expected<std::shared_ptr<const WatchSet>> resolve_thresholds(
    const SceneDefinition& scene, const std::vector<model::ThresholdInput>& thresholds,
    std::size_t max_watches, bool signed_distance) {
  if (thresholds.size() > kMaxThresholds)
    return resource_exhausted(
        "thresholds", text("names ", thresholds.size(), " thresholds; a stream may watch at most ",
                           kMaxThresholds));
  auto set = std::make_shared<WatchSet>();
  auto names = std::make_shared<std::vector<std::string>>();
  const std::size_t pair_count = scene.pairs.size();
  // Per threshold, which pairs it watches (marked, then gathered per pair in pair order).
  std::vector<std::vector<std::uint32_t>> per_threshold(thresholds.size());
  std::size_t watches = 0;
  for (std::size_t t = 0; t < thresholds.size(); ++t) {
    const model::ThresholdInput& in = thresholds[t];
    const std::string field = text("thresholds[", t, ']');
    if (auto error = check_name(in.name, field + ".name")) return *error;
    if (!std::isfinite(in.distance))
      return invalid_argument(field + ".distance",
                              text("must be a finite distance (metres), got ", in.distance));
    if (!signed_distance && !(in.distance > 0))
      return invalid_argument(
          field + ".distance",
          text("must be > 0 (metres), got ", in.distance,
               ": a threshold at or below 0 watches a penetration depth, which needs "
               "options.penetration PENETRATION_MODE_DEPTH (--penetration depth)"));
    if (!(std::isfinite(in.hysteresis) && in.hysteresis >= 0))
      return invalid_argument(field + ".hysteresis",
                              text("must be a finite distance >= 0 (metres), got ", in.hysteresis));
    std::int64_t a = -1, b = -1;
    if (!in.object_a.empty()) {
      if (auto error = check_id(in.object_a, field + ".object_a")) return *error;
      a = scene.find_object(in.object_a);
      if (a < 0)
        return not_found(field + ".object_a",
                         text("no object ", quoted(in.object_a), " in the scene"));
    }
    if (!in.object_b.empty()) {
      if (a < 0)
        return invalid_argument(field + ".object_b",
                                "needs object_a (a pair names both objects, an object object_a)");
      if (auto error = check_id(in.object_b, field + ".object_b")) return *error;
      b = scene.find_object(in.object_b);
      if (b < 0)
        return not_found(field + ".object_b",
                         text("no object ", quoted(in.object_b), " in the scene"));
      if (a == b) return invalid_argument(field, "must name two different objects");
    }
    auto in_groups = [&](std::uint32_t object) {
      return in.groups == 0 || (scene.objects[object].group & in.groups) != 0;
    };
    std::vector<std::uint32_t>& pairs = per_threshold[t];
    if (a >= 0) {
      for (std::uint32_t k = scene.object_pairs_begin[std::size_t(a)];
           k < scene.object_pairs_begin[std::size_t(a) + 1]; ++k) {
        const std::uint32_t p = scene.object_pairs[k];
        const ScenePair& pair = scene.pairs[p];
        const std::uint32_t other =
            pair.object_a == std::uint32_t(a) ? pair.object_b : pair.object_a;
        if (b >= 0 ? other == std::uint32_t(b) : in_groups(other)) pairs.push_back(p);
      }
    } else {
      for (std::uint32_t p = 0; p < pair_count; ++p)
        if (in_groups(scene.pairs[p].object_a) || in_groups(scene.pairs[p].object_b))
          pairs.push_back(p);
    }
    if (pairs.empty())
      return invalid_argument(field, b >= 0 ? "names a pair the scene does not select"
                                            : "watches no selected pair of the scene");
    watches += pairs.size();
    if (watches > max_watches)
      return resource_exhausted("thresholds",
                                text("the thresholds watch more than ", max_watches,
                                     " (pair, threshold) combinations (--max-pairs-per-scene)"));
    ResolvedThreshold& resolved = set->thresholds.emplace_back();
    resolved.name = in.name;
    resolved.enter = in.distance;
    resolved.exit = in.distance + in.hysteresis;
    if (!(in.distance > 0) && set->signed_threshold < 0) set->signed_threshold = std::int64_t(t);
    if (!std::isfinite(resolved.exit))
      return invalid_argument(field + ".hysteresis", "distance + hysteresis overflows");
    if (resolved.exit > set->max_exit) {
      set->max_exit = resolved.exit;
      set->max_exit_threshold = t;
    }
    names->push_back(in.name);
  }
  // Gather per pair, thresholds in order.
  set->watch_begin.assign(pair_count + 1, 0);
  for (const auto& pairs : per_threshold)
    for (const std::uint32_t p : pairs) ++set->watch_begin[p + 1];
  for (std::size_t p = 0; p < pair_count; ++p) set->watch_begin[p + 1] += set->watch_begin[p];
  set->watch_threshold.resize(set->watch_begin[pair_count]);
  std::vector<std::uint32_t> fill(set->watch_begin.begin(), set->watch_begin.end() - 1);
  set->watched_object.assign(scene.objects.size(), 0);
  for (std::uint32_t t = 0; t < per_threshold.size(); ++t) {
    for (const std::uint32_t p : per_threshold[t]) {
      set->watch_threshold[fill[p]++] = t;
      const ScenePair& pair = scene.pairs[p];
      set->watched_object[pair.object_a] = set->watched_object[pair.object_b] = 1;
      set->event_bytes_per_update += report_size::event_entry(
          set->thresholds[t].name.size(), scene.objects[pair.object_a].id.size(),
          scene.objects[pair.object_b].id.size());
    }
  }
  set->names = std::move(names);
  return std::shared_ptr<const WatchSet>(std::move(set));
}

std::optional<Error> check_cutoff(const WatchSet& watches, double cutoff) {
  if (watches.thresholds.empty() || !(cutoff < watches.max_exit)) return std::nullopt;
  return invalid_argument(
      "options.distance_cutoff",
      text("is ", cutoff, " m, below the exit distance ", watches.max_exit,
           " m (distance + hysteresis) of thresholds[", watches.max_exit_threshold,
           "]: a pair between the two would be BEYOND_CUTOFF with no distance to compare; raise "
           "the cutoff to at least the largest exit distance"));
}

std::optional<Error> check_penetration(const WatchSet& watches, const ResolvedOptions& options) {
  if (watches.signed_threshold < 0 || options.engine.penetration_depth) return std::nullopt;
  const ResolvedThreshold& threshold = watches.thresholds[std::size_t(watches.signed_threshold)];
  return invalid_argument(
      "options.penetration",
      text("must be PENETRATION_MODE_DEPTH: thresholds[", watches.signed_threshold, "] (",
           quoted(threshold.name), ") watches the signed distance ", threshold.enter,
           " m, which only the depth mode reports"));
}

bool watch_distance(const model::PairReport& pair, double& distance) {
  switch (pair.status) {
    case model::PairStatus::intersecting:
    case model::PairStatus::touching:
      // With the depth mode the signed distance (−depth); without, contact is 0.
      distance = pair.has_signed_distance ? std::min(0.0, pair.signed_distance) : 0;
      return true;
    case model::PairStatus::beyond_cutoff:
      distance = pair.distance_lower_bound;
      return true;
    case model::PairStatus::separated:
    case model::PairStatus::iteration_limit:  // an upper bound, within error_bound of the truth
      distance = pair.distance;
      return true;
    case model::PairStatus::engine_error:
      return false;
  }
  return false;
}

void check_crossings(const WatchSet& watches, const ScenePair& pair, std::uint32_t p,
                     double distance, std::uint64_t sequence, std::vector<char>& inside,
                     std::vector<model::ThresholdEvent>& events) {
  for (std::uint32_t w = watches.watch_begin[p]; w < watches.watch_begin[p + 1]; ++w) {
    const std::uint32_t t = watches.watch_threshold[w];
    const ResolvedThreshold& threshold = watches.thresholds[t];
    char& in = inside[w];
    model::Crossing crossing;
    if (!in && distance < threshold.enter) {
      crossing = model::Crossing::enter;
    } else if (in && distance > threshold.exit) {
      crossing = model::Crossing::exit;
    } else {
      continue;  // in the hysteresis band, or no change of side
    }
    in = !in;
    events.push_back(
        model::ThresholdEvent{t, p, pair.object_a, pair.object_b, crossing, distance, sequence});
  }
}

void sort_events(std::vector<model::ThresholdEvent>& events) {
  std::stable_sort(events.begin(), events.end(),
                   [](const model::ThresholdEvent& x, const model::ThresholdEvent& y) {
                     return std::tie(x.sequence, x.pair, x.threshold) <
                            std::tie(y.sequence, y.pair, y.threshold);
                   });
}

}  // namespace nearpoint::server
