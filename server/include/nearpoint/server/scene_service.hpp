// SPDX-License-Identifier: Apache-2.0
// The scene API: geometry store, scenes, unary queries and pose streams, independent of any
// transport. The gRPC service is a thin adapter over it, and so will be the DDS bridge.
//
// Threading: every method may be called from any thread. Geometry runs on the service's worker
// pool; callbacks (`ReportCallback`) run on a pool thread.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <shared_mutex>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "nearpoint/compound.hpp"
#include "nearpoint/options.hpp"
#include "nearpoint/server/errors.hpp"
#include "nearpoint/server/limits.hpp"
#include "nearpoint/server/report.hpp"
#include "nearpoint/server/worker_pool.hpp"

namespace nearpoint::server {

struct WatchSet;
struct SceneRobot;
struct RobotUpdate;
struct RobotPosition;

/// A validated, immutable geometry: the engine's compound plus what the broad phase needs.
/// Shared (shared_ptr<const>) by the store and every scene object that uses it.
struct StoredGeometry {
  model::GeometryInfo info;
  Compound<double> compound;
  /// Order of first registration (ListGeometries lists by it; ids are content hashes).
  std::uint64_t registration = 0;
};

/// A scene request's inline geometries by key, validated but not yet stored.
using InlineGeometries = std::unordered_map<std::string, std::shared_ptr<StoredGeometry>>;

/// Options after inheritance and validation: what the engine is run with.
struct ResolvedOptions {
  DistanceOptions<double> engine;
  bool warm_start = true;
  /// Never unspecified/unknown once resolved.
  model::ReportMode report_mode = model::ReportMode::all_pairs;
  /// REPORT_MODE_CHANGED's distance tolerance, metres (only chooses what is sent).
  double change_tolerance = 0;
};

struct SceneObject {
  std::string id;
  std::shared_ptr<const StoredGeometry> geometry;
  /// Geometry frame → world frame.
  Pose<double> initial_pose;
  std::uint32_t group = 1;
  std::uint32_t mask = 0xFFFFFFFFu;
  /// Metres (see nearpoint.v1.SceneObject); and the body's index (-1: a body of its own).
  double padding = 0;
  double self_padding = 0;
  std::int64_t body = -1;
};

struct ScenePair {
  std::uint32_t object_a = 0;
  std::uint32_t object_b = 0;
  /// This pair's warm-start caches: `cache_count` (= pieces of A × pieces of B) entries from
  /// `cache_offset` in a per-stream (or per-scene query) cache array.
  std::size_t cache_offset = 0;
  std::size_t cache_count = 0;
  /// The pair's padding, metres: the sum of its objects' paddings (self paddings for a pair of
  /// one body). Reports are those of the padded objects.
  double padding = 0;
};

/// A scene's immutable part: objects, selected pairs, default options.
class SceneDefinition {
 public:
  std::string id;
  std::string name;
  std::vector<SceneObject> objects;
  std::vector<ScenePair> pairs;
  ResolvedOptions default_options;
  /// SceneInput::fingerprint of the request that created it ("" for none): an identical request
  /// for the same id is answered as the first was. `info` is that first answer.
  std::string fingerprint;
  model::SceneInfo info;
  /// Sum of cache_count over the pairs: the size of one warm-start cache array.
  std::size_t piece_pair_count = 0;
  /// An upper bound on the bytes of this scene's reports without near points, penetration
  /// bounds or gradients (the envelope plus each pair's ids and fixed fields), and the longest
  /// object id; see report_size.hpp.
  std::size_t report_bytes_base = 0;
  std::size_t longest_object_id = 0;
  /// The scene's default thresholds (CreateSceneRequest.thresholds; null: none): what a stream
  /// watches when its first update names none.
  std::shared_ptr<const WatchSet> default_watches;
  /// How many pool tasks one evaluation is split into (1 … workers), from the scene's estimated
  /// GJK cost: splitting only pays when each task outweighs the cost of waking a worker.
  std::size_t tasks_per_evaluation = 1;
  /// The scene's robot (CreateSceneRequest.robot; null: none): the objects its links carry move
  /// by joint positions (robot_scene.hpp).
  std::shared_ptr<const SceneRobot> robot;

  /// Index of an object by id, or -1.
  std::int64_t find_object(const std::string& object_id) const;
  std::unordered_map<std::string, std::uint32_t> index_by_id;
  /// Each object's pairs: `object_pairs[object_pairs_begin[i] .. object_pairs_begin[i + 1])` are
  /// the indices in `pairs` of the pairs object i belongs to, so that an update that moves k
  /// objects visits only their pairs.
  std::vector<std::uint32_t> object_pairs_begin;
  std::vector<std::uint32_t> object_pairs;
};

/// A live scene: its definition plus the mutable state that unary queries share.
class Scene {
 public:
  explicit Scene(std::shared_ptr<const SceneDefinition> definition);
  const std::shared_ptr<const SceneDefinition>& definition() const { return definition_; }

  /// The warm-start caches unary queries share. Queries copy them out under the lock, evaluate
  /// without it, and copy their caches back: concurrent queries never hold the lock during
  /// geometry, and a lost write-back only costs a colder start (any cache content is valid).
  void copy_query_cache(std::vector<SimplexCache>& out);
  void store_query_cache(const std::vector<SimplexCache>& caches);

  /// Set by DeleteScene; streams bound to the scene reject their next updates.
  bool deleted() const { return deleted_.load(std::memory_order_acquire); }
  void mark_deleted() { deleted_.store(true, std::memory_order_release); }

 private:
  std::shared_ptr<const SceneDefinition> definition_;
  std::mutex query_cache_mutex_;
  std::vector<SimplexCache> query_cache_;
  std::atomic<bool> deleted_{false};
};

/// The poses one update set on watched objects (object index, world pose), and its sequence:
/// what a merged update replays for the crossings of the updates it absorbed.
struct WatchStep {
  std::uint64_t sequence = 0;
  std::vector<std::pair<std::uint32_t, Pose<double>>> moves;
};

/// An update that passed validation: everything its evaluation needs, by value.
struct PreparedUpdate {
  std::uint64_t sequence = 0;
  /// Every object's pose (world frame) after this update, in scene object order.
  std::vector<Pose<double>> poses;
  ResolvedOptions options;
  /// When the transport read it (for ReportTiming).
  Clock::time_point received;
  std::uint32_t coalesced_updates = 0;
  std::uint64_t coalesced_from_sequence = 0;
  /// With thresholds: the poses this update set on watched objects, and those of the updates it
  /// absorbed (oldest first, at most `replay_limit` of them), replayed for their crossings.
  WatchStep step;
  std::vector<WatchStep> absorbed;
  std::size_t replay_limit = 0;
  /// Robot scenes: the robot's positions and kinematics after this update (joint gradients and
  /// limit violations of its report).
  std::shared_ptr<const RobotUpdate> robot;
};

using ReportCallback = std::function<void(Report)>;

class SceneService;
struct IncrementalState;
/// One evaluation on its way through the service (evaluation_job.hpp).
struct EvaluationJob;

/// One client's pose stream: it owns the per-pair, per-piece-pair warm-start caches, so streams
/// never share mutable state. Not thread-safe: its owner serialises calls (the gRPC reactor does
/// so under its lock), and runs at most one evaluation at a time, because each evaluation reads
/// and writes the caches.
class PoseStream {
 public:
  ~PoseStream();
  PoseStream(const PoseStream&) = delete;
  PoseStream& operator=(const PoseStream&) = delete;

  /// Validates `update` against the stream's state (scene binding, sequence order, poses,
  /// options) and, if it is accepted, records its poses as the stream's current ones. Cheap: no
  /// geometry. `field` paths are relative to the update ("poses[1].pose.rotation").
  Expected<PreparedUpdate> prepare(const model::PoseUpdateInput& update,
                                   Clock::time_point received);

  /// Folds `older` (accepted earlier, not yet evaluated) into `newer`: since a prepared update
  /// carries every object's pose, the newer one already holds the older one's poses. With
  /// thresholds, `newer` keeps the poses `older` (and what it absorbed) set on watched objects,
  /// so that the crossings they caused are still reported.
  static void coalesce(PreparedUpdate& newer, const PreparedUpdate& older);

  /// Evaluates the update on the worker pool; `done` gets the report (every selected pair) on a
  /// pool thread. Only pairs with an object whose pose changed since the stream's previous
  /// evaluation (or all, when the options changed) reach the engine, unless the broad phase
  /// proves them beyond the cutoff; the others repeat their previous result (Report::counts).
  /// Call again only after `done` has run (the caches and that state are this stream's mutable
  /// state).
  void evaluate(PreparedUpdate update, ReportCallback done);

  /// Whether an evaluation of this stream's scene is small enough (one task's worth of pairs,
  /// SceneDefinition::tasks_per_evaluation) that handing it to a worker costs more than it
  /// saves: a transport then calls evaluate_here on its own thread. Profiles of cell45 (45
  /// polytope pairs) spent a third of nearpointd's CPU on the thread hand-offs.
  bool evaluates_inline() const;
  /// As `evaluate`, on the calling thread, in two steps: `take` (under the owner's lock, like
  /// every other call: the job that evaluates `update` against this stream's caches and
  /// incremental state) and `run` (without it: it touches only the job and the stream's caches
  /// and results, which no other call does while an evaluation is under way).
  std::shared_ptr<EvaluationJob> take_evaluation(PreparedUpdate update);
  Report run_evaluation(EvaluationJob& job);

  /// The flow-control policy chosen by the first update (block until then).
  model::FlowControl flow_control() const { return flow_control_; }
  bool bound() const { return scene_ != nullptr; }

 private:
  friend class SceneService;
  explicit PoseStream(SceneService& service);

  SceneService& service_;
  std::shared_ptr<Scene> scene_;
  std::vector<Pose<double>> current_poses_;
  /// Robot scenes: the robot's state after the latest accepted update (null before the first).
  std::shared_ptr<const RobotUpdate> current_robot_;
  std::vector<SimplexCache> caches_;
  /// The previous evaluation's poses, options and results, and the broad phase's boxes: pairs of
  /// unmoved objects are not evaluated again.
  std::shared_ptr<IncrementalState> incremental_;
  /// The thresholds named by the first update (null: none).
  std::shared_ptr<const WatchSet> watches_;
  bool has_sequence_ = false;
  std::uint64_t last_sequence_ = 0;
  model::FlowControl flow_control_ = model::FlowControl::block;
  bool evaluating_ = false;
};

class SceneService {
 public:
  /// `workers` = 0: one per hardware thread.
  SceneService(const ServiceLimits& limits, std::size_t workers);
  ~SceneService();
  SceneService(const SceneService&) = delete;
  SceneService& operator=(const SceneService&) = delete;

  /// Validates (finite, non-empty, within limits, radii >= 0, unit quaternions) and stores under
  /// its content id (content_hash.hpp): the same geometry again is stored once and answered the
  /// same. Error fields start with "geometry.".
  Expected<model::GeometryInfo> register_geometry(const model::GeometryInput& geometry);
  Outcome remove_geometry(const std::string& geometry_id);
  std::vector<model::GeometryInfo> list_geometries() const;

  /// Stores the scene's inline geometries (as register_geometry would) and creates it. A taken
  /// requested_id is ALREADY_EXISTS unless the request's fingerprint matches the scene's.
  Expected<model::SceneInfo> create_scene(const model::SceneInput& scene);
  Outcome delete_scene(const std::string& scene_id);
  /// The live scene, or nullptr.
  std::shared_ptr<Scene> find_scene(const std::string& scene_id) const;
  /// Every live scene's definition, ordered by scene id (ListScenes; `nearpoint scene list`).
  std::vector<std::shared_ptr<const SceneDefinition>> list_scenes() const;

  /// Validates the query now (the error, if any, is returned and `done` is never called) and
  /// evaluates it on the pool; `done` runs exactly once, on a pool thread.
  Outcome query(const model::QueryInput& query, Clock::time_point received, ReportCallback done);

  /// A new stream, or RESOURCE_EXHAUSTED when `max_streams` are open.
  Expected<std::unique_ptr<PoseStream>> open_stream();

  const ServiceLimits& limits() const { return limits_; }
  std::size_t worker_count() const { return pool_.size(); }
  std::size_t open_streams() const { return open_streams_.load(); }
  /// Live scenes and stored geometries (the metrics' gauges, read at each scrape).
  std::size_t scene_count() const;
  std::size_t geometry_count() const;

 private:
  friend class PoseStream;
  using Job = EvaluationJob;
  /// Runs `job`'s pairs on the pool, in parallel, and calls its completion on the last one.
  void run(std::shared_ptr<Job> job);
  /// Runs `job` on the calling thread, as one task; its completion runs before this returns.
  void run_here(Job& job);
  /// Replays absorbed updates, plans the evaluation (what moved, the broad phase) and sets the
  /// job's task count, which it returns.
  std::size_t plan(Job& job);
  /// One task: takes pairs until none are left; the last task to finish completes the job.
  static void run_task(Job& job);
  Expected<std::vector<Pose<double>>> apply_poses(
      const SceneDefinition& scene, std::vector<Pose<double>> poses,
      const std::vector<model::ObjectPoseInput>& updates, const char* field) const;

  ServiceLimits limits_;

  mutable std::shared_mutex geometries_mutex_;
  std::unordered_map<std::string, std::shared_ptr<const StoredGeometry>> geometries_;
  std::uint64_t next_geometry_number_ = 1;
  /// Stores `geometry` under its id unless that id is stored already; the stored one either way,
  /// or RESOURCE_EXHAUSTED at --max-geometries. `field` names it in that error.
  Expected<std::shared_ptr<const StoredGeometry>> store_geometry(
      std::shared_ptr<StoredGeometry> geometry, const std::string& field);
  /// The stored geometry `geometry_id`, or nullptr.
  std::shared_ptr<const StoredGeometry> find_geometry(const std::string& geometry_id) const;
  /// The last step of create_scene: stores the scene's inline geometries, then the scene under
  /// its requested id (or the next free "scene-N"), unless the id is taken.
  Expected<model::SceneInfo> commit_scene(std::shared_ptr<SceneDefinition> scene,
                                          const model::SceneInput& input,
                                          const InlineGeometries& inline_geometries);

  mutable std::shared_mutex scenes_mutex_;
  std::unordered_map<std::string, std::shared_ptr<Scene>> scenes_;
  std::uint64_t next_scene_number_ = 1;

  std::atomic<std::size_t> open_streams_{0};
  std::atomic<std::size_t> running_queries_{0};

  // Last member: destroyed first, so queued work finishes while everything above still exists.
  WorkerPool pool_;
};

}  // namespace nearpoint::server
