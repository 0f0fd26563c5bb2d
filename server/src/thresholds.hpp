// SPDX-License-Identifier: Apache-2.0
// Watched pairs: thresholds with hysteresis and the ENTER/EXIT events of a pose stream.
//
// A stream's first update may name thresholds (nearpoint.v1.Threshold). Each resolves to a set of
// the scene's selected pairs; every (pair, threshold) is a watch with an "inside" flag, false at
// the start. After a pair's result changes, its watch distance w (the distance, 0 when
// intersecting or touching — with PENETRATION_MODE_DEPTH the signed distance, −depth — the proven
// lower bound when beyond the cutoff) is compared: an outside watch
// with w < distance goes inside (ENTER), an inside watch with w > distance + hysteresis goes
// outside (EXIT), anything between keeps the flag. So an event fires once per crossing, and a
// pair that hovers at the threshold fires nothing until it leaves the hysteresis band.
//
// Coalesced updates: a merged update carries the poses each absorbed update set on watched
// objects, and the evaluation replays them in order (the watched pairs of the moved objects
// only) before the merged update's own poses, so that the crossings of absorbed updates are
// reported, each with its own sequence number.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "nearpoint/server/errors.hpp"
#include "nearpoint/server/scene_service.hpp"

namespace nearpoint::server {

/// At most this many thresholds per stream.
inline constexpr std::size_t kMaxThresholds = 64;
/// At most this many absorbed updates are replayed per merged update; beyond them the oldest two
/// are folded into one (the crossings of the older one are then judged at the newer one's poses),
/// so that a stream's memory stays bounded however fast a client sends.
inline constexpr std::size_t kMaxReplayedUpdates = 256;

struct ResolvedThreshold {
  std::string name;
  /// ENTER below `enter`, EXIT above `exit` (= distance + hysteresis), metres.
  double enter = 0;
  double exit = 0;
};

/// A stream's thresholds resolved against its scene: immutable, shared with its reports.
struct WatchSet {
  std::vector<ResolvedThreshold> thresholds;
  std::shared_ptr<const std::vector<std::string>> names;
  /// The watches of pair p: thresholds `watch_threshold[watch_begin[p] .. watch_begin[p + 1])`
  /// (the watch index is the position in that array).
  std::vector<std::uint32_t> watch_begin;
  std::vector<std::uint32_t> watch_threshold;
  /// Per object: whether any of its pairs is watched (their poses are kept for replay).
  std::vector<char> watched_object;
  /// The largest exit distance: the cutoff may not be below it (a pair beyond the cutoff must be
  /// provably outside every threshold).
  double max_exit = 0;
  /// Index of the threshold with the largest exit distance (for messages).
  std::size_t max_exit_threshold = 0;
  /// Index of the first threshold at or below 0 (a penetration depth, PENETRATION_MODE_DEPTH
  /// only), or -1 when none is.
  std::int64_t signed_threshold = -1;
  /// An upper bound on the bytes one update's events add to a report (every watch crossing).
  std::size_t event_bytes_per_update = 0;

  std::size_t watch_count() const { return watch_threshold.size(); }
  bool watched(std::uint32_t pair) const { return watch_begin[pair] != watch_begin[pair + 1]; }
};

/// Validates `thresholds` (field paths "thresholds[i]. …") against `scene` and resolves them.
/// At most `max_watches` (pair, threshold) watches. `signed_distance`: the options they start
/// under compute the signed distance (PENETRATION_MODE_DEPTH), so distances <= 0 are allowed.
Expected<std::shared_ptr<const WatchSet>> resolve_thresholds(
    const SceneDefinition& scene, const std::vector<model::ThresholdInput>& thresholds,
    std::size_t max_watches, bool signed_distance);

/// INVALID_ARGUMENT ("options.penetration") when `watches` hold a threshold at or below 0 and
/// `options` do not compute the signed distance: every update of such a stream needs the depth
/// mode (a later update may not turn it off).
std::optional<Error> check_penetration(const WatchSet& watches, const ResolvedOptions& options);

/// INVALID_ARGUMENT ("options.distance_cutoff") when `cutoff` is below a threshold's exit
/// distance: a pair between the two would be BEYOND_CUTOFF, with no distance to compare.
std::optional<Error> check_cutoff(const WatchSet& watches, double cutoff);

/// A pair's watch distance, or false for a result that has none (ENGINE_ERROR).
bool watch_distance(const model::PairReport& pair, double& distance);

/// Compares pair `p`'s watch distance `distance` with its watches (flags in `inside`, indexed by
/// watch) and appends an event per crossing. Calling it again with the same distance adds
/// nothing.
void check_crossings(const WatchSet& watches, const ScenePair& pair, std::uint32_t p,
                     double distance, std::uint64_t sequence, std::vector<char>& inside,
                     std::vector<model::ThresholdEvent>& events);

/// Orders events by sequence, then pair, then threshold.
void sort_events(std::vector<model::ThresholdEvent>& events);

}  // namespace nearpoint::server
