// SPDX-License-Identifier: Apache-2.0
// The evaluation of a scene's pairs on the worker pool (SceneService::run), and the unary query
// that starts one.
#include "evaluation_job.hpp"

#include <algorithm>
#include <cmath>

#include "evaluation.hpp"
#include "metrics.hpp"
#include "report_bytes.hpp"
#include "robot_scene.hpp"
#include "thresholds.hpp"
#include "validation.hpp"

namespace nearpoint::server {
namespace {

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

void SceneService::run_task(Job& job) {
  // One task of the evaluation: takes pairs one at a time from a shared counter, so uneven pairs
  // (a 100-vertex hull next to a sphere) balance across the workers without any partitioning.
  IncrementalState& state = *job.state;
  const std::size_t count = job.evaluate.size();
  metrics::PairTally tally;  // recorded once per task, not per pair
  const bool tallying = metrics::enabled();
  // The task's pair loop is timed as a whole, not pair by pair: two clock reads per pair were
  // about 3 % of a 45-pair update's CPU. What the loop adds to the engine's time (taking the
  // next index, the tally) is a few nanoseconds per pair.
  const Clock::time_point begin = Clock::now();
  for (;;) {
    const std::size_t i = job.next_pair.fetch_add(1, std::memory_order_relaxed);
    if (i >= count) break;
    const std::uint32_t p = job.evaluate[i];
    const ScenePair& pair = job.scene->pairs[p];
    const std::span<SimplexCache> caches =
        job.caches.empty() ? std::span<SimplexCache>{}
                           : job.caches.subspan(pair.cache_offset, pair.cache_count);
    evaluate_pair(*job.scene, pair, job.poses, job.options, caches, state.pairs[p]);
    if (tallying) tally.add(state.pairs[p].iterations, state.pairs[p].warm_started);
  }
  job.geometry_ns.fetch_add(std::chrono::nanoseconds(Clock::now() - begin).count(),
                            std::memory_order_relaxed);
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
  if (job.robot) {
    if (job.options.engine.gradient) add_joint_gradients(*job.scene, *job.robot, job.report);
    job.report.joint_limit_violations = job.robot->violations;
  }
  const Clock::time_point end = Clock::now();
  model::ReportTiming& timing = job.report.timing;
  timing.server_us = microseconds(end - job.received);
  timing.queue_us = microseconds(job.started - job.received);
  timing.evaluation_us = microseconds(end - job.started);
  timing.geometry_us = double(job.geometry_ns.load(std::memory_order_relaxed)) / 1000.0;
  // A query's state is its own (keep_state false); a stream's outlives the job.
  metrics::record_report(!job.keep_state, timing, job.report.counts, job.report.coalesced_updates);
  job.complete(job);
}

std::size_t SceneService::plan(Job& job) {
  job.started = Clock::now();  // time before this is queueing
  if (job.state->watches && !job.replay.empty())
    replay_steps(*job.scene, *job.state, job.replay, job.options, job.caches, job.replayed_pairs,
                 job.report.events);
  plan_evaluation(*job.scene, job.poses, job.options, *job.state, job.evaluate, job.report.counts);
  const std::size_t tasks =
      std::max<std::size_t>(1, std::min(job.evaluate.size(), job.scene->tasks_per_evaluation));
  job.tasks_left.store(tasks, std::memory_order_relaxed);
  return tasks;
}

void SceneService::run(std::shared_ptr<Job> job) {
  // Planning (which objects moved, the broad phase) touches every pair of a moved object, and the
  // last task copies results into the report, so for a scene worth splitting both run on the
  // pool; planning then splits the pairs that reach the engine into tasks, this one included.
  // (Smaller evaluations of streams run where they were read: run_here.)
  pool_.post([this, job] {
    const std::size_t tasks = plan(*job);
    for (std::size_t t = 1; t < tasks; ++t) pool_.post([job] { run_task(*job); });
    run_task(*job);
  });
}

void SceneService::run_here(Job& job) {
  // One task whatever the scene's split: the caller chose this thread because the scene's
  // evaluation is too small to pay for waking a worker (SceneDefinition::tasks_per_evaluation).
  plan(job);
  job.tasks_left.store(1, std::memory_order_relaxed);
  run_task(job);
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
  std::shared_ptr<const RobotUpdate> robot;
  if (definition->robot) {
    Expected<std::shared_ptr<const RobotUpdate>> applied = apply_joint_positions(
        *definition, initial_position(*definition->robot), query.joints, poses.value(), "joints");
    if (!applied) return applied.error();
    robot = std::move(applied.value());
  } else if (!query.joints.empty()) {
    return Error{ErrorCode::failed_precondition, "joints",
                 text("scene ", quoted(definition->id), " has no robot")};
  }

  if (running_queries_.fetch_add(1) >= limits_.max_concurrent_queries) {
    running_queries_.fetch_sub(1);
    return resource_exhausted(
        "", text("the server is already evaluating ", limits_.max_concurrent_queries,
                 " queries (--max-concurrent-queries)"));
  }
  auto job = std::make_shared<Job>();
  job->scene = definition;
  job->poses = std::move(poses.value());
  job->robot = std::move(robot);
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

}  // namespace nearpoint::server
