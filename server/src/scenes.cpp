// SPDX-License-Identifier: Apache-2.0
// Scenes: their creation (inline geometries and objects, pair selection, report sizing,
// thresholds, then the commit), lookup and deletion.
#include <algorithm>
#include <cmath>
#include <functional>
#include <unordered_set>

#include "content_hash.hpp"
#include "incremental.hpp"
#include "nearpoint/server/scene_service.hpp"
#include "report_bytes.hpp"
#include "report_size.hpp"
#include "robot_scene.hpp"
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

/// The scene's inline geometries (SceneInput::geometries) by key: validated and given their
/// content ids, not stored yet (stored once the scene is known to be valid, so that a refused scene
/// leaves nothing behind but what it names).
Expected<InlineGeometries> build_inline_geometries(const model::SceneInput& input,
                                                   const ServiceLimits& limits) {
  if (input.geometries.size() > limits.max_objects_per_scene)
    return resource_exhausted(
        "geometries",
        text("has ", input.geometries.size(), " geometries; the limit is ",
             limits.max_objects_per_scene, " (--max-objects-per-scene, one per object at most)"));
  InlineGeometries out;
  for (const auto& [key, geometry] : input.geometries) {
    const std::string field = text("geometries[", quoted(key), ']');
    if (auto error = check_id(key, field)) return *error;
    Expected<std::shared_ptr<StoredGeometry>> built = build_geometry(geometry, limits);
    if (!built) {
      Error error = built.error();
      // build_geometry's paths start with "geometry" (RegisterGeometry's request field).
      if (error.field.rfind("geometry", 0) == 0) error.field.replace(0, 8, field);
      return error;
    }
    built.value()->info.geometry_id = geometry_content_id(geometry);
    out.emplace(key, std::move(built.value()));
  }
  return out;
}

/// The scene's objects, each resolved to its geometry (an inline one first, else `stored(id)`),
/// checked and indexed by id; bodies are numbered in order of first use.
Outcome add_objects(
    SceneDefinition& scene, const std::vector<model::ObjectInput>& objects,
    const InlineGeometries& inline_geometries,
    const std::function<std::shared_ptr<const StoredGeometry>(const std::string&)>& stored) {
  std::unordered_map<std::string, std::size_t> bodies;  // body id → index
  scene.objects.reserve(objects.size());
  for (std::size_t i = 0; i < objects.size(); ++i) {
    const model::ObjectInput& object = objects[i];
    const std::string field = text("objects[", i, ']');
    if (auto error = check_id(object.id, field + ".id")) return *error;
    if (const auto [it, inserted] = scene.index_by_id.emplace(object.id, std::uint32_t(i));
        !inserted)
      return invalid_argument(
          field + ".id",
          text(quoted(object.id), " is already the id of objects[", it->second, "]"));
    if (auto error = check_id(object.geometry_id, field + ".geometry_id")) return *error;
    std::shared_ptr<const StoredGeometry> geometry;
    if (const auto sent = inline_geometries.find(object.geometry_id);
        sent != inline_geometries.end())
      geometry = sent->second;
    else
      geometry = stored(object.geometry_id);
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
    scene.objects.push_back(
        SceneObject{object.id, std::move(geometry), pose.value(), object.group.value_or(1u),
                    object.mask.value_or(0xFFFFFFFFu), object.padding, object.self_padding, body});
  }
  return {};
}

/// The scene's pairs, as `selection` chooses them: the listed ones, or every pair of objects
/// whose groups and masks let them meet, less the excluded ones; within the pair limits.
Outcome select_pairs(SceneDefinition& scene, const model::PairSelectionInput& selection,
                     const ServiceLimits& limits) {
  const std::vector<SceneObject>& objects = scene.objects;
  auto add_pair = [&](std::uint32_t a, std::uint32_t b, const std::string& field) -> Outcome {
    if (scene.pairs.size() >= limits.max_pairs_per_scene)
      return resource_exhausted(field,
                                text("the scene selects more than ", limits.max_pairs_per_scene,
                                     " pairs (--max-pairs-per-scene)"));
    const std::size_t count =
        objects[a].geometry->compound.size() * objects[b].geometry->compound.size();
    if (scene.piece_pair_count + count > limits.max_piece_pairs_per_scene)
      return resource_exhausted(
          field, text("the scene's pairs hold more than ", limits.max_piece_pairs_per_scene,
                      " piece pairs (--max-piece-pairs-per-scene)"));
    const SceneObject& object_a = objects[a];
    const SceneObject& object_b = objects[b];
    const bool self = object_a.body >= 0 && object_a.body == object_b.body;
    const double padding =
        self ? object_a.self_padding + object_b.self_padding : object_a.padding + object_b.padding;
    scene.pairs.push_back(ScenePair{a, b, scene.piece_pair_count, count, padding});
    scene.piece_pair_count += count;
    return {};
  };
  // Resolves a listed pair's two ids; `field` is the pair's path.
  auto resolve_pair =
      [&](const std::pair<std::string, std::string>& pair,
          const std::string& field) -> Expected<std::pair<std::uint32_t, std::uint32_t>> {
    if (auto error = check_id(pair.first, field + ".object_a")) return *error;
    if (auto error = check_id(pair.second, field + ".object_b")) return *error;
    const std::int64_t a = scene.find_object(pair.first);
    if (a < 0)
      return not_found(field + ".object_a",
                       text("no object ", quoted(pair.first), " in the scene"));
    const std::int64_t b = scene.find_object(pair.second);
    if (b < 0)
      return not_found(field + ".object_b",
                       text("no object ", quoted(pair.second), " in the scene"));
    if (a == b) return invalid_argument(field, "must name two different objects");
    return std::pair(std::uint32_t(a), std::uint32_t(b));
  };
  auto key = [](std::uint32_t a, std::uint32_t b) {
    return (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
  };

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
    return {};
  }
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
  return {};
}

/// Sizes the scene's reports and refuses the scene when one in its default report mode could not
/// be sent: a report that could not be sent could never answer an update, so the client is told
/// now, while it can still choose fewer pairs or shorter ids. (Requests asking for more than the
/// scene's defaults are checked the same way: query, PoseStream::prepare.) Then splits the
/// scene's evaluations into tasks by their estimated cost, and indexes each object's pairs.
Outcome size_reports(SceneDefinition& scene, const ServiceLimits& limits, std::size_t workers) {
  const std::vector<SceneObject>& objects = scene.objects;
  scene.report_bytes_base = report_size::kReportEnvelope;
  for (const SceneObject& object : objects)
    scene.longest_object_id = std::max(scene.longest_object_id, object.id.size());
  for (const ScenePair& pair : scene.pairs)
    scene.report_bytes_base +=
        report_size::kPairEntryOverhead + report_size::kPairFixed +
        report_size::pair_ids(objects[pair.object_a].id.size(), objects[pair.object_b].id.size());
  if (auto error = check_report_bytes(scene, scene.default_options, limits.max_report_bytes, ""))
    return *error;

  std::size_t visits = 0;
  for (const ScenePair& pair : scene.pairs)
    visits +=
        pair_cost(objects[pair.object_a].geometry->info, objects[pair.object_b].geometry->info);
  scene.tasks_per_evaluation =
      std::clamp<std::size_t>(visits / kVisitsPerTask, 1, std::max<std::size_t>(1, workers));
  index_object_pairs(scene);
  return {};
}

/// The scene's default thresholds (CreateSceneRequest.thresholds), checked against its default
/// cutoff and its report size.
Outcome watch_default_thresholds(SceneDefinition& scene,
                                 const std::vector<model::ThresholdInput>& thresholds,
                                 const ServiceLimits& limits) {
  if (thresholds.empty()) return {};
  Expected<std::shared_ptr<const WatchSet>> watches =
      resolve_thresholds(scene, thresholds, limits.max_pairs_per_scene,
                         scene.default_options.engine.penetration_depth);
  if (!watches) return watches.error();
  if (auto error = check_cutoff(**watches, scene.default_options.engine.distance_cutoff))
    return Error{error->code, "default_options.distance_cutoff", error->message};
  if (auto error = check_report_bytes(scene, scene.default_options, limits.max_report_bytes, "",
                                      (*watches)->event_bytes_per_update))
    return *error;
  scene.default_watches = std::move(watches.value());
  return {};
}

}  // namespace

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

Expected<model::SceneInfo> SceneService::create_scene(const model::SceneInput& input) {
  if (auto error = check_name(input.name, "name")) return *error;
  if (!input.requested_id.empty())
    if (auto error = check_id(input.requested_id, "scene_id")) return *error;
  if (input.objects.empty()) return invalid_argument("objects", "must hold at least one object");
  if (input.objects.size() > limits_.max_objects_per_scene)
    return resource_exhausted("objects",
                              text("has ", input.objects.size(), " objects; the limit is ",
                                   limits_.max_objects_per_scene, " (--max-objects-per-scene)"));
  Expected<InlineGeometries> inline_geometries = build_inline_geometries(input, limits_);
  if (!inline_geometries) return inline_geometries.error();

  auto scene = std::make_shared<SceneDefinition>();
  scene->name = input.name;
  scene->fingerprint = input.fingerprint;
  if (Outcome added = add_objects(*scene, input.objects, *inline_geometries,
                                  [this](const std::string& id) { return find_geometry(id); });
      !added)
    return added.error();
  if (!input.robot.empty()) {
    Expected<std::shared_ptr<const SceneRobot>> robot = build_scene_robot(input.robot, *scene);
    if (!robot) return robot.error();
    scene->robot = std::move(robot.value());
    // Streams and queries start with every joint at its reference, the base at the identity.
    std::vector<Pose<double>> poses;
    for (const SceneObject& object : scene->objects) poses.push_back(object.initial_pose);
    Expected<std::shared_ptr<const RobotUpdate>> start = apply_joint_positions(
        *scene, initial_position(*scene->robot), model::JointPositionsInput{}, poses, "robot");
    if (!start) return start.error();
    for (std::size_t o = 0; o < poses.size(); ++o) scene->objects[o].initial_pose = poses[o];
  }
  Expected<ResolvedOptions> defaults =
      resolve_options(ResolvedOptions{}, input.default_options, "default_options");
  if (!defaults) return defaults.error();
  scene->default_options = defaults.value();
  if (Outcome selected = select_pairs(*scene, input.pair_selection, limits_); !selected)
    return selected.error();
  if (Outcome sized = size_reports(*scene, limits_, pool_.size()); !sized) return sized.error();
  if (Outcome watched = watch_default_thresholds(*scene, input.thresholds, limits_); !watched)
    return watched.error();
  return commit_scene(std::move(scene), input, *inline_geometries);
}

Expected<model::SceneInfo> SceneService::commit_scene(std::shared_ptr<SceneDefinition> scene,
                                                      const model::SceneInput& input,
                                                      const InlineGeometries& inline_geometries) {
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

std::vector<std::shared_ptr<const SceneDefinition>> SceneService::list_scenes() const {
  std::vector<std::shared_ptr<const SceneDefinition>> out;
  {
    std::shared_lock lock(scenes_mutex_);
    out.reserve(scenes_.size());
    for (const auto& [id, scene] : scenes_) out.push_back(scene->definition());
  }
  // The map's order is arbitrary: sort, so that a listing is stable from call to call.
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a->id < b->id; });
  return out;
}

Expected<std::vector<Pose<double>>> SceneService::apply_poses(
    const SceneDefinition& scene, std::vector<Pose<double>> poses,
    const std::vector<model::ObjectPoseInput>& updates, const char* field) const {
  std::vector<char> seen(scene.objects.size(), 0);
  for (std::size_t j = 0; j < updates.size(); ++j) {
    // The entry's field path ("poses[3].object_id") is spelled only when the entry is refused:
    // accepting an update builds no strings (a formatted name per pose was a stream's largest
    // allocation cost).
    const auto refused = [&](Error error) {
      error.field = text(field, '[', j, "].", error.field);
      return error;
    };
    if (auto error = check_id(updates[j].object_id, "object_id")) return refused(*error);
    const std::int64_t index = scene.find_object(updates[j].object_id);
    if (index < 0)
      return refused(not_found("object_id", text("no object ", quoted(updates[j].object_id),
                                                 " in scene ", quoted(scene.id))));
    if (seen[std::size_t(index)]++)
      return refused(invalid_argument(
          "object_id", text("object ", quoted(updates[j].object_id), " is listed twice")));
    if (scene.robot && scene.robot->object_link[std::size_t(index)] >= 0)
      return refused(invalid_argument(
          "object_id",
          text("object ", quoted(updates[j].object_id), " rides on link ",
               quoted(scene.robot->tree
                          .links[std::size_t(scene.robot->object_link[std::size_t(index)])]
                          .name),
               " of the robot: send joint positions (joints) instead of its pose")));
    Expected<Pose<double>> pose = check_pose(updates[j].pose, "pose");
    if (!pose) return refused(pose.error());
    poses[std::size_t(index)] = pose.value();
  }
  return poses;
}

}  // namespace nearpoint::server
