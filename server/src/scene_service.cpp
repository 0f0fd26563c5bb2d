// SPDX-License-Identifier: Apache-2.0
#include "nearpoint/server/scene_service.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_set>

#include "content_hash.hpp"
#include "evaluation.hpp"
#include "incremental.hpp"
#include "metrics.hpp"
#include "nearpoint/model/vocabulary.hpp"
#include "report_size.hpp"
#include "thresholds.hpp"
#include "validation.hpp"

namespace nearpoint::server {
namespace {

/// The work one pool task should carry before an evaluation is split further, in "vertex
/// visits" (a support call on a polytope visits each of its vertices once; a primitive counts as
/// 8). A pair costs roughly (M_A + M_B) per support call and a few calls per update, so 4096
/// visits are ~10–20 µs of GJK on this class of machine: about what waking a worker costs. Below
/// that, one worker per update is faster than two.
constexpr std::size_t kVisitsPerTask = 4096;
constexpr std::size_t kVisitsPerPrimitive = 8;

/// The vertex visits of one support call on each piece pair of (a, b), summed.
std::size_t pair_cost(const model::GeometryInfo& a, const model::GeometryInfo& b) {
  auto effective = [](const model::GeometryInfo& g) {
    return g.vertex_count + kVisitsPerPrimitive * g.piece_count;
  };
  return b.piece_count * effective(a) + a.piece_count * effective(b);
}

/// The most one report of `scene` with `options` can take on the wire in report mode `mode`
/// (see report_size.hpp): every pair (all pairs; changed, whose first report carries every
/// pair; within the cutoff with no cutoff), one per object at most (nearest per object), one
/// (global minimum). A within-cutoff report under a finite cutoff has no bound from the scene:
/// it holds what is near (counted as the envelope here; the transport checks it when sending).
std::size_t report_bytes_bound(const SceneDefinition& scene, const DistanceOptions<double>& options,
                               model::ReportMode mode) {
  const std::size_t extra =
      report_size::pair_options(options.near_points, options.penetration_bound, options.gradient);
  const std::size_t longest_entry =
      report_size::kPairEntryOverhead + report_size::kPairFixed +
      report_size::pair_ids(scene.longest_object_id, scene.longest_object_id) + extra;
  switch (mode) {
    case model::ReportMode::nearest_per_object:
      return report_size::kReportEnvelope +
             std::min(scene.pairs.size(), scene.objects.size()) * longest_entry;
    case model::ReportMode::global_minimum:
      return report_size::kReportEnvelope +
             std::min<std::size_t>(scene.pairs.size(), 1) * longest_entry;
    case model::ReportMode::within_cutoff:
      if (std::isfinite(options.distance_cutoff)) return report_size::kReportEnvelope;
      [[fallthrough]];
    default:
      return scene.report_bytes_base + scene.pairs.size() * extra;
  }
}
std::size_t report_bytes_bound(const SceneDefinition& scene, const ResolvedOptions& options) {
  return report_bytes_bound(scene, options.engine, options.report_mode);
}

/// The mode's name in messages: the proto's and the CLI's (unspecified reads as all pairs).
std::string mode_name(model::ReportMode mode) {
  const model::Term<model::ReportMode>* term = model::find_term(mode);
  if (term == nullptr || term->wire == 0) term = model::find_term(model::ReportMode::all_pairs);
  return text(term->name, " (--mode ", term->spelling,
              mode == model::ReportMode::changed ? "; its first report holds every pair)" : ")");
}

/// "near points and gradients", or "" when the options ask for neither of the three extras.
std::string extras(const DistanceOptions<double>& options) {
  std::string out;
  auto add = [&](bool on, const char* what) {
    if (!on) return;
    if (!out.empty()) out += " and ";
    out += what;
  };
  add(options.near_points, "near points");
  add(options.penetration_bound, "penetration bounds");
  add(options.gradient, "gradients");
  return out;
}

/// RESOURCE_EXHAUSTED when a report of `scene` with `options` (its outputs and report mode) could
/// be larger than `limit`: such a report could never be sent, so the scene (at creation) or the
/// request is refused instead. The message names the limit, the mode, the bound, how many pairs
/// fit, and which report modes would fit. `field` is "" at creation. `event_bytes`: what a
/// stream's threshold events may add (one update's crossings).
std::optional<Error> check_report_bytes(const SceneDefinition& scene,
                                        const ResolvedOptions& options, std::size_t limit,
                                        const std::string& field, std::size_t event_bytes = 0) {
  const std::size_t pairs_bound = report_bytes_bound(scene, options);
  const std::size_t bound = pairs_bound + event_bytes;
  if (bound <= limit) return std::nullopt;
  if (pairs_bound <= limit)
    return resource_exhausted(
        "thresholds",
        text("a report of scene ", quoted(scene.id), " could take up to ", pairs_bound,
             " bytes for its pairs and ", event_bytes,
             " for the thresholds' events (one per watched pair and threshold), more than the ",
             limit,
             " bytes the server sends in one message (--max-message-bytes): watch fewer "
             "pairs, or ask for fewer outputs"));
  const DistanceOptions<double>& engine = options.engine;
  const std::size_t all_bound = report_bytes_bound(scene, engine, model::ReportMode::all_pairs);
  const std::size_t pairs = std::max<std::size_t>(1, scene.pairs.size());
  const std::size_t per_pair =
      std::max<std::size_t>(1, (all_bound - report_size::kReportEnvelope) / pairs);
  const std::size_t fitting =
      limit > report_size::kReportEnvelope ? (limit - report_size::kReportEnvelope) / per_pair : 0;
  // The modes whose reports would fit, with these outputs.
  std::string fit;
  for (const model::ReportMode mode :
       {model::ReportMode::nearest_per_object, model::ReportMode::global_minimum}) {
    const std::size_t mode_bound = report_bytes_bound(scene, engine, mode);
    if (mode_bound <= limit && mode != options.report_mode)
      fit += text(fit.empty() ? "" : ", ", mode_name(mode), " (up to ", mode_bound, " bytes)");
  }
  if (options.report_mode != model::ReportMode::within_cutoff ||
      !std::isfinite(engine.distance_cutoff))
    fit += text(fit.empty() ? "" : ", ", mode_name(model::ReportMode::within_cutoff),
                " with a finite distance_cutoff (as large as the pairs within it)");
  const std::string with = extras(engine);
  const std::string what =
      text("a report of ", field.empty() ? std::string("this scene") : "scene " + quoted(scene.id),
           " in ", mode_name(options.report_mode), with.empty() ? std::string() : " with " + with,
           " could take up to ", bound, " bytes (", scene.pairs.size(), " pairs, object ids up to ",
           scene.longest_object_id, " bytes), more than the ", limit,
           " bytes the server sends in one message (--max-message-bytes); about ", fitting,
           " pairs of this size fit. Report modes that fit: ", fit, ". ");
  if (field.empty())
    return resource_exhausted(field, what +
                                         "Set default_options.report_mode to one of them, or "
                                         "select fewer pairs or use shorter object ids");
  return resource_exhausted(field, what +
                                       "Ask for one of them (options.report_mode) or for "
                                       "fewer outputs, or create a scene with fewer pairs or "
                                       "shorter ids");
}

/// The crossings of the updates a merged one absorbed: from the stream's previous poses, each
/// absorbed update's poses in turn, and for each the watched pairs of the objects it moved
/// through the engine (results kept apart: the stream's per-pair results stay those of its
/// reports). Runs on a worker, before the merged update's own evaluation.
void replay_steps(const SceneDefinition& scene, IncrementalState& state,
                  const std::vector<WatchStep>& steps, const ResolvedOptions& options,
                  std::span<SimplexCache> caches, std::vector<std::uint32_t>& touched,
                  std::vector<model::ThresholdEvent>& events) {
  const WatchSet& watches = *state.watches;
  std::vector<Pose<double>> poses;
  if (state.valid) {
    poses = state.poses;
  } else {
    poses.reserve(scene.objects.size());
    for (const SceneObject& object : scene.objects) poses.push_back(object.initial_pose);
  }
  std::vector<std::uint32_t> pairs;
  model::PairReport result;
  for (const WatchStep& step : steps) {
    pairs.clear();
    for (const auto& [object, pose] : step.moves) {
      poses[object] = pose;
      for (std::uint32_t k = scene.object_pairs_begin[object];
           k < scene.object_pairs_begin[object + 1]; ++k)
        if (watches.watched(scene.object_pairs[k])) pairs.push_back(scene.object_pairs[k]);
    }
    std::sort(pairs.begin(), pairs.end());
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    for (const std::uint32_t p : pairs) {
      const ScenePair& pair = scene.pairs[p];
      evaluate_pair(scene, pair, poses, options,
                    caches.empty() ? caches : caches.subspan(pair.cache_offset, pair.cache_count),
                    result);
      double distance = 0;
      if (watch_distance(result, distance))
        check_crossings(watches, pair, p, distance, step.sequence, state.inside, events);
      touched.push_back(p);
    }
  }
}

/// The crossings of the evaluation just finished: every watched pair whose result it changed
/// (evaluated, pruned) or that a replay left at another pose's result.
void check_evaluation(const SceneDefinition& scene, IncrementalState& state,
                      const std::vector<std::uint32_t>& evaluated,
                      const std::vector<std::uint32_t>& replayed, std::uint64_t sequence,
                      std::vector<model::ThresholdEvent>& events) {
  const WatchSet& watches = *state.watches;
  auto check = [&](std::uint32_t p) {
    if (!watches.watched(p)) return;
    // A pruned pair's entry may not be written yet: its bound is the boxes' gap.
    double distance = state.pruned_bound[p];
    if (std::isnan(distance) && !watch_distance(state.pairs[p], distance)) return;
    check_crossings(watches, scene.pairs[p], p, distance, sequence, state.inside, events);
  };
  for (const std::uint32_t p : evaluated) check(p);
  for (const std::uint32_t p : state.pruned_now) check(p);
  for (const std::uint32_t p : replayed) check(p);  // a second check of a pair adds nothing
}

double microseconds(Clock::duration d) {
  return std::chrono::duration<double, std::micro>(d).count();
}

}  // namespace

const char* to_string(ErrorCode code) {
  switch (code) {
    case ErrorCode::invalid_argument:
      return "invalid_argument";
    case ErrorCode::not_found:
      return "not_found";
    case ErrorCode::resource_exhausted:
      return "resource_exhausted";
    case ErrorCode::failed_precondition:
      return "failed_precondition";
    case ErrorCode::unavailable:
      return "unavailable";
    case ErrorCode::already_exists:
      return "already_exists";
    case ErrorCode::internal:
      return "internal";
  }
  return "internal";
}

std::string quoted(std::string_view value, std::size_t max_bytes) {
  const std::string_view shown = value.substr(0, max_bytes);
  std::string out;
  out.reserve(shown.size() + 32);
  out.push_back('\'');
  for (const char c : shown) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte >= 0x20 && byte < 0x7F) {
      out.push_back(c);
    } else {
      // Escaped so that a quoted value never carries a line break, a terminal escape or a
      // partial UTF-8 sequence into a log line or a message.
      constexpr char kHex[] = "0123456789abcdef";
      out.append("\\x");
      out.push_back(kHex[byte >> 4]);
      out.push_back(kHex[byte & 15]);
    }
  }
  if (shown.size() < value.size()) out.append("\u2026");  // …
  out.push_back('\'');
  if (shown.size() < value.size()) out.append(text(" (", value.size(), " bytes)"));
  return out;
}

std::size_t SceneService::geometry_count() const {
  std::shared_lock lock(geometries_mutex_);
  return geometries_.size();
}

// ---- scenes ----

std::int64_t SceneDefinition::find_object(const std::string& object_id) const {
  const auto found = index_by_id.find(object_id);
  return found == index_by_id.end() ? -1 : std::int64_t(found->second);
}

Scene::Scene(std::shared_ptr<const SceneDefinition> definition)
    : definition_(std::move(definition)), query_cache_(definition_->piece_pair_count) {}

void Scene::copy_query_cache(std::vector<SimplexCache>& out) {
  std::lock_guard lock(query_cache_mutex_);
  out = query_cache_;
}

void Scene::store_query_cache(const std::vector<SimplexCache>& caches) {
  std::lock_guard lock(query_cache_mutex_);
  if (caches.size() == query_cache_.size()) query_cache_ = caches;
}

// ---- one evaluation: the pairs of one update or query, in parallel on the pool ----

struct SceneService::Job {
  std::shared_ptr<const SceneDefinition> scene;
  std::vector<Pose<double>> poses;
  ResolvedOptions options;
  /// The warm-start caches read and written (a stream's, or `own_caches`); empty: cold.
  std::span<SimplexCache> caches;
  std::vector<SimplexCache> own_caches;
  /// The stream's previous evaluation (a query's is fresh): results of unmoved pairs, boxes.
  std::shared_ptr<IncrementalState> state;
  /// The pairs (indices in scene->pairs) this evaluation hands to the engine.
  std::vector<std::uint32_t> evaluate;
  /// With thresholds: the absorbed updates' poses to replay, and the pairs the replay evaluated.
  std::vector<WatchStep> replay;
  std::vector<std::uint32_t> replayed_pairs;
  /// Whether `state` outlives the job (a stream's): then the report gets a copy of its results,
  /// else (a query's) they may be moved into the report.
  bool keep_state = true;
  Report report;
  Clock::time_point received;
  Clock::time_point started;
  std::atomic<std::size_t> next_pair{0};
  std::atomic<std::size_t> tasks_left{0};
  std::atomic<std::int64_t> geometry_ns{0};
  /// Runs once, on the pool thread that finishes the last pair.
  std::function<void(Job&)> complete;
};

void SceneService::run(std::shared_ptr<Job> job) {
  // One task of the evaluation: takes pairs one at a time from a shared counter, so uneven pairs
  // (a 100-vertex hull next to a sphere) balance across the workers without any partitioning.
  auto work = [](Job& job) {
    IncrementalState& state = *job.state;
    const std::size_t count = job.evaluate.size();
    std::int64_t nanoseconds = 0;
    metrics::PairTally tally;  // recorded once per task, not per pair
    const bool tallying = metrics::enabled();
    for (;;) {
      const std::size_t i = job.next_pair.fetch_add(1, std::memory_order_relaxed);
      if (i >= count) break;
      const std::uint32_t p = job.evaluate[i];
      const ScenePair& pair = job.scene->pairs[p];
      const std::span<SimplexCache> caches =
          job.caches.empty() ? std::span<SimplexCache>{}
                             : job.caches.subspan(pair.cache_offset, pair.cache_count);
      const Clock::time_point begin = Clock::now();
      evaluate_pair(*job.scene, pair, job.poses, job.options, caches, state.pairs[p]);
      nanoseconds += std::chrono::nanoseconds(Clock::now() - begin).count();
      if (tallying) tally.add(state.pairs[p].iterations, state.pairs[p].warm_started);
    }
    job.geometry_ns.fetch_add(nanoseconds, std::memory_order_relaxed);
    if (tallying) metrics::record_pairs(tally);
    // acq_rel: the last task sees every other task's pair results.
    if (job.tasks_left.fetch_sub(1, std::memory_order_acq_rel) != 1) return;
    job.report.scene = job.scene;
    job.report.mode = job.options.report_mode;
    finish_evaluation(std::move(job.poses), job.options, job.evaluate, state);
    if (state.watches) {
      check_evaluation(*job.scene, state, job.evaluate, job.replayed_pairs, job.report.sequence,
                       job.report.events);
      sort_events(job.report.events);
      job.report.threshold_names = state.watches->names;
    }
    collect_report(*job.scene, state, job.options, !job.keep_state, job.report.pairs);
    const Clock::time_point end = Clock::now();
    model::ReportTiming& timing = job.report.timing;
    timing.server_us = microseconds(end - job.received);
    timing.queue_us = microseconds(job.started - job.received);
    timing.evaluation_us = microseconds(end - job.started);
    timing.geometry_us = double(job.geometry_ns.load(std::memory_order_relaxed)) / 1000.0;
    // A query's state is its own (keep_state false); a stream's outlives the job.
    metrics::record_report(!job.keep_state, timing, job.report.counts,
                           job.report.coalesced_updates);
    job.complete(job);
  };
  // Planning (which objects moved, the broad phase) touches every pair of a moved object, and the
  // last task copies results into the report, so both run on the pool, never on a transport
  // thread; planning then splits the pairs that reach the engine into tasks, this one included.
  pool_.post([this, job, work] {
    job->started = Clock::now();  // time before this is queueing
    if (job->state->watches && !job->replay.empty())
      replay_steps(*job->scene, *job->state, job->replay, job->options, job->caches,
                   job->replayed_pairs, job->report.events);
    plan_evaluation(*job->scene, job->poses, job->options, *job->state, job->evaluate,
                    job->report.counts);
    const std::size_t tasks =
        std::max<std::size_t>(1, std::min(job->evaluate.size(), job->scene->tasks_per_evaluation));
    job->tasks_left.store(tasks, std::memory_order_relaxed);
    for (std::size_t t = 1; t < tasks; ++t) pool_.post([job, work] { work(*job); });
    work(*job);
  });
}

// ---- geometry store ----

SceneService::SceneService(const ServiceLimits& limits, std::size_t workers)
    : limits_(limits), pool_(workers) {}

SceneService::~SceneService() = default;

Expected<std::shared_ptr<const StoredGeometry>> SceneService::store_geometry(
    std::shared_ptr<StoredGeometry> geometry, const std::string& field) {
  std::unique_lock lock(geometries_mutex_);
  const auto found = geometries_.find(geometry->info.geometry_id);
  if (found != geometries_.end()) return found->second;  // the same content: idempotent
  if (geometries_.size() >= limits_.max_geometries)
    return resource_exhausted(
        field, text("the server holds ", geometries_.size(), " geometries; the limit is ",
                    limits_.max_geometries, " (--max-geometries)"));
  geometry->registration = next_geometry_number_++;
  geometries_.emplace(geometry->info.geometry_id, geometry);
  return std::shared_ptr<const StoredGeometry>(std::move(geometry));
}

Expected<model::GeometryInfo> SceneService::register_geometry(
    const model::GeometryInput& geometry) {
  Expected<std::shared_ptr<StoredGeometry>> built = build_geometry(geometry, limits_);
  if (!built) return built.error();
  built.value()->info.geometry_id = geometry_content_id(geometry);
  Expected<std::shared_ptr<const StoredGeometry>> stored =
      store_geometry(std::move(built.value()), "");
  if (!stored) return stored.error();
  return stored.value()->info;
}

Outcome SceneService::remove_geometry(const std::string& geometry_id) {
  if (auto error = check_id(geometry_id, "geometry_id")) return *error;
  std::unique_lock lock(geometries_mutex_);
  if (geometries_.erase(geometry_id) == 0)
    return not_found("geometry_id", text("no geometry ", quoted(geometry_id)));
  return {};
}

std::vector<model::GeometryInfo> SceneService::list_geometries() const {
  std::vector<model::GeometryInfo> out;
  {
    std::shared_lock lock(geometries_mutex_);
    out.reserve(geometries_.size());
    std::vector<const StoredGeometry*> stored;
    stored.reserve(geometries_.size());
    for (const auto& [id, geometry] : geometries_) stored.push_back(geometry.get());
    // Registration order (ids are content hashes and say nothing of it).
    std::sort(stored.begin(), stored.end(), [](const StoredGeometry* a, const StoredGeometry* b) {
      return a->registration < b->registration;
    });
    for (const StoredGeometry* geometry : stored) out.push_back(geometry->info);
  }
  return out;
}

// ---- scenes ----

Expected<model::SceneInfo> SceneService::create_scene(const model::SceneInput& input) {
  if (auto error = check_name(input.name, "name")) return *error;
  if (!input.requested_id.empty())
    if (auto error = check_id(input.requested_id, "scene_id")) return *error;
  if (input.objects.empty()) return invalid_argument("objects", "must hold at least one object");
  if (input.objects.size() > limits_.max_objects_per_scene)
    return resource_exhausted("objects",
                              text("has ", input.objects.size(), " objects; the limit is ",
                                   limits_.max_objects_per_scene, " (--max-objects-per-scene)"));
  // Inline geometries: validated and given their content ids now, stored once the scene is
  // known to be valid (so a refused scene leaves nothing behind but what it names).
  if (input.geometries.size() > limits_.max_objects_per_scene)
    return resource_exhausted(
        "geometries",
        text("has ", input.geometries.size(), " geometries; the limit is ",
             limits_.max_objects_per_scene, " (--max-objects-per-scene, one per object at most)"));
  std::unordered_map<std::string, std::shared_ptr<StoredGeometry>> inline_geometries;
  for (const auto& [key, geometry] : input.geometries) {
    const std::string field = text("geometries[", quoted(key), ']');
    if (auto error = check_id(key, field)) return *error;
    Expected<std::shared_ptr<StoredGeometry>> built = build_geometry(geometry, limits_);
    if (!built) {
      Error error = built.error();
      // build_geometry's paths start with "geometry" (RegisterGeometry's request field).
      if (error.field.rfind("geometry", 0) == 0) error.field.replace(0, 8, field);
      return error;
    }
    built.value()->info.geometry_id = geometry_content_id(geometry);
    inline_geometries.emplace(key, std::move(built.value()));
  }
  auto scene = std::make_shared<SceneDefinition>();
  scene->name = input.name;
  std::unordered_map<std::string, std::size_t> bodies;  // body id → index
  scene->fingerprint = input.fingerprint;
  scene->objects.reserve(input.objects.size());
  for (std::size_t i = 0; i < input.objects.size(); ++i) {
    const model::ObjectInput& object = input.objects[i];
    const std::string field = text("objects[", i, ']');
    if (auto error = check_id(object.id, field + ".id")) return *error;
    if (const auto [it, inserted] = scene->index_by_id.emplace(object.id, std::uint32_t(i));
        !inserted)
      return invalid_argument(
          field + ".id",
          text(quoted(object.id), " is already the id of objects[", it->second, "]"));
    if (auto error = check_id(object.geometry_id, field + ".geometry_id")) return *error;
    std::shared_ptr<const StoredGeometry> geometry;
    if (const auto sent = inline_geometries.find(object.geometry_id);
        sent != inline_geometries.end()) {
      geometry = sent->second;
    } else {
      std::shared_lock lock(geometries_mutex_);
      const auto found = geometries_.find(object.geometry_id);
      if (found != geometries_.end()) geometry = found->second;
    }
    if (!geometry)
      return not_found(field + ".geometry_id", text("no geometry ", quoted(object.geometry_id)));
    Expected<Pose<double>> pose = check_pose(object.pose, field + ".pose");
    if (!pose) return pose.error();
    for (const auto& [value, name] :
         {std::pair{object.padding, ".padding"}, std::pair{object.self_padding, ".self_padding"}})
      if (!(std::isfinite(value) && value >= 0))
        return invalid_argument(field + name,
                                text("must be a finite distance >= 0 (metres), got ", value));
    std::int64_t body = -1;
    if (!object.body.empty()) {
      if (auto error = check_id(object.body, field + ".body")) return *error;
      body = std::int64_t(bodies.emplace(object.body, bodies.size()).first->second);
    }
    scene->objects.push_back(
        SceneObject{object.id, std::move(geometry), pose.value(), object.group.value_or(1u),
                    object.mask.value_or(0xFFFFFFFFu), object.padding, object.self_padding, body});
  }
  Expected<ResolvedOptions> defaults =
      resolve_options(ResolvedOptions{}, input.default_options, "default_options");
  if (!defaults) return defaults.error();
  scene->default_options = defaults.value();

  // The pairs.
  const std::vector<SceneObject>& objects = scene->objects;
  auto add_pair = [&](std::uint32_t a, std::uint32_t b, const std::string& field) -> Outcome {
    if (scene->pairs.size() >= limits_.max_pairs_per_scene)
      return resource_exhausted(field,
                                text("the scene selects more than ", limits_.max_pairs_per_scene,
                                     " pairs (--max-pairs-per-scene)"));
    const std::size_t count =
        objects[a].geometry->compound.size() * objects[b].geometry->compound.size();
    if (scene->piece_pair_count + count > limits_.max_piece_pairs_per_scene)
      return resource_exhausted(
          field, text("the scene's pairs hold more than ", limits_.max_piece_pairs_per_scene,
                      " piece pairs (--max-piece-pairs-per-scene)"));
    const SceneObject& object_a = objects[a];
    const SceneObject& object_b = objects[b];
    const bool self = object_a.body >= 0 && object_a.body == object_b.body;
    const double padding =
        self ? object_a.self_padding + object_b.self_padding : object_a.padding + object_b.padding;
    scene->pairs.push_back(ScenePair{a, b, scene->piece_pair_count, count, padding});
    scene->piece_pair_count += count;
    return {};
  };
  // Resolves a listed pair's two ids; `field` is the pair's path.
  auto resolve_pair =
      [&](const std::pair<std::string, std::string>& pair,
          const std::string& field) -> Expected<std::pair<std::uint32_t, std::uint32_t>> {
    if (auto error = check_id(pair.first, field + ".object_a")) return *error;
    if (auto error = check_id(pair.second, field + ".object_b")) return *error;
    const std::int64_t a = scene->find_object(pair.first);
    if (a < 0)
      return not_found(field + ".object_a",
                       text("no object ", quoted(pair.first), " in the scene"));
    const std::int64_t b = scene->find_object(pair.second);
    if (b < 0)
      return not_found(field + ".object_b",
                       text("no object ", quoted(pair.second), " in the scene"));
    if (a == b) return invalid_argument(field, "must name two different objects");
    return std::pair(std::uint32_t(a), std::uint32_t(b));
  };
  auto key = [](std::uint32_t a, std::uint32_t b) {
    return (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
  };

  const model::PairSelectionInput& selection = input.pair_selection;
  if (selection.mode == model::PairSelectionInput::Mode::listed_pairs) {
    std::unordered_set<std::uint64_t> seen;
    for (std::size_t k = 0; k < selection.pairs.size(); ++k) {
      const std::string field = text("pair_selection.listed_pairs.pairs[", k, ']');
      auto pair = resolve_pair(selection.pairs[k], field);
      if (!pair) return pair.error();
      if (!seen.insert(key(pair->first, pair->second)).second)
        return invalid_argument(field, "lists a pair already listed");
      if (Outcome added = add_pair(pair->first, pair->second, "pair_selection"); !added)
        return added.error();
    }
  } else {
    std::unordered_set<std::uint64_t> excluded;
    if (selection.mode == model::PairSelectionInput::Mode::excluded_pairs) {
      for (std::size_t k = 0; k < selection.pairs.size(); ++k) {
        auto pair =
            resolve_pair(selection.pairs[k], text("pair_selection.excluded_pairs.pairs[", k, ']'));
        if (!pair) return pair.error();
        excluded.insert(key(pair->first, pair->second));
      }
    }
    for (std::uint32_t a = 0; a < objects.size(); ++a) {
      for (std::uint32_t b = a + 1; b < objects.size(); ++b) {
        const bool filtered_in =
            (objects[a].group & objects[b].mask) != 0 && (objects[b].group & objects[a].mask) != 0;
        if (!filtered_in || excluded.count(key(a, b))) continue;
        if (Outcome added = add_pair(a, b, "pair_selection"); !added) return added.error();
      }
    }
  }

  // A report that could not be sent could never answer an update: refuse the scene now, while
  // the client can still choose fewer pairs or shorter ids. Requests asking for more than the
  // scene's defaults are checked the same way (query, PoseStream::prepare).
  scene->report_bytes_base = report_size::kReportEnvelope;
  for (const SceneObject& object : objects)
    scene->longest_object_id = std::max(scene->longest_object_id, object.id.size());
  for (const ScenePair& pair : scene->pairs)
    scene->report_bytes_base +=
        report_size::kPairEntryOverhead + report_size::kPairFixed +
        report_size::pair_ids(objects[pair.object_a].id.size(), objects[pair.object_b].id.size());
  if (auto error = check_report_bytes(*scene, scene->default_options, limits_.max_report_bytes, ""))
    return *error;

  std::size_t visits = 0;
  for (const ScenePair& pair : scene->pairs)
    visits +=
        pair_cost(objects[pair.object_a].geometry->info, objects[pair.object_b].geometry->info);
  scene->tasks_per_evaluation =
      std::clamp<std::size_t>(visits / kVisitsPerTask, 1, std::max<std::size_t>(1, pool_.size()));
  index_object_pairs(*scene);
  if (!input.thresholds.empty()) {
    Expected<std::shared_ptr<const WatchSet>> watches =
        resolve_thresholds(*scene, input.thresholds, limits_.max_pairs_per_scene);
    if (!watches) return watches.error();
    if (auto error = check_cutoff(**watches, scene->default_options.engine.distance_cutoff))
      return Error{error->code, "default_options.distance_cutoff", error->message};
    if (auto error = check_report_bytes(*scene, scene->default_options, limits_.max_report_bytes,
                                        "", (*watches)->event_bytes_per_update))
      return *error;
    scene->default_watches = std::move(watches.value());
  }

  model::SceneInfo info{"", scene->pairs.size(), {}};
  for (auto& [key, geometry] : inline_geometries) {
    info.geometry_ids.emplace(key, geometry->info.geometry_id);
    Expected<std::shared_ptr<const StoredGeometry>> stored =
        store_geometry(geometry, text("geometries[", quoted(key), ']'));
    if (!stored) return stored.error();
  }

  std::unique_lock lock(scenes_mutex_);
  if (scenes_.size() >= limits_.max_scenes)
    return resource_exhausted(
        "", text("the server holds ", scenes_.size(), " scenes; the limit is ", limits_.max_scenes,
                 " (--max-scenes)"));
  if (!input.requested_id.empty()) {
    if (const auto found = scenes_.find(input.requested_id); found != scenes_.end()) {
      // The same request again (a client re-creating its scene after a lost connection or a
      // failover, not knowing whether the first call arrived): the first answer.
      const SceneDefinition& existing = *found->second->definition();
      if (!input.fingerprint.empty() && existing.fingerprint == input.fingerprint)
        return existing.info;
      return Error{ErrorCode::already_exists, "scene_id",
                   text("a scene ", quoted(input.requested_id), " already exists",
                        input.fingerprint.empty() ? "" : " with another definition")};
    }
    scene->id = input.requested_id;
  } else {
    // Skip numbers a client took by asking for "scene-N" itself.
    do scene->id = text("scene-", next_scene_number_++);
    while (scenes_.count(scene->id));
  }
  info.scene_id = scene->id;
  scene->info = info;
  scenes_.emplace(info.scene_id, std::make_shared<Scene>(std::move(scene)));
  return info;
}

Outcome SceneService::delete_scene(const std::string& scene_id) {
  if (auto error = check_id(scene_id, "scene_id")) return *error;
  std::shared_ptr<Scene> scene;
  {
    std::unique_lock lock(scenes_mutex_);
    const auto found = scenes_.find(scene_id);
    if (found == scenes_.end()) return not_found("scene_id", text("no scene ", quoted(scene_id)));
    scene = std::move(found->second);
    scenes_.erase(found);
  }
  scene->mark_deleted();
  return {};
}

std::size_t SceneService::scene_count() const {
  std::shared_lock lock(scenes_mutex_);
  return scenes_.size();
}

std::shared_ptr<Scene> SceneService::find_scene(const std::string& scene_id) const {
  std::shared_lock lock(scenes_mutex_);
  const auto found = scenes_.find(scene_id);
  return found == scenes_.end() ? nullptr : found->second;
}

Expected<std::vector<Pose<double>>> SceneService::apply_poses(
    const SceneDefinition& scene, std::vector<Pose<double>> poses,
    const std::vector<model::ObjectPoseInput>& updates, const char* field) const {
  std::vector<char> seen(scene.objects.size(), 0);
  for (std::size_t j = 0; j < updates.size(); ++j) {
    const std::string entry = text(field, '[', j, ']');
    if (auto error = check_id(updates[j].object_id, entry + ".object_id")) return *error;
    const std::int64_t index = scene.find_object(updates[j].object_id);
    if (index < 0)
      return not_found(entry + ".object_id", text("no object ", quoted(updates[j].object_id),
                                                  " in scene ", quoted(scene.id)));
    if (seen[std::size_t(index)]++)
      return invalid_argument(entry + ".object_id",
                              text("object ", quoted(updates[j].object_id), " is listed twice"));
    Expected<Pose<double>> pose = check_pose(updates[j].pose, entry + ".pose");
    if (!pose) return pose.error();
    poses[std::size_t(index)] = pose.value();
  }
  return poses;
}

Outcome SceneService::query(const model::QueryInput& query, Clock::time_point received,
                            ReportCallback done) {
  if (auto error = check_id(query.scene_id, "scene_id")) return *error;
  std::shared_ptr<Scene> scene = find_scene(query.scene_id);
  if (!scene) return not_found("scene_id", text("no scene ", quoted(query.scene_id)));
  const std::shared_ptr<const SceneDefinition>& definition = scene->definition();
  Expected<ResolvedOptions> options =
      resolve_options(definition->default_options, query.options, "options");
  if (!options) return options.error();
  if (auto error = check_report_bytes(*definition, *options, limits_.max_report_bytes, "options"))
    return *error;
  std::vector<Pose<double>> initial;
  initial.reserve(definition->objects.size());
  for (const SceneObject& object : definition->objects) initial.push_back(object.initial_pose);
  Expected<std::vector<Pose<double>>> poses =
      apply_poses(*definition, std::move(initial), query.poses, "poses");
  if (!poses) return poses.error();

  if (running_queries_.fetch_add(1) >= limits_.max_concurrent_queries) {
    running_queries_.fetch_sub(1);
    return resource_exhausted(
        "", text("the server is already evaluating ", limits_.max_concurrent_queries,
                 " queries (--max-concurrent-queries)"));
  }
  auto job = std::make_shared<Job>();
  job->scene = definition;
  job->poses = std::move(poses.value());
  job->options = options.value();
  job->received = received;
  job->state = std::make_shared<IncrementalState>();  // a query starts from nothing
  job->keep_state = false;
  job->report.sequence = query.sequence;
  if (job->options.warm_start) {
    scene->copy_query_cache(job->own_caches);
    job->caches = job->own_caches;
  }
  job->complete = [this, scene, done = std::move(done)](Job& finished) {
    if (finished.options.warm_start) scene->store_query_cache(finished.own_caches);
    running_queries_.fetch_sub(1);
    done(std::move(finished.report));
  };
  run(std::move(job));
  return {};
}

// ---- streams ----

Expected<std::unique_ptr<PoseStream>> SceneService::open_stream() {
  const std::size_t open = open_streams_.fetch_add(1);
  if (open >= limits_.max_streams) {
    open_streams_.fetch_sub(1);
    return resource_exhausted(
        "", text("the server already serves ", open, " pose streams; the limit is ",
                 limits_.max_streams, " (--max-streams)"));
  }
  return std::unique_ptr<PoseStream>(new PoseStream(*this));
}

PoseStream::PoseStream(SceneService& service) : service_(service) {}

PoseStream::~PoseStream() {
  service_.open_streams_.fetch_sub(1);
}

Expected<PreparedUpdate> PoseStream::prepare(const model::PoseUpdateInput& update,
                                             Clock::time_point received) {
  std::shared_ptr<Scene> scene = scene_;
  if (!scene || !update.scene_id.empty())
    if (auto error = check_id(update.scene_id, "scene_id")) return *error;
  if (!scene) {
    scene = service_.find_scene(update.scene_id);
    if (!scene) return not_found("scene_id", text("no scene ", quoted(update.scene_id)));
  } else if (!update.scene_id.empty() && update.scene_id != scene->definition()->id) {
    return Error{
        ErrorCode::failed_precondition, "scene_id",
        text("this stream is bound to scene ", quoted(scene->definition()->id),
             " by its first update; open another stream for scene ", quoted(update.scene_id))};
  }
  const SceneDefinition& definition = *scene->definition();
  if (scene->deleted())
    return not_found("scene_id", text("scene ", quoted(definition.id), " was deleted"));
  if (!scene_ && update.flow_control == model::FlowControl::unknown)
    return invalid_argument("flow_control", "unknown FlowControl value");
  if (has_sequence_ && update.sequence <= last_sequence_)
    return invalid_argument("sequence", text("must increase over the stream: got ", update.sequence,
                                             " after ", last_sequence_));
  Expected<ResolvedOptions> options =
      resolve_options(definition.default_options, update.options, "options");
  if (!options) return options.error();
  // Thresholds come with the first update (else the scene's); later ones keep them.
  std::shared_ptr<const WatchSet> watches = scene_ ? watches_ : definition.default_watches;
  if (!update.thresholds.empty()) {
    if (scene_)
      return invalid_argument("thresholds",
                              "are named by a stream's first update only; open another stream "
                              "to watch other thresholds");
    Expected<std::shared_ptr<const WatchSet>> resolved =
        resolve_thresholds(definition, update.thresholds, service_.limits_.max_pairs_per_scene);
    if (!resolved) return resolved.error();
    watches = std::move(resolved.value());
  }
  const std::size_t event_bytes = watches ? watches->event_bytes_per_update : 0;
  if (watches)
    if (auto error = check_cutoff(*watches, options->engine.distance_cutoff)) return *error;
  if (auto error = check_report_bytes(definition, *options, service_.limits_.max_report_bytes,
                                      "options", event_bytes))
    return *error;
  std::vector<Pose<double>> start;
  if (scene_) {
    start = current_poses_;
  } else {
    start.reserve(definition.objects.size());
    for (const SceneObject& object : definition.objects) start.push_back(object.initial_pose);
  }
  Expected<std::vector<Pose<double>>> poses =
      service_.apply_poses(definition, std::move(start), update.poses, "poses");
  if (!poses) return poses.error();

  // Accepted: only now does the stream's state change.
  if (!scene_) {
    scene_ = std::move(scene);
    caches_.assign(definition.piece_pair_count, SimplexCache{});
    flow_control_ = update.flow_control;
    watches_ = watches;
  }
  current_poses_ = poses.value();
  has_sequence_ = true;
  last_sequence_ = update.sequence;
  PreparedUpdate prepared;
  prepared.sequence = update.sequence;
  prepared.poses = std::move(poses.value());
  prepared.options = options.value();
  prepared.received = received;
  if (watches) {
    prepared.step.sequence = update.sequence;
    for (const model::ObjectPoseInput& pose : update.poses) {
      const auto object = std::uint32_t(definition.find_object(pose.object_id));
      if (watches->watched_object[object])
        prepared.step.moves.emplace_back(object, prepared.poses[object]);
    }
    // A merged report carries the crossings of every update it replays: as many as fit in one
    // message beside the pairs (checked above for one update's worth).
    const std::size_t room =
        service_.limits_.max_report_bytes - report_bytes_bound(definition, *options) - event_bytes;
    prepared.replay_limit =
        std::min(kMaxReplayedUpdates, room / std::max<std::size_t>(1, event_bytes));
  }
  return prepared;
}

void PoseStream::coalesce(PreparedUpdate& newer, const PreparedUpdate& older) {
  newer.coalesced_updates += older.coalesced_updates + 1;
  newer.coalesced_from_sequence =
      older.coalesced_updates > 0 ? older.coalesced_from_sequence : older.sequence;
  if (older.absorbed.empty() && older.step.moves.empty()) return;  // no watched object moved
  std::vector<WatchStep> steps = older.absorbed;
  if (!older.step.moves.empty()) steps.push_back(older.step);
  for (WatchStep& step : newer.absorbed) steps.push_back(std::move(step));
  // Beyond the limit the two oldest become one: the older one's poses are then judged together
  // with the newer one's (crossings between them may go unseen, never a report too large).
  while (steps.size() > newer.replay_limit) {
    if (steps.size() == 1) {
      steps.clear();
      break;
    }
    steps[1].moves.insert(steps[1].moves.begin(), steps[0].moves.begin(), steps[0].moves.end());
    steps.erase(steps.begin());
  }
  newer.absorbed = std::move(steps);
}

void PoseStream::evaluate(PreparedUpdate update, ReportCallback done) {
  auto job = std::make_shared<SceneService::Job>();
  job->scene = scene_->definition();
  job->poses = std::move(update.poses);
  job->options = update.options;
  if (update.options.warm_start) job->caches = caches_;
  if (!incremental_) {
    incremental_ = std::make_shared<IncrementalState>();
    if (watches_) {
      incremental_->watches = watches_;
      incremental_->inside.assign(watches_->watch_count(), 0);
    }
  }
  job->state = incremental_;
  job->replay = std::move(update.absorbed);
  job->received = update.received;
  job->report.sequence = update.sequence;
  job->report.coalesced_updates = update.coalesced_updates;
  job->report.coalesced_from_sequence = update.coalesced_from_sequence;
  job->complete = [done = std::move(done)](SceneService::Job& finished) {
    done(std::move(finished.report));
  };
  service_.run(std::move(job));
}

}  // namespace nearpoint::server
