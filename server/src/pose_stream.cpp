// SPDX-License-Identifier: Apache-2.0
// Pose streams: a client's sequence of updates on one scene, each validated against the stream's
// state, merged when the server is behind, and evaluated with the stream's own caches.
#include <algorithm>

#include "evaluation_job.hpp"
#include "incremental.hpp"
#include "report_bytes.hpp"
#include "robot_scene.hpp"
#include "thresholds.hpp"
#include "validation.hpp"

namespace nearpoint::server {

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
        resolve_thresholds(definition, update.thresholds, service_.limits_.max_pairs_per_scene,
                           options->engine.penetration_depth);
    if (!resolved) return resolved.error();
    watches = std::move(resolved.value());
  }
  const std::size_t event_bytes = watches ? watches->event_bytes_per_update : 0;
  if (watches) {
    if (auto error = check_cutoff(*watches, options->engine.distance_cutoff)) return *error;
    if (auto error = check_penetration(*watches, *options)) return *error;
  }
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
  std::shared_ptr<const RobotUpdate> robot;
  if (definition.robot) {
    // Every update carries the robot's state, joints given or not (its report names violations).
    if (current_robot_ && scene_ && update.joints.empty()) {
      robot = current_robot_;
    } else {
      Expected<std::shared_ptr<const RobotUpdate>> applied = apply_joint_positions(
          definition,
          current_robot_ && scene_ ? current_robot_->position : initial_position(*definition.robot),
          update.joints, poses.value(), "joints");
      if (!applied) return applied.error();
      robot = std::move(applied.value());
    }
  } else if (!update.joints.empty()) {
    return Error{
        ErrorCode::failed_precondition, "joints",
        text("scene ", quoted(definition.id), " has no robot: move its objects by their poses")};
  }

  // Accepted: only now does the stream's state change.
  if (!scene_) {
    scene_ = std::move(scene);
    caches_.assign(definition.piece_pair_count, SimplexCache{});
    flow_control_ = update.flow_control;
    watches_ = watches;
  }
  current_poses_ = poses.value();
  current_robot_ = robot;
  has_sequence_ = true;
  last_sequence_ = update.sequence;
  PreparedUpdate prepared;
  prepared.sequence = update.sequence;
  prepared.poses = std::move(poses.value());
  prepared.options = options.value();
  prepared.received = received;
  prepared.robot = std::move(robot);
  if (watches) {
    prepared.step.sequence = update.sequence;
    for (const model::ObjectPoseInput& pose : update.poses) {
      const auto object = std::uint32_t(definition.find_object(pose.object_id));
      if (watches->watched_object[object])
        prepared.step.moves.emplace_back(object, prepared.poses[object]);
    }
    // The objects the robot carries moved with its joints.
    if (definition.robot && !update.joints.empty())
      for (std::size_t object = 0; object < definition.objects.size(); ++object)
        if (definition.robot->object_link[object] >= 0 && watches->watched_object[object])
          prepared.step.moves.emplace_back(std::uint32_t(object), prepared.poses[object]);
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

std::shared_ptr<EvaluationJob> PoseStream::take_evaluation(PreparedUpdate update) {
  auto job = std::make_shared<EvaluationJob>();
  job->scene = scene_->definition();
  job->poses = std::move(update.poses);
  job->robot = std::move(update.robot);
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
  return job;
}

void PoseStream::evaluate(PreparedUpdate update, ReportCallback done) {
  std::shared_ptr<EvaluationJob> job = take_evaluation(std::move(update));
  job->complete = [done = std::move(done)](EvaluationJob& finished) {
    done(std::move(finished.report));
  };
  service_.run(std::move(job));
}

bool PoseStream::evaluates_inline() const {
  return service_.limits().inline_evaluation && scene_ &&
         scene_->definition()->tasks_per_evaluation <= 1;
}

Report PoseStream::run_evaluation(EvaluationJob& job) {
  Report report;
  job.complete = [&report](EvaluationJob& finished) { report = std::move(finished.report); };
  service_.run_here(job);
  return report;
}

}  // namespace nearpoint::server
