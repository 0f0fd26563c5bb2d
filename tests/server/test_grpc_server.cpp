// SPDX-License-Identifier: Apache-2.0
// Integration tests: a real in-process server on 127.0.0.1:0, driven through the generated gRPC
// client. Every reported distance is checked against the engine run locally on the same poses.
#include <google/protobuf/descriptor.h>
#include <grpcpp/generic/generic_stub.h>

#include <atomic>
#include <cstdio>
#include <functional>
#include <future>
#include <limits>
#include <random>
#include <thread>

#include "common/exact_distance.hpp"
#include "common/held_workers.hpp"
#include "common/paper_family.hpp"
#include "scene_fixture.hpp"
#include "tsan_handoff.hpp"

namespace nearpoint::server::testing {
namespace {

class GrpcServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ServerConfig config = test_config();
    config.limits.max_vertices_per_geometry = 2000;
    config.max_message_bytes = 1u << 20;
    running_ = start_server(config);
    ASSERT_TRUE(running_.server);
  }
  v1::DistanceService::Stub& stub() { return *running_.stub; }

  RunningServer running_;
};

// For the tests that hold the worker pool to make updates wait: every evaluation on the pool.
class GrpcServerPoolTest : public GrpcServerTest {
 protected:
  void SetUp() override {
    ServerConfig config = test_config();
    config.limits.max_vertices_per_geometry = 2000;
    config.max_message_bytes = 1u << 20;
    config.limits.inline_evaluation = false;
    running_ = start_server(config);
    ASSERT_TRUE(running_.server);
  }
};

// The stream tests that take a parameter run on StreamPoses (0) and on StreamPoseBatches with
// 1 and with 7 updates per message (7 divides none of their update counts: the last batch is a
// partial one): each update of a batch must be handled exactly as if it had been sent alone.
std::string framing_name(const ::testing::TestParamInfo<std::size_t>& info) {
  return info.param == 0 ? "StreamPoses" : "Batches" + std::to_string(info.param);
}
const auto kFramings = ::testing::Values(std::size_t(0), std::size_t(1), std::size_t(7));

class GrpcStreamTest : public GrpcServerTest, public ::testing::WithParamInterface<std::size_t> {};
INSTANTIATE_TEST_SUITE_P(Framing, GrpcStreamTest, kFramings, framing_name);
class GrpcStreamPoolTest : public GrpcServerPoolTest,
                           public ::testing::WithParamInterface<std::size_t> {};
INSTANTIATE_TEST_SUITE_P(Framing, GrpcStreamPoolTest, kFramings, framing_name);

// ---- streams ----

// The main path: a pipelined stream of 300 poses along a smooth trajectory (a writer thread
// sends while the reader checks), every report in order with its sequence number and every
// distance equal to the engine's within the error bounds.
TEST_P(GrpcStreamTest, StreamedTrajectoryMatchesTheEngineInOrder) {
  v1::QueryOptions defaults;
  defaults.set_near_points(true);
  const LocalScene scene = make_scene(stub(), defaults);
  ASSERT_EQ(scene.pair_count, 21u);
  constexpr int kSteps = 300;
  constexpr std::uint64_t kFirstSequence = 1000;

  StreamClient stream(stub(), kCallDeadline, GetParam());
  std::thread writer([&] {
    for (int step = 0; step < kSteps; ++step)
      if (!stream.write(make_update(scene, kFirstSequence + std::uint64_t(step),
                                    trajectory(scene.size(), step))))
        return;
    stream.flush();
  });
  CheckStats stats;
  int warm_pairs_after_first = 0, pairs_after_first = 0;
  for (int step = 0; step < kSteps; ++step) {
    v1::DistanceReport report;
    ASSERT_TRUE(stream.read(report)) << "stream ended at step " << step;
    ASSERT_EQ(report.sequence(), kFirstSequence + std::uint64_t(step));
    EXPECT_EQ(report.coalesced_updates(), 0u);
    EXPECT_GE(report.timing().server_us(), report.timing().evaluation_us());
    EXPECT_GT(report.timing().geometry_us(), 0.0);
    const CheckStats before = stats;
    expect_matches_local(scene, trajectory(scene.size(), step), report, true, &stats);
    if (step > 0) {
      pairs_after_first += stats.pairs - before.pairs;
      warm_pairs_after_first += stats.warm_started - before.warm_started;
    }
  }
  writer.join();
  EXPECT_TRUE(stream.finish().ok());
  // A representative sample (lesson 8): contacts and clearances are both common.
  EXPECT_GT(stats.intersecting, stats.pairs / 5) << stats.intersecting << " of " << stats.pairs;
  EXPECT_LT(stats.intersecting, stats.pairs * 4 / 5) << stats.intersecting << " of " << stats.pairs;
  // After the first update the stream's caches warm-start nearly every pair (the two-piece arm
  // may switch to a piece pair that was pruned before, which then starts cold).
  EXPECT_GT(warm_pairs_after_first, pairs_after_first * 9 / 10);
}

// Section VIII's mechanism: the stream keeps each pair's final simplex (vertex indices) and the
// next update starts from it. With single-piece polytopes every pair after the first update is
// warm; with warm_start = false none is, and the answers are the same within the error bounds.
TEST_F(GrpcServerTest, WarmStartCachesMakeLaterUpdatesWarm) {
  const TestGeometry box = polytope_geometry("box", box_vertices(Vec3<double>(0.5, 0.4, 0.3)));
  const TestGeometry hull = polytope_geometry("hull", random_hull_vertices(5, 30, 0.5));
  const std::string box_id = register_geometry(stub(), box);
  const std::string hull_id = register_geometry(stub(), hull);
  v1::CreateSceneRequest create;
  for (auto [id, geometry] : {std::pair{"a", box_id}, {"b", hull_id}, {"c", hull_id}}) {
    v1::SceneObject& object = *create.add_objects();
    object.set_id(id);
    object.set_geometry_id(geometry);
  }
  v1::CreateSceneResponse created;
  ASSERT_TRUE(stub().CreateScene(make_context().get(), create, &created).ok());

  for (const bool warm : {true, false}) {
    SCOPED_TRACE(warm ? "warm" : "cold");
    StreamClient stream(stub());
    for (int step = 0; step < 20; ++step) {
      v1::PoseUpdate update;
      update.set_scene_id(created.scene_id());
      update.set_sequence(std::uint64_t(step));
      update.mutable_options()->set_warm_start(warm);
      const std::vector<TestPose> poses = trajectory(3, step);
      for (int i = 0; i < 3; ++i) {
        v1::ObjectPose& pose = *update.add_poses();
        pose.set_object_id(std::string(1, char('a' + i)));
        poses[std::size_t(i)].to_message(*pose.mutable_pose());
      }
      ASSERT_TRUE(stream.write(update));
      v1::DistanceReport report;
      ASSERT_TRUE(stream.read(report));
      ASSERT_EQ(report.pairs_size(), 3);
      for (const v1::PairDistance& pair : report.pairs())
        EXPECT_EQ(pair.warm_started(), warm && step > 0) << "step " << step;
    }
    EXPECT_TRUE(stream.finish().ok());
  }
}

// A rejected update yields an error report naming its sequence number and the field, and the
// stream goes on: later updates are answered as usual.
TEST_F(GrpcServerTest, RejectedUpdateGetsAnErrorReportAndTheStreamContinues) {
  const LocalScene scene = make_scene(stub());
  StreamClient stream(stub());
  auto send = [&](const v1::PoseUpdate& update) {
    EXPECT_TRUE(stream.write(update));
    v1::DistanceReport report;
    EXPECT_TRUE(stream.read(report));
    return report;
  };
  const std::vector<TestPose> poses = trajectory(scene.size(), 3);

  // The first update names an unknown scene: NOT_FOUND, and the stream is still unbound.
  v1::PoseUpdate unknown_scene = make_update(scene, 1, poses);
  unknown_scene.set_scene_id("scene-404");
  v1::DistanceReport report = send(unknown_scene);
  EXPECT_EQ(report.sequence(), 1u);
  EXPECT_EQ(report.error().code(), v1::ERROR_CODE_NOT_FOUND);
  EXPECT_EQ(report.error().field(), "scene_id");
  EXPECT_EQ(report.pairs_size(), 0);

  report = send(make_update(scene, 2, poses));
  EXPECT_EQ(report.sequence(), 2u);
  expect_matches_local(scene, poses, report, false);

  v1::PoseUpdate nan_translation = make_update(scene, 3, poses);
  nan_translation.mutable_poses(1)->mutable_pose()->mutable_translation()->set_x(std::nan(""));
  report = send(nan_translation);
  EXPECT_EQ(report.sequence(), 3u);
  EXPECT_EQ(report.error().code(), v1::ERROR_CODE_INVALID_ARGUMENT);
  EXPECT_EQ(report.error().field(), "poses[1].pose.translation.x");

  v1::PoseUpdate long_quaternion = make_update(scene, 4, poses);
  long_quaternion.mutable_poses(0)->mutable_pose()->mutable_rotation()->set_w(2.0);
  report = send(long_quaternion);
  EXPECT_EQ(report.error().code(), v1::ERROR_CODE_INVALID_ARGUMENT);
  EXPECT_EQ(report.error().field(), "poses[0].pose.rotation");

  v1::PoseUpdate unknown_object = make_update(scene, 5, poses);
  unknown_object.mutable_poses(2)->set_object_id("ghost");
  report = send(unknown_object);
  EXPECT_EQ(report.error().code(), v1::ERROR_CODE_NOT_FOUND);
  EXPECT_EQ(report.error().field(), "poses[2].object_id");

  // A penetration mode this server does not know (a newer client's): refused, naming the field.
  v1::PoseUpdate depth = make_update(scene, 6, poses);
  depth.mutable_options()->set_penetration(v1::PenetrationMode(42));
  report = send(depth);
  EXPECT_EQ(report.error().code(), v1::ERROR_CODE_INVALID_ARGUMENT);
  EXPECT_EQ(report.error().field(), "options.penetration");

  // Sequence numbers must increase over the accepted updates (2 was the last accepted).
  report = send(make_update(scene, 2, poses));
  EXPECT_EQ(report.error().code(), v1::ERROR_CODE_INVALID_ARGUMENT);
  EXPECT_EQ(report.error().field(), "sequence");

  // Still alive, and the rejected updates changed nothing.
  const std::vector<TestPose> later = trajectory(scene.size(), 9);
  report = send(make_update(scene, 7, later));
  EXPECT_EQ(report.sequence(), 7u);
  expect_matches_local(scene, later, report, false);
  EXPECT_TRUE(stream.finish().ok());
}

// Objects an update leaves out keep the stream's previous poses (not the initial ones).
TEST_F(GrpcServerTest, UnlistedObjectsKeepTheirPreviousPose) {
  const LocalScene scene = make_scene(stub());
  StreamClient stream(stub());
  std::vector<TestPose> poses = trajectory(scene.size(), 4);
  ASSERT_TRUE(stream.write(make_update(scene, 1, poses)));
  v1::DistanceReport report;
  ASSERT_TRUE(stream.read(report));
  poses[2].translation.x() += 0.25;
  v1::PoseUpdate partial;
  partial.set_sequence(2);  // scene_id may be left out once the stream is bound
  v1::ObjectPose& moved = *partial.add_poses();
  moved.set_object_id(scene.object_ids[2]);
  poses[2].to_message(*moved.mutable_pose());
  ASSERT_TRUE(stream.write(partial));
  ASSERT_TRUE(stream.read(report));
  expect_matches_local(scene, poses, report, false);
  EXPECT_TRUE(stream.finish().ok());
}

// Two streams on one scene with different trajectories each get the answers for their own
// poses: streams share the immutable scene but none of the mutable state.
TEST_F(GrpcServerTest, TwoConcurrentStreamsOnOneSceneGetTheirOwnAnswers) {
  const LocalScene scene = make_scene(stub());
  auto run = [&](double phase) {
    StreamClient stream(stub());
    for (int step = 0; step < 120; ++step) {
      const std::vector<TestPose> poses = trajectory(scene.size(), step, phase);
      ASSERT_TRUE(stream.write(make_update(scene, std::uint64_t(step) + 1, poses)));
      v1::DistanceReport report;
      ASSERT_TRUE(stream.read(report));
      ASSERT_EQ(report.sequence(), std::uint64_t(step) + 1);
      expect_matches_local(scene, poses, report, false);
    }
    EXPECT_TRUE(stream.finish().ok());
  };
  std::thread first(run, 0.0);
  std::thread second(run, 2.5);
  first.join();
  second.join();
}

// A client that vanishes mid-stream (cancelled with updates in flight and reports unread) does
// not disturb another stream, and its server-side state is released.
TEST_F(GrpcServerTest, ClientThatDisconnectsMidStreamDoesNotDisturbOthers) {
  const LocalScene scene = make_scene(stub());
  std::promise<void> steady_started;
  std::thread steady([&] {
    StreamClient stream(stub());
    for (int step = 0; step < 150; ++step) {
      const std::vector<TestPose> poses = trajectory(scene.size(), step);
      ASSERT_TRUE(stream.write(make_update(scene, std::uint64_t(step), poses)));
      v1::DistanceReport report;
      ASSERT_TRUE(stream.read(report));
      ASSERT_EQ(report.sequence(), std::uint64_t(step));
      expect_matches_local(scene, poses, report, false);
      if (step == 10) steady_started.set_value();
    }
    EXPECT_TRUE(stream.finish().ok());
  });
  steady_started.get_future().wait();
  {
    StreamClient leaver(stub());
    for (int step = 0; step < 30; ++step)
      ASSERT_TRUE(leaver.write(
          make_update(scene, std::uint64_t(step), trajectory(scene.size(), step, 1.0))));
    leaver.context().TryCancel();
  }  // the stream object is destroyed with reports unread
  steady.join();
  // The cancelled stream's reactor ends once its evaluation in flight returns. Bounded wait for
  // that asynchronous cleanup (there is no event to wait on from outside the server).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (running_.server->scenes().open_streams() != 0 &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_EQ(running_.server->scenes().open_streams(), 0u);
}

// A stream bound to a scene that is deleted gets NOT_FOUND error reports from then on.
TEST_F(GrpcServerTest, DeletedSceneRejectsFurtherUpdates) {
  const LocalScene scene = make_scene(stub());
  StreamClient stream(stub());
  const std::vector<TestPose> poses = trajectory(scene.size(), 0);
  ASSERT_TRUE(stream.write(make_update(scene, 1, poses)));
  v1::DistanceReport report;
  ASSERT_TRUE(stream.read(report));
  EXPECT_FALSE(report.has_error());
  v1::DeleteSceneRequest remove;
  remove.set_scene_id(scene.scene_id);
  v1::DeleteSceneResponse removed;
  ASSERT_TRUE(stub().DeleteScene(make_context().get(), remove, &removed).ok());
  ASSERT_TRUE(stream.write(make_update(scene, 2, poses)));
  ASSERT_TRUE(stream.read(report));
  EXPECT_EQ(report.error().code(), v1::ERROR_CODE_NOT_FOUND);
  EXPECT_EQ(report.error().field(), "scene_id");
  EXPECT_TRUE(stream.finish().ok());
}

// ListScenes: every live scene, ordered by id, with its name, pair count and objects (id,
// geometry id, initial pose); a deleted scene is no longer listed.
TEST_F(GrpcServerTest, ListScenesShowsLiveScenesUntilDeleted) {
  const LocalScene first = make_scene(stub());
  const LocalScene second = make_scene(stub());
  ASSERT_NE(first.scene_id, second.scene_id);
  auto list = [&] {
    v1::ListScenesResponse listed;
    EXPECT_TRUE(stub().ListScenes(make_context().get(), v1::ListScenesRequest{}, &listed).ok());
    return listed;
  };
  v1::ListScenesResponse listed = list();
  ASSERT_EQ(listed.scenes_size(), 2);
  const bool first_is_lower = first.scene_id < second.scene_id;
  const v1::SceneSummary& a = listed.scenes(first_is_lower ? 0 : 1);
  EXPECT_EQ(a.scene_id(), first.scene_id);
  EXPECT_EQ(listed.scenes(first_is_lower ? 1 : 0).scene_id(), second.scene_id);
  EXPECT_EQ(a.name(), "paper-like");
  EXPECT_EQ(a.pair_count(), first.pair_count);
  ASSERT_EQ(std::size_t(a.objects_size()), first.size());
  for (std::size_t i = 0; i < first.size(); ++i) {
    const v1::SceneObject& object = a.objects(int(i));
    EXPECT_EQ(object.id(), first.object_ids[i]);
    EXPECT_EQ(object.geometry_id(), first.geometry_ids[std::size_t(first.object_geometry[i])]);
    // Created without a pose: the identity.
    EXPECT_DOUBLE_EQ(std::abs(object.pose().rotation().w()), 1.0);
    EXPECT_DOUBLE_EQ(object.pose().translation().x(), 0.0);
  }
  v1::DeleteSceneRequest remove;
  remove.set_scene_id(first.scene_id);
  v1::DeleteSceneResponse removed;
  ASSERT_TRUE(stub().DeleteScene(make_context().get(), remove, &removed).ok());
  listed = list();
  ASSERT_EQ(listed.scenes_size(), 1);
  EXPECT_EQ(listed.scenes(0).scene_id(), second.scene_id);
}

// Flow control, BLOCK (the default): a client that keeps writing without reading any report
// gets every update answered, in order — the server stops reading (HTTP/2 flow control then
// holds the writer back) instead of buffering without bound or dropping.
TEST_P(GrpcStreamTest, BlockPolicyAnswersEveryUpdateOfAFastWriter) {
  const LocalScene scene = make_scene(stub());
  StreamClient stream(stub(), kCallDeadline, GetParam());
  constexpr int kUpdates = 200;
  std::promise<void> half_written;
  std::thread writer([&] {
    for (int step = 0; step < kUpdates; ++step) {
      if (!stream.write(
              make_update(scene, std::uint64_t(step) + 1, trajectory(scene.size(), step))))
        break;
      if (step == kUpdates / 4) half_written.set_value();
    }
    stream.writes_done();
  });
  half_written.get_future().wait();
  std::vector<v1::DistanceReport> reports;
  const grpc::Status status = stream.read_to_end(reports);
  writer.join();
  EXPECT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(reports.size(), std::size_t(kUpdates));
  for (int step = 0; step < kUpdates; ++step) {
    ASSERT_EQ(reports[std::size_t(step)].sequence(), std::uint64_t(step) + 1);
    EXPECT_EQ(reports[std::size_t(step)].coalesced_updates(), 0u);
  }
  expect_matches_local(scene, trajectory(scene.size(), kUpdates - 1), reports.back(), false);
}

// Flow control, COALESCE: with a reader that reads nothing until the writer is done, the server
// keeps reading and merges what arrives while it is busy into the newest update. Every update is
// accounted for (each report counts the updates it absorbed), the newest poses are answered, and
// the merged reports are correct for their own sequence's poses.
TEST_P(GrpcStreamPoolTest, CoalescePolicyMergesUpdatesForASlowReader) {
  v1::QueryOptions defaults;
  defaults.set_near_points(true);
  defaults.set_gradient(true);  // larger reports fill the transport's window sooner
  const LocalScene scene = make_scene(stub(), defaults);
  StreamClient stream(stub(), kCallDeadline, GetParam());
  constexpr int kUpdates = 400;
  // "Busy" must not depend on how fast the engine is today: the workers are held until the
  // writer is done, so the server has to keep reading while nothing can be evaluated.
  testkit::HeldWorkers held(running_.server->scenes(), scene.scene_id);
  ASSERT_TRUE(held.held());
  std::promise<void> all_written;
  std::thread writer([&] {
    for (int step = 0; step < kUpdates; ++step) {
      v1::PoseUpdate update =
          make_update(scene, std::uint64_t(step) + 1, trajectory(scene.size(), step));
      if (step == 0) update.set_flow_control(v1::FLOW_CONTROL_COALESCE);
      if (!stream.write(update)) break;
    }
    all_written.set_value();
    stream.writes_done();
  });
  // The server must keep reading: the writer finishes without any report being read.
  ASSERT_EQ(all_written.get_future().wait_for(std::chrono::seconds(15)), std::future_status::ready);
  held.release();
  std::vector<v1::DistanceReport> reports;
  const grpc::Status status = stream.read_to_end(reports);
  writer.join();
  EXPECT_TRUE(status.ok()) << status.error_message();
  ASSERT_FALSE(reports.empty());
  std::uint64_t accounted = 0, previous = 0;
  int merged_reports = 0;
  for (const v1::DistanceReport& report : reports) {
    ASSERT_GT(report.sequence(), previous);
    if (report.coalesced_updates() > 0) {
      ++merged_reports;
      EXPECT_EQ(report.coalesced_from_sequence(), previous + 1);
      EXPECT_EQ(report.sequence() - report.coalesced_from_sequence(), report.coalesced_updates());
    } else {
      EXPECT_EQ(report.sequence(), previous + 1);
    }
    accounted += 1 + report.coalesced_updates();
    previous = report.sequence();
    expect_matches_local(scene, trajectory(scene.size(), int(report.sequence()) - 1), report, true);
  }
  EXPECT_EQ(accounted, std::uint64_t(kUpdates));
  EXPECT_EQ(reports.back().sequence(), std::uint64_t(kUpdates));
  // Update 1 was taken by the (held) pool and everything the server read before the release was
  // merged into one waiting update. (Not exactly two reports: the writer's last writes may still
  // sit in the transport's window when it is done, and be read after the release.)
  EXPECT_GT(merged_reports, 0);
}

// Thresholds over the wire, through COALESCE: while the workers are held, the writer moves one
// object of a watched pair onto its partner and away again, twenty times; the server merges
// what it reads into few reports, yet every ENTER and EXIT arrives, once, in order, with the
// sequence number of the update that caused it, the threshold's name and the pair's ids. Guards
// the replay of absorbed updates (a merged update alone would see only its last poses) and the
// proto conversion of events.
TEST_P(GrpcStreamPoolTest, ThresholdEventsSurviveCoalescedUpdates) {
  const LocalScene scene = make_scene(stub());
  StreamClient stream(stub(), kCallDeadline, GetParam());
  constexpr int kUpdates = 20;
  testkit::HeldWorkers held(running_.server->scenes(), scene.scene_id);
  ASSERT_TRUE(held.held());
  const std::vector<TestPose> base = trajectory(scene.size(), 0);
  std::promise<void> all_written;
  std::thread writer([&] {
    for (int step = 0; step < kUpdates; ++step) {
      std::vector<TestPose> poses = base;
      // Odd steps: object 1 on object 0 (intersecting, distance 0); even steps: 10 m away.
      poses[1].translation = poses[0].translation + Vec3<double>(step % 2 ? 0.0 : 10.0, 0, 0);
      v1::PoseUpdate update = make_update(scene, std::uint64_t(step) + 1, poses);
      if (step == 0) {
        update.set_flow_control(v1::FLOW_CONTROL_COALESCE);
        v1::Threshold& threshold = *update.add_thresholds();
        threshold.set_name("keep-out");
        threshold.set_distance(0.05);
        threshold.set_hysteresis(0.01);
        threshold.set_object_a(scene.object_ids[1]);
        threshold.set_object_b(scene.object_ids[0]);
      }
      if (!stream.write(update)) break;
    }
    all_written.set_value();
    stream.writes_done();
  });
  ASSERT_EQ(all_written.get_future().wait_for(std::chrono::seconds(15)), std::future_status::ready);
  held.release();
  std::vector<v1::DistanceReport> reports;
  const grpc::Status status = stream.read_to_end(reports);
  writer.join();
  ASSERT_TRUE(status.ok()) << status.error_message();
  std::vector<std::pair<std::uint64_t, v1::ThresholdCrossing>> events;
  int merged = 0;
  for (const v1::DistanceReport& report : reports) {
    ASSERT_FALSE(report.has_error()) << report.error().message();
    merged += report.coalesced_updates() > 0;
    for (const v1::ThresholdEvent& event : report.events()) {
      EXPECT_EQ(event.threshold(), "keep-out");
      EXPECT_EQ(event.threshold_index(), 0u);
      EXPECT_EQ(event.object_a(), scene.object_ids[0]);  // the scene's pair order
      EXPECT_EQ(event.object_b(), scene.object_ids[1]);
      EXPECT_LE(event.sequence(), report.sequence());
      if (event.crossing() == v1::THRESHOLD_CROSSING_ENTER)
        EXPECT_EQ(event.distance(), 0.0);
      else
        EXPECT_GT(event.distance(), 0.06);
      events.emplace_back(event.sequence(), event.crossing());
    }
  }
  EXPECT_GT(merged, 0);
  ASSERT_EQ(events.size(), std::size_t(kUpdates - 1));
  for (std::size_t e = 0; e < events.size(); ++e) {
    EXPECT_EQ(events[e].first, e + 2);  // update 1 is far: nothing to report
    EXPECT_EQ(events[e].second, e % 2 ? v1::THRESHOLD_CROSSING_EXIT : v1::THRESHOLD_CROSSING_ENTER);
  }
}

// ---- batches (StreamPoseBatches) ----

// Rejected updates inside a batch get their error report in their place and the others are
// answered, as if each had been sent alone; the rejected ones change nothing. Reports that are
// ready together leave in one message: the three refusals of an unbound stream's first batch
// (no evaluation runs, so all three are ready when the batch has been read) arrive as one
// DistanceReportBatch. Guards the per-update loop over a batch and the packing of writes.
TEST_F(GrpcServerTest, RejectedUpdatesInABatchAreAnsweredInTheirPlace) {
  const LocalScene scene = make_scene(stub());
  StreamClient stream(stub(), kCallDeadline, /*batch=*/100);  // sent by flush()
  auto read_reports = [&](std::size_t count) {
    std::vector<v1::DistanceReport> reports(count);
    for (v1::DistanceReport& report : reports) EXPECT_TRUE(stream.read(report));
    return reports;
  };
  const std::vector<TestPose> first = trajectory(scene.size(), 3);
  for (std::uint64_t sequence = 1; sequence <= 3; ++sequence) {
    v1::PoseUpdate unknown_scene = make_update(scene, sequence, first);
    unknown_scene.set_scene_id("scene-404");
    ASSERT_TRUE(stream.write(unknown_scene));
  }
  ASSERT_TRUE(stream.flush());
  std::vector<v1::DistanceReport> reports = read_reports(3);
  EXPECT_EQ(stream.messages_read(), 1u);
  for (std::uint64_t i = 0; i < 3; ++i) {
    EXPECT_EQ(reports[i].sequence(), i + 1);
    EXPECT_EQ(reports[i].error().code(), v1::ERROR_CODE_NOT_FOUND);
    EXPECT_EQ(reports[i].error().field(), "scene_id");
  }

  const std::vector<TestPose> second = trajectory(scene.size(), 9);
  ASSERT_TRUE(stream.write(make_update(scene, 4, first)));
  v1::PoseUpdate nan_translation = make_update(scene, 5, second);
  nan_translation.mutable_poses(1)->mutable_pose()->mutable_translation()->set_x(std::nan(""));
  ASSERT_TRUE(stream.write(nan_translation));
  ASSERT_TRUE(stream.write(make_update(scene, 6, second)));
  ASSERT_TRUE(stream.write(make_update(scene, 6, first)));  // sequence 6 again
  v1::PoseUpdate unknown_object = make_update(scene, 7, first);
  unknown_object.mutable_poses(2)->set_object_id("ghost");
  ASSERT_TRUE(stream.write(unknown_object));
  v1::PoseUpdate unchanged;  // no poses: the stream's last accepted ones (sequence 6's)
  unchanged.set_sequence(8);
  ASSERT_TRUE(stream.write(unchanged));
  ASSERT_TRUE(stream.flush());
  reports = read_reports(6);
  const std::vector<std::uint64_t> sequences{4, 5, 6, 6, 7, 8};
  for (std::size_t i = 0; i < reports.size(); ++i)
    EXPECT_EQ(reports[i].sequence(), sequences[i]) << "report " << i;
  expect_matches_local(scene, first, reports[0], false);
  EXPECT_EQ(reports[1].error().field(), "poses[1].pose.translation.x");
  expect_matches_local(scene, second, reports[2], false);
  EXPECT_EQ(reports[3].error().code(), v1::ERROR_CODE_INVALID_ARGUMENT);
  EXPECT_EQ(reports[3].error().field(), "sequence");
  EXPECT_EQ(reports[4].error().code(), v1::ERROR_CODE_NOT_FOUND);
  EXPECT_EQ(reports[4].error().field(), "poses[2].object_id");
  expect_matches_local(scene, second, reports[5], false);
  EXPECT_TRUE(stream.finish().ok());
}

/// A scene of `count` copies of one 40-vertex hull (every pair listed), with `options` as its
/// defaults: as cheap or as costly per update as the batch tests below need.
LocalScene hull_scene(v1::DistanceService::Stub& stub, int count,
                      const v1::QueryOptions& options = {}) {
  LocalScene scene;
  scene.geometries.push_back(polytope_geometry("hull40", random_hull_vertices(11, 40, 0.6)));
  scene.geometry_ids.push_back(register_geometry(stub, scene.geometries[0]));
  v1::CreateSceneRequest request;
  request.set_name("hulls");
  for (int i = 0; i < count; ++i) {
    const std::string id = "hull-" + std::to_string(i);
    scene.object_ids.push_back(id);
    scene.object_geometry.push_back(0);
    scene.object_index[id] = i;
    v1::SceneObject& object = *request.add_objects();
    object.set_id(id);
    object.set_geometry_id(scene.geometry_ids[0]);
  }
  *request.mutable_default_options() = options;
  v1::CreateSceneResponse created;
  const grpc::Status status = stub.CreateScene(make_context().get(), request, &created);
  EXPECT_TRUE(status.ok()) << status.error_message();
  scene.scene_id = created.scene_id();
  scene.pair_count = created.pair_count();
  return scene;
}

// A batch's reports leave together: the reports of a batch evaluated on the stream's thread wait
// for the batch's last evaluation and go out in one DistanceReportBatch, not the first alone and
// the rest behind it (two writes per batch, each costing gRPC's framing and a sendmsg). One pair
// keeps each evaluation to microseconds, under the sanitizers too. Only a batch whose
// evaluations after the first took less than the hold (2 ms; half of it, to leave room for the
// encoding and locking around them) must arrive whole; on a machine slow enough to leave no such
// batch the test says so and fails rather than pass without checking.
TEST_F(GrpcServerTest, BatchReportsLeaveInOneMessage) {
  const LocalScene scene = hull_scene(stub(), 2);
  ASSERT_EQ(scene.pair_count, 1u);
  constexpr std::size_t kBatch = 4;
  constexpr int kBatches = 20;
  StreamClient stream(stub(), kCallDeadline, kBatch);
  int checked = 0;
  std::uint64_t sequence = 0;
  for (int b = 0; b < kBatches; ++b) {
    for (std::size_t i = 0; i < kBatch; ++i, ++sequence)
      ASSERT_TRUE(stream.write(
          make_update(scene, sequence + 1, trajectory(scene.size(), int(sequence)))));  // flushes
    const std::size_t messages_before = stream.messages_read();
    double held_us = 0;  // the evaluations the first report waited for
    for (std::size_t i = 0; i < kBatch; ++i) {
      v1::DistanceReport report;
      ASSERT_TRUE(stream.read(report));
      ASSERT_EQ(report.sequence(), sequence - kBatch + i + 1);
      if (i > 0) held_us += report.timing().evaluation_us();
    }
    if (held_us >= 1000) continue;
    ++checked;
    EXPECT_EQ(stream.messages_read() - messages_before, 1u)
        << "batch " << b << " (" << held_us << " us of evaluations after its first report)";
  }
  ::testing::Test::RecordProperty("batches_checked", checked);
  EXPECT_GT(checked, 0) << "every batch took more than 1 ms to evaluate: nothing was checked";
  EXPECT_TRUE(stream.finish().ok());
}

// The hold is bounded: when the evaluations after a batch's first take longer than the hold, the
// first report leaves before the batch is done. 150 objects (11,175 pairs, every object moved,
// no warm start) take milliseconds per update; the reports are the global minimum only.
TEST_F(GrpcServerTest, BatchFirstReportWaitsNoLongerThanTheHold) {
  v1::QueryOptions options;
  options.set_report_mode(v1::REPORT_MODE_GLOBAL_MINIMUM);
  options.set_warm_start(false);
  const LocalScene scene = hull_scene(stub(), 150, options);

  constexpr std::size_t kBatch = 3;
  StreamClient stream(stub(), kCallDeadline, kBatch);
  for (std::size_t i = 0; i < kBatch; ++i)
    ASSERT_TRUE(stream.write(make_update(scene, i + 1, trajectory(scene.size(), int(i)))));
  std::vector<v1::DistanceReport> reports(kBatch);
  for (v1::DistanceReport& report : reports) ASSERT_TRUE(stream.read(report));
  // The first report waited for the second evaluation at least: longer than the hold.
  ASSERT_GT(reports[1].timing().evaluation_us(), 2000.0)
      << "the scene evaluates too fast to outlast the hold";
  EXPECT_GE(stream.messages_read(), 2u);
  for (std::size_t i = 0; i < kBatch; ++i) {
    EXPECT_EQ(reports[i].sequence(), i + 1);
    ASSERT_EQ(reports[i].pairs_size(), 1);
    EXPECT_EQ(reports[i].counts().pairs_evaluated(), 150u * 149u / 2u);
  }
  EXPECT_TRUE(stream.finish().ok());
}

// FLOW_CONTROL_BLOCK counts updates, not messages: with --max-in-flight 4 and batches of 3 while
// nothing can be answered (the workers are held), the server reads batch 1 (3 updates in flight,
// below 4), batch 2 (6), and then no more. The drain that follows says how many updates it read:
// at most 6, whole batches, and exactly those answered. Counting messages would read 4 batches.
// (The pause only gives the server time to read what it will; a slow machine makes the count
// smaller, never larger.)
TEST(GrpcServerBatches, BlockBackPressureCountsUpdatesNotMessages) {
  ServerConfig config = test_config();
  config.limits.max_in_flight_per_stream = 4;
  config.limits.inline_evaluation = false;
  RunningServer running = start_server(config);
  ASSERT_TRUE(running.server);
  const LocalScene scene = make_scene(*running.stub);
  testkit::HeldWorkers held(running.server->scenes(), scene.scene_id);
  ASSERT_TRUE(held.held());
  StreamClient stream(*running.stub, kCallDeadline, /*batch=*/3);
  for (int step = 0; step < 30; ++step)
    ASSERT_TRUE(
        stream.write(make_update(scene, std::uint64_t(step) + 1, trajectory(scene.size(), step))));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  auto shutdown = std::async(std::launch::async, [&] { running.server->shutdown(); });
  // The workers are released only once the shutdown has had time to stop the stream's reads:
  // released at once, they answered the first batches and the reactor read more before the drain
  // began (18 read instead of at most 6, about 1 run in 5 on a loaded machine).
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  held.release();
  std::vector<v1::DistanceReport> reports;
  const grpc::Status status = stream.read_to_end(reports);
  ASSERT_EQ(shutdown.wait_for(std::chrono::seconds(15)), std::future_status::ready);
  ASSERT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << status.error_message();
  std::size_t read = 0;
  ASSERT_EQ(std::sscanf(status.error_message().c_str(),
                        "server is draining (shutting down): all %zu", &read),
            1)
      << status.error_message();
  ::testing::Test::RecordProperty("updates_read", int(read));
  EXPECT_LE(read, 6u);
  EXPECT_EQ(read % 3, 0u);
  ASSERT_EQ(reports.size(), read);
  for (std::size_t i = 0; i < reports.size(); ++i) {
    EXPECT_EQ(reports[i].sequence(), i + 1);
    expect_matches_local(scene, trajectory(scene.size(), int(i)), reports[i], false);
  }
}

// A message that does not parse as a PoseUpdateBatch ends the stream INVALID_ARGUMENT after the
// updates of the batches before it are answered, counting messages and updates apart.
TEST_F(GrpcServerTest, MalformedBatchEndsTheStreamInvalidArgument) {
  const LocalScene scene = make_scene(stub());
  RawStream stream(running_.channel, "/nearpoint.v1.DistanceService/StreamPoseBatches");
  ASSERT_TRUE(stream.started());
  v1::PoseUpdateBatch batch;
  *batch.add_updates() = make_update(scene, 1, trajectory(scene.size(), 1));
  *batch.add_updates() = make_update(scene, 2, trajectory(scene.size(), 2));
  ASSERT_TRUE(stream.write(batch.SerializeAsString()));
  ASSERT_TRUE(stream.write(std::string("\xFF\xFF\xFF\xFF\x0F", 5)));
  batch.Clear();
  *batch.add_updates() = make_update(scene, 3, trajectory(scene.size(), 3));
  stream.write(batch.SerializeAsString());  // must go unread (the stream may be over already)
  std::vector<v1::DistanceReport> reports;
  for (std::string bytes; stream.read(bytes);) {
    v1::DistanceReportBatch received;
    ASSERT_TRUE(received.ParseFromString(bytes));
    reports.insert(reports.end(), received.reports().begin(), received.reports().end());
  }
  const grpc::Status status = stream.finish();
  ASSERT_EQ(reports.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(reports[i].sequence(), i + 1);
    expect_matches_local(scene, trajectory(scene.size(), int(i) + 1), reports[i], false);
  }
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_NE(status.error_message().find("message 2 of the stream (after sequence 2) does not "
                                        "parse as nearpoint.v1.PoseUpdateBatch"),
            std::string::npos)
      << status.error_message();
  EXPECT_NE(status.error_message().find("the 2 updates before it were answered"), std::string::npos)
      << status.error_message();
}

// ---- unary queries ----

TEST_F(GrpcServerTest, UnaryQueryMatchesTheEngineAndWarmStartsFromTheSceneCache) {
  const LocalScene scene = make_scene(stub());
  const std::vector<TestPose> poses = trajectory(scene.size(), 7);
  v1::QueryRequest query;
  query.set_scene_id(scene.scene_id);
  query.set_sequence(77);
  query.mutable_options()->set_near_points(true);
  for (std::size_t i = 0; i < poses.size(); ++i) {
    v1::ObjectPose& pose = *query.add_poses();
    pose.set_object_id(scene.object_ids[i]);
    poses[i].to_message(*pose.mutable_pose());
  }
  v1::DistanceReport first, second, cold;
  ASSERT_TRUE(stub().Query(make_context().get(), query, &first).ok());
  EXPECT_EQ(first.sequence(), 77u);
  expect_matches_local(scene, poses, first, true);
  for (const v1::PairDistance& pair : first.pairs()) EXPECT_FALSE(pair.warm_started());
  // The same query again starts every pair from the scene's shared cache.
  ASSERT_TRUE(stub().Query(make_context().get(), query, &second).ok());
  expect_matches_local(scene, poses, second, true);
  for (const v1::PairDistance& pair : second.pairs()) EXPECT_TRUE(pair.warm_started());
  query.mutable_options()->set_warm_start(false);
  ASSERT_TRUE(stub().Query(make_context().get(), query, &cold).ok());
  for (const v1::PairDistance& pair : cold.pairs()) EXPECT_FALSE(pair.warm_started());
}

// Objects a query does not list sit at their initial pose: here the identity, all at the origin,
// so every pair intersects; the penetration bound is reported on request.
TEST_F(GrpcServerTest, UnaryQueryUsesInitialPosesAndReportsPenetrationBounds) {
  const LocalScene scene = make_scene(stub());
  v1::QueryRequest query;
  query.set_scene_id(scene.scene_id);
  query.mutable_options()->set_penetration(v1::PENETRATION_MODE_BOUND);
  v1::DistanceReport report;
  ASSERT_TRUE(stub().Query(make_context().get(), query, &report).ok());
  ASSERT_EQ(report.pairs_size(), 21);
  for (const v1::PairDistance& pair : report.pairs()) {
    EXPECT_EQ(pair.status(), v1::PAIR_STATUS_INTERSECTING)
        << pair.object_a() << "/" << pair.object_b();
    EXPECT_EQ(pair.distance(), 0.0);
    EXPECT_TRUE(pair.has_penetration_bound());
    EXPECT_GE(pair.penetration_bound(), 0.0);
  }
}

// The broad phase: pairs whose bounding spheres are farther apart than the cutoff are reported
// as BEYOND_CUTOFF with a certified lower bound, without running GJK; near pairs get exact
// distances.
TEST_F(GrpcServerTest, PairsBeyondTheCutoffAreReportedWithALowerBound) {
  const LocalScene scene = make_scene(stub());
  std::vector<TestPose> poses(scene.size());
  for (std::size_t i = 0; i < poses.size(); ++i)
    poses[i].translation = Vec3<double>(3.0 * double(i), 0, 0);            // 3 m apart: all far
  poses[1].translation = poses[0].translation + Vec3<double>(0, 0.95, 0);  // 0.25 m gap
  v1::QueryRequest query;
  query.set_scene_id(scene.scene_id);
  query.mutable_options()->set_distance_cutoff(0.3);
  for (std::size_t i = 0; i < poses.size(); ++i) {
    v1::ObjectPose& pose = *query.add_poses();
    pose.set_object_id(scene.object_ids[i]);
    poses[i].to_message(*pose.mutable_pose());
  }
  v1::DistanceReport report;
  ASSERT_TRUE(stub().Query(make_context().get(), query, &report).ok());
  int beyond = 0, skipped_by_spheres = 0;
  for (const v1::PairDistance& pair : report.pairs()) {
    const int a = scene.object_index.at(pair.object_a());
    const int b = scene.object_index.at(pair.object_b());
    const double truth = distance(scene.compound(a), poses[std::size_t(a)].local(),
                                  scene.compound(b), poses[std::size_t(b)].local())
                             .nearest.distance;
    SCOPED_TRACE(pair.object_a() + "/" + pair.object_b());
    if (pair.status() == v1::PAIR_STATUS_BEYOND_CUTOFF) {
      ++beyond;
      skipped_by_spheres += pair.iterations() == 0 && pair.piece_pairs_evaluated() == 0;
      EXPECT_GT(pair.distance_lower_bound(), 0.3 - 1e-9);
      EXPECT_LE(pair.distance_lower_bound(), truth + 1e-9);
    } else {
      EXPECT_EQ(pair.status(), v1::PAIR_STATUS_SEPARATED);
      EXPECT_NEAR(pair.distance(), truth, pair.error_bound() + 1e-9);
      EXPECT_LE(truth, 0.3 + 1e-9);
    }
  }
  EXPECT_EQ(beyond, 20);
  EXPECT_GT(skipped_by_spheres, 10);
  // The counts say the same (a query has no previous report, so nothing is unmoved).
  EXPECT_EQ(report.report_mode(), v1::REPORT_MODE_ALL_PAIRS);
  EXPECT_EQ(report.counts().pairs_pruned(), std::uint32_t(skipped_by_spheres));
  EXPECT_EQ(report.counts().pairs_evaluated() + report.counts().pairs_pruned(),
            std::uint32_t(report.pairs_size()));
  EXPECT_EQ(report.counts().pairs_unmoved(), 0u);

  // REPORT_MODE_WITHIN_CUTOFF: the same answers less the BEYOND_CUTOFF pairs.
  query.mutable_options()->set_report_mode(v1::REPORT_MODE_WITHIN_CUTOFF);
  v1::DistanceReport near;
  ASSERT_TRUE(stub().Query(make_context().get(), query, &near).ok());
  EXPECT_EQ(near.report_mode(), v1::REPORT_MODE_WITHIN_CUTOFF);
  ASSERT_EQ(near.pairs_size(), report.pairs_size() - beyond);  // the others are within 0.3
  int j = 0;
  for (const v1::PairDistance& pair : report.pairs()) {
    if (pair.status() == v1::PAIR_STATUS_BEYOND_CUTOFF) continue;
    EXPECT_EQ(near.pairs(j).object_a(), pair.object_a());
    EXPECT_EQ(near.pairs(j).object_b(), pair.object_b());
    EXPECT_NEAR(near.pairs(j).distance(), pair.distance(), 2 * pair.error_bound() + 1e-12);
    ++j;
  }

  // REPORT_MODE_GLOBAL_MINIMUM over the wire: the one nearest of the all-pairs report's
  // candidates, named as such (the modes themselves are checked in test_broad_phase).
  query.mutable_options()->set_report_mode(v1::REPORT_MODE_GLOBAL_MINIMUM);
  v1::DistanceReport global;
  ASSERT_TRUE(stub().Query(make_context().get(), query, &global).ok());
  EXPECT_EQ(global.report_mode(), v1::REPORT_MODE_GLOBAL_MINIMUM);
  ASSERT_EQ(global.pairs_size(), 1);
  for (const v1::PairDistance& pair : report.pairs())
    if (pair.status() != v1::PAIR_STATUS_BEYOND_CUTOFF) {
      EXPECT_LE(global.pairs(0).distance(), pair.distance() + 2 * pair.error_bound() + 1e-12);
    }
  // A negative change_tolerance is refused naming the field.
  query.mutable_options()->set_change_tolerance(-1);
  v1::DistanceReport refused;
  const grpc::Status status = stub().Query(make_context().get(), query, &refused);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message().rfind("options.change_tolerance: ", 0), 0u)
      << status.error_message();
}

// ---- error paths ----

/// Expects `status` to carry `code` and a message that starts with the field path.
void expect_error(const grpc::Status& status, grpc::StatusCode code, const std::string& field) {
  EXPECT_EQ(status.error_code(), code) << status.error_message();
  if (!field.empty()) {
    EXPECT_EQ(status.error_message().rfind(field + ": ", 0), 0u)
        << "message '" << status.error_message() << "' does not start with '" << field << ": '";
  }
}

// Guards the server's hull path (RegisterGeometry builds the hull of a polytope of 64+ vertices
// and gives its faces to the engine): exact hulls were refused as "the surface is not convex"
// when rounding of the centred vertices exceeded the convexity check's allowance. The paper's
// M = 100 polytopes placed in world coordinates (the first set below was refused before the fix,
// the others sit 1 km and 100 km from the origin) must be accepted, and a query on each must give
// CGAL's exact distance.
TEST_F(GrpcServerTest, LargePolytopesInWorldCoordinatesAreAcceptedAndExact) {
  const auto paper = testkit::paper_polytopes();
  struct Placement {
    int number;
    std::uint64_t seed;
    double reach;
  };
  for (const Placement& at :
       {Placement{12, 749, 1.0}, Placement{11, 3, 1e3}, Placement{12, 4, 1e5}}) {
    SCOPED_TRACE(::testing::Message() << "polytope " << at.number << " at " << at.reach);
    std::mt19937_64 rng(at.seed);
    std::normal_distribution<double> normal;
    const Eigen::Quaterniond q(normal(rng), normal(rng), normal(rng), normal(rng));
    const Pose<double> pose =
        Pose<double>::from_quaternion(q, at.reach * testkit::random_unit_vector(rng));
    std::vector<Vec3<double>> world;
    for (const Vec3<double>& v : *paper[std::size_t(at.number - 1)].vertices)
      world.push_back(pose.apply(v));
    ASSERT_EQ(world.size(), 100u);
    std::vector<Vec3<double>> probe = box_vertices(Vec3<double>(0.5, 0.3, 0.2));
    for (Vec3<double>& v : probe) v += world[0] + Vec3<double>(2.5, -1.0, 0.5);

    const std::string hull_id = register_geometry(stub(), polytope_geometry("paper", world));
    const std::string probe_id = register_geometry(stub(), polytope_geometry("probe", probe));
    ASSERT_FALSE(hull_id.empty());
    v1::CreateSceneRequest create;
    create.add_objects()->set_id("paper");
    create.mutable_objects(0)->set_geometry_id(hull_id);
    create.add_objects()->set_id("probe");
    create.mutable_objects(1)->set_geometry_id(probe_id);
    v1::CreateSceneResponse created;
    ASSERT_TRUE(stub().CreateScene(make_context().get(), create, &created).ok());
    v1::QueryRequest query;
    query.set_scene_id(created.scene_id());
    v1::DistanceReport report;
    const grpc::Status status = stub().Query(make_context().get(), query, &report);
    ASSERT_TRUE(status.ok()) << status.error_message();
    ASSERT_EQ(report.pairs_size(), 1);
    const testkit::ExactDistance exact = testkit::exact_distance<double>(
        world, Pose<double>::identity(), probe, Pose<double>::identity());
    ASSERT_FALSE(exact.intersecting);
    // Beyond the reported bound, the rounding of world coordinates of magnitude `reach`.
    EXPECT_LE(
        std::abs(report.pairs(0).distance() - exact.distance),
        report.pairs(0).error_bound() + 4 * std::numeric_limits<double>::epsilon() * at.reach);
  }
}

TEST_F(GrpcServerTest, InvalidGeometriesAreRejectedNamingTheField) {
  const TestGeometry base =
      polytope_geometry("tetra", {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}});
  struct Case {
    const char* what;
    std::function<void(v1::Geometry&)> mutate;
    grpc::StatusCode code;
    std::string field;
  };
  const double nan = std::nan("");
  const std::vector<Case> cases = {
      {"no pieces", [](v1::Geometry& g) { g.clear_pieces(); }, grpc::StatusCode::INVALID_ARGUMENT,
       "geometry.pieces"},
      {"no shape", [](v1::Geometry& g) { g.add_pieces(); }, grpc::StatusCode::INVALID_ARGUMENT,
       "geometry.pieces[1].shape"},
      {"empty polytope",
       [](v1::Geometry& g) { g.mutable_pieces(0)->mutable_polytope()->clear_vertices(); },
       grpc::StatusCode::INVALID_ARGUMENT, "geometry.pieces[0].polytope.vertices"},
      {"NaN coordinate",
       [nan](v1::Geometry& g) {
         g.mutable_pieces(0)->mutable_polytope()->mutable_vertices(1)->set_y(nan);
       },
       grpc::StatusCode::INVALID_ARGUMENT, "geometry.pieces[0].polytope.vertices[1].y"},
      {"infinite coordinate",
       [](v1::Geometry& g) {
         g.mutable_pieces(0)->mutable_polytope()->mutable_vertices(2)->set_z(INFINITY);
       },
       grpc::StatusCode::INVALID_ARGUMENT, "geometry.pieces[0].polytope.vertices[2].z"},
      {"negative radius", [](v1::Geometry& g) { g.mutable_pieces(0)->set_radius(-0.1); },
       grpc::StatusCode::INVALID_ARGUMENT, "geometry.pieces[0].radius"},
      {"negative half extent",
       [](v1::Geometry& g) {
         v1::Vector3& half = *g.add_pieces()->mutable_box()->mutable_half_extents();
         half.set_x(1);
         half.set_y(-1);
       },
       grpc::StatusCode::INVALID_ARGUMENT, "geometry.pieces[1].box.half_extents.y"},
      {"zero offset quaternion",
       [](v1::Geometry& g) { g.mutable_pieces(0)->mutable_offset()->mutable_rotation(); },
       grpc::StatusCode::INVALID_ARGUMENT, "geometry.pieces[0].offset.rotation"},
      {"too many vertices",
       [](v1::Geometry& g) {
         for (int i = 0; i < 2001; ++i) g.mutable_pieces(0)->mutable_polytope()->add_vertices();
       },
       grpc::StatusCode::RESOURCE_EXHAUSTED, "geometry.pieces"},
      {"message too large",  // beyond --max-message-bytes (1 MiB here): gRPC refuses it
       [](v1::Geometry& g) {
         for (int i = 0; i < 50000; ++i) {
           v1::Vector3& v = *g.mutable_pieces(0)->mutable_polytope()->add_vertices();
           v.set_x(0.5 + i);
           v.set_y(0.25);
           v.set_z(0.125);
         }
       },
       grpc::StatusCode::RESOURCE_EXHAUSTED, ""},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    v1::RegisterGeometryRequest request;
    *request.mutable_geometry() = base.message;
    c.mutate(*request.mutable_geometry());
    v1::RegisterGeometryResponse response;
    expect_error(stub().RegisterGeometry(make_context().get(), request, &response), c.code,
                 c.field);
  }
  // Nothing was stored by the rejected requests.
  v1::ListGeometriesResponse listed;
  ASSERT_TRUE(stub().ListGeometries(make_context().get(), {}, &listed).ok());
  EXPECT_EQ(listed.geometries_size(), 0);
}

// The routing key (issue 24): a CreateScene whose x-nearpoint-scene header names another scene
// would be placed where no later call for it is routed; refused. The same request sent twice
// (a client unsure whether the first arrived) is answered as the first, inline geometries and
// all.
TEST_F(GrpcServerTest, CreateSceneChecksTheRoutingHeaderAndIsIdempotent) {
  v1::CreateSceneRequest request;
  request.set_scene_id("routed");
  *(*request.mutable_geometries())["crate"].mutable_pieces() =
      polytope_geometry("box", box_vertices({1, 1, 1})).message.pieces();
  for (const char* id : {"a", "b"}) {
    v1::SceneObject& object = *request.add_objects();
    object.set_id(id);
    object.set_geometry_id("crate");
  }
  auto routed = [](const std::string& key) {
    auto context = make_context();
    context->AddMetadata("x-nearpoint-scene", key);
    return context;
  };
  v1::CreateSceneResponse response;
  expect_error(stub().CreateScene(routed("elsewhere").get(), request, &response),
               grpc::StatusCode::INVALID_ARGUMENT, "scene_id");
  ASSERT_TRUE(stub().CreateScene(routed("routed").get(), request, &response).ok());
  EXPECT_EQ(response.scene_id(), "routed");
  EXPECT_EQ(response.pair_count(), 1u);
  ASSERT_EQ(response.geometry_ids().count("crate"), 1u);
  v1::CreateSceneResponse again;
  ASSERT_TRUE(stub().CreateScene(routed("routed").get(), request, &again).ok());
  EXPECT_EQ(again.scene_id(), "routed");
  EXPECT_EQ(again.geometry_ids().at("crate"), response.geometry_ids().at("crate"));
  request.mutable_objects(1)->mutable_pose()->mutable_translation()->set_x(5);
  expect_error(stub().CreateScene(make_context().get(), request, &again),
               grpc::StatusCode::ALREADY_EXISTS, "scene_id");
}

TEST_F(GrpcServerTest, InvalidScenesAreRejectedNamingTheField) {
  const std::string box =
      register_geometry(stub(), polytope_geometry("box", box_vertices({1, 1, 1})));
  auto valid = [&] {
    v1::CreateSceneRequest request;
    for (const char* id : {"a", "b"}) {
      v1::SceneObject& object = *request.add_objects();
      object.set_id(id);
      object.set_geometry_id(box);
    }
    return request;
  };
  struct Case {
    const char* what;
    std::function<void(v1::CreateSceneRequest&)> mutate;
    grpc::StatusCode code;
    std::string field;
  };
  const std::vector<Case> cases = {
      {"no objects", [](v1::CreateSceneRequest& r) { r.clear_objects(); },
       grpc::StatusCode::INVALID_ARGUMENT, "objects"},
      {"unknown geometry",
       [](v1::CreateSceneRequest& r) { r.mutable_objects(1)->set_geometry_id("geom-999"); },
       grpc::StatusCode::NOT_FOUND, "objects[1].geometry_id"},
      {"duplicate id", [](v1::CreateSceneRequest& r) { r.mutable_objects(1)->set_id("a"); },
       grpc::StatusCode::INVALID_ARGUMENT, "objects[1].id"},
      {"empty id", [](v1::CreateSceneRequest& r) { r.mutable_objects(0)->clear_id(); },
       grpc::StatusCode::INVALID_ARGUMENT, "objects[0].id"},
      {"non-unit initial quaternion",
       [](v1::CreateSceneRequest& r) {
         r.mutable_objects(0)->mutable_pose()->mutable_rotation()->set_w(0.9);
       },
       grpc::StatusCode::INVALID_ARGUMENT, "objects[0].pose.rotation"},
      {"listed pair with unknown object",
       [](v1::CreateSceneRequest& r) {
         v1::ObjectPair& pair = *r.mutable_pair_selection()->mutable_listed_pairs()->add_pairs();
         pair.set_object_a("a");
         pair.set_object_b("zz");
       },
       grpc::StatusCode::NOT_FOUND, "pair_selection.listed_pairs.pairs[0].object_b"},
      {"listed pair of one object",
       [](v1::CreateSceneRequest& r) {
         v1::ObjectPair& pair = *r.mutable_pair_selection()->mutable_listed_pairs()->add_pairs();
         pair.set_object_a("a");
         pair.set_object_b("a");
       },
       grpc::StatusCode::INVALID_ARGUMENT, "pair_selection.listed_pairs.pairs[0]"},
      {"NaN epsilon",
       [](v1::CreateSceneRequest& r) { r.mutable_default_options()->set_epsilon(std::nan("")); },
       grpc::StatusCode::INVALID_ARGUMENT, "default_options.epsilon"},
      {"unknown penetration mode",
       [](v1::CreateSceneRequest& r) {
         r.mutable_default_options()->set_penetration(v1::PenetrationMode(42));
       },
       grpc::StatusCode::INVALID_ARGUMENT, "default_options.penetration"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    v1::CreateSceneRequest request = valid();
    c.mutate(request);
    v1::CreateSceneResponse response;
    expect_error(stub().CreateScene(make_context().get(), request, &response), c.code, c.field);
  }
  v1::CreateSceneResponse response;
  EXPECT_TRUE(stub().CreateScene(make_context().get(), valid(), &response).ok());
}

TEST_F(GrpcServerTest, InvalidQueriesAndUnknownIdsAreRejectedNamingTheField) {
  const LocalScene scene = make_scene(stub());
  auto valid = [&] {
    v1::QueryRequest request;
    request.set_scene_id(scene.scene_id);
    v1::ObjectPose& pose = *request.add_poses();
    pose.set_object_id(scene.object_ids[0]);
    TestPose{}.to_message(*pose.mutable_pose());
    return request;
  };
  struct Case {
    const char* what;
    std::function<void(v1::QueryRequest&)> mutate;
    grpc::StatusCode code;
    std::string field;
  };
  const std::vector<Case> cases = {
      {"unknown scene", [](v1::QueryRequest& r) { r.set_scene_id("scene-404"); },
       grpc::StatusCode::NOT_FOUND, "scene_id"},
      {"unknown object", [](v1::QueryRequest& r) { r.mutable_poses(0)->set_object_id("nobody"); },
       grpc::StatusCode::NOT_FOUND, "poses[0].object_id"},
      {"object twice", [](v1::QueryRequest& r) { *r.add_poses() = r.poses(0); },
       grpc::StatusCode::INVALID_ARGUMENT, "poses[1].object_id"},
      {"NaN quaternion component",
       [](v1::QueryRequest& r) {
         r.mutable_poses(0)->mutable_pose()->mutable_rotation()->set_x(std::nan(""));
       },
       grpc::StatusCode::INVALID_ARGUMENT, "poses[0].pose.rotation.x"},
      {"zero quaternion",
       [](v1::QueryRequest& r) {
         r.mutable_poses(0)->mutable_pose()->mutable_rotation()->set_w(0);
       },
       grpc::StatusCode::INVALID_ARGUMENT, "poses[0].pose.rotation"},
      {"infinite translation",
       [](v1::QueryRequest& r) {
         r.mutable_poses(0)->mutable_pose()->mutable_translation()->set_z(-INFINITY);
       },
       grpc::StatusCode::INVALID_ARGUMENT, "poses[0].pose.translation.z"},
      {"unknown penetration mode",
       [](v1::QueryRequest& r) { r.mutable_options()->set_penetration(v1::PenetrationMode(42)); },
       grpc::StatusCode::INVALID_ARGUMENT, "options.penetration"},
      {"negative cutoff", [](v1::QueryRequest& r) { r.mutable_options()->set_distance_cutoff(-1); },
       grpc::StatusCode::INVALID_ARGUMENT, "options.distance_cutoff"},
      {"unknown report mode",
       [](v1::QueryRequest& r) {
         r.mutable_options()->set_report_mode(static_cast<v1::ReportMode>(42));
       },
       grpc::StatusCode::INVALID_ARGUMENT, "options.report_mode"},
      {"zero iteration cap",
       [](v1::QueryRequest& r) { r.mutable_options()->set_max_iterations(0); },
       grpc::StatusCode::INVALID_ARGUMENT, "options.max_iterations"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    v1::QueryRequest request = valid();
    c.mutate(request);
    v1::DistanceReport report;
    expect_error(stub().Query(make_context().get(), request, &report), c.code, c.field);
  }
  v1::DistanceReport report;
  EXPECT_TRUE(stub().Query(make_context().get(), valid(), &report).ok());

  v1::DeleteSceneRequest delete_unknown;
  delete_unknown.set_scene_id("scene-404");
  v1::DeleteSceneResponse deleted;
  expect_error(stub().DeleteScene(make_context().get(), delete_unknown, &deleted),
               grpc::StatusCode::NOT_FOUND, "scene_id");
  v1::RemoveGeometryRequest remove_unknown;
  remove_unknown.set_geometry_id("geom-404");
  v1::RemoveGeometryResponse removed;
  expect_error(stub().RemoveGeometry(make_context().get(), remove_unknown, &removed),
               grpc::StatusCode::NOT_FOUND, "geometry_id");

  // Removing a geometry a scene uses is allowed: the scene holds it and keeps working.
  v1::RemoveGeometryRequest remove_used;
  remove_used.set_geometry_id(scene.geometry_ids[0]);
  EXPECT_TRUE(stub().RemoveGeometry(make_context().get(), remove_used, &removed).ok());
  EXPECT_TRUE(stub().Query(make_context().get(), valid(), &report).ok());
  EXPECT_EQ(report.pairs_size(), 21);
}

// Limits give RESOURCE_EXHAUSTED: geometries, scenes, vertices, message size, streams.
TEST(GrpcServerLimits, LimitsAreResourceExhausted) {
  ServerConfig config = test_config();
  config.limits.max_geometries = 2;
  config.limits.max_scenes = 1;
  config.limits.max_streams = 1;
  config.limits.max_vertices_per_geometry = 100;
  config.max_message_bytes = 64u << 10;
  RunningServer running = start_server(config);
  ASSERT_TRUE(running.server);
  v1::DistanceService::Stub& stub = *running.stub;

  const TestGeometry box = polytope_geometry("box", box_vertices({1, 1, 1}));
  const std::string first = register_geometry(stub, box);
  register_geometry(stub, polytope_geometry("box-2", box_vertices({1, 1, 1})));
  // The same geometry again is the one already stored (content ids): not a third.
  EXPECT_EQ(register_geometry(stub, box), first);
  v1::RegisterGeometryRequest request;
  *request.mutable_geometry() = polytope_geometry("box-3", box_vertices({1, 1, 1})).message;
  v1::RegisterGeometryResponse response;
  expect_error(stub.RegisterGeometry(make_context().get(), request, &response),
               grpc::StatusCode::RESOURCE_EXHAUSTED, "");

  *request.mutable_geometry() = polytope_geometry("many", random_hull_vertices(1, 101, 1)).message;
  expect_error(stub.RegisterGeometry(make_context().get(), request, &response),
               grpc::StatusCode::RESOURCE_EXHAUSTED, "geometry.pieces");
  *request.mutable_geometry() = polytope_geometry("huge", random_hull_vertices(1, 4000, 1)).message;
  expect_error(stub.RegisterGeometry(make_context().get(), request, &response),
               grpc::StatusCode::RESOURCE_EXHAUSTED, "");

  v1::CreateSceneRequest create;
  for (const char* id : {"a", "b"}) {
    v1::SceneObject& object = *create.add_objects();
    object.set_id(id);
    object.set_geometry_id(first);
  }
  v1::CreateSceneResponse created, refused;
  ASSERT_TRUE(stub.CreateScene(make_context().get(), create, &created).ok());
  expect_error(stub.CreateScene(make_context().get(), create, &refused),
               grpc::StatusCode::RESOURCE_EXHAUSTED, "");

  v1::PoseUpdate update;
  update.set_scene_id(created.scene_id());
  StreamClient open(stub);
  ASSERT_TRUE(open.write(update));
  v1::DistanceReport report;
  ASSERT_TRUE(open.read(report));
  StreamClient second(stub);
  second.write(update);
  EXPECT_FALSE(second.read(report));
  std::vector<v1::DistanceReport> rest;
  expect_error(second.read_to_end(rest), grpc::StatusCode::RESOURCE_EXHAUSTED, "");
  EXPECT_TRUE(open.finish().ok());
}

// ---- operations ----

// Graceful shutdown: open streams stop reading, answer every update they had read (a gap-free
// prefix of what was sent, each correct), and end with UNAVAILABLE; shutdown returns well
// before the drain timeout, i.e. nothing had to be cancelled.
// The drain's promise, on both RPCs: the status says "draining" and the count N of updates read
// (updates, not messages), the first N updates sent were all answered, and a batch is read whole
// or not at all.
class GrpcServerShutdown : public ::testing::TestWithParam<std::size_t> {};
INSTANTIATE_TEST_SUITE_P(Framing, GrpcServerShutdown, kFramings, framing_name);

TEST_P(GrpcServerShutdown, ShutdownDrainsOpenStreams) {
  RunningServer running = start_server();
  ASSERT_TRUE(running.server);
  const LocalScene scene = make_scene(*running.stub);
  const std::size_t batch = GetParam();
  StreamClient stream(*running.stub, kCallDeadline, batch);
  for (int step = 0; step < 5; ++step) {
    ASSERT_TRUE(
        stream.write(make_update(scene, std::uint64_t(step) + 1, trajectory(scene.size(), step))));
    ASSERT_TRUE(stream.flush());
    v1::DistanceReport report;
    ASSERT_TRUE(stream.read(report));
  }
  for (int step = 5; step < 30; ++step)  // in flight when the shutdown starts
    ASSERT_TRUE(
        stream.write(make_update(scene, std::uint64_t(step) + 1, trajectory(scene.size(), step))));
  ASSERT_TRUE(stream.flush());
  const auto begin = std::chrono::steady_clock::now();
  auto shutdown = std::async(std::launch::async, [&] { running.server->shutdown(); });
  std::vector<v1::DistanceReport> reports;
  const grpc::Status status = stream.read_to_end(reports);
  ASSERT_EQ(shutdown.wait_for(std::chrono::seconds(15)), std::future_status::ready);
  EXPECT_LT(std::chrono::steady_clock::now() - begin, std::chrono::seconds(4));
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << status.error_message();
  ::testing::Test::RecordProperty("drained_reports", int(reports.size()));
  for (std::size_t i = 0; i < reports.size(); ++i) {
    ASSERT_EQ(reports[i].sequence(), 6 + i);
    expect_matches_local(scene, trajectory(scene.size(), int(5 + i)), reports[i], false);
  }
  std::size_t read = 0;
  ASSERT_EQ(std::sscanf(status.error_message().c_str(),
                        "server is draining (shutting down): all %zu", &read),
            1)
      << status.error_message();
  EXPECT_EQ(read, 5 + reports.size()) << status.error_message();
  if (batch > 0 && read < 30) {  // whole batches: the 25 in flight went as 7, 7, 7, 4
    EXPECT_EQ((read - 5) % batch, 0u) << read << " updates read";
  }
  // New calls are refused once the server is down.
  v1::ListGeometriesResponse listed;
  EXPECT_FALSE(
      running.stub->ListGeometries(make_context(std::chrono::seconds(2)).get(), {}, &listed).ok());
}

/// The next event of a generic call's completion queue, which must carry tag `expected`; its ok.
bool next_event(grpc::CompletionQueue& queue, std::intptr_t expected) {
  void* tag = nullptr;
  bool ok = false;
  EXPECT_TRUE(queue.Next(&tag, &ok));
  EXPECT_EQ(reinterpret_cast<std::intptr_t>(tag), expected);
  return ok;
}

// The gRPC health checking protocol answers SERVING (checked with a generic call: the health
// proto's generated client is not installed by Debian's packages).
TEST_F(GrpcServerTest, HealthCheckSaysServing) {
  grpc::GenericStub generic(running_.channel);
  for (const std::string service : {"", "nearpoint.v1.DistanceService"}) {
    // HealthCheckRequest { string service = 1; }
    std::string request_bytes;
    if (!service.empty()) {
      request_bytes.push_back(0x0a);
      request_bytes.push_back(char(service.size()));
      request_bytes += service;
    }
    grpc::Slice slice(request_bytes);
    grpc::ByteBuffer request(&slice, 1), response;
    std::promise<grpc::Status> done;
    auto context = make_context();
    // The callback runs on a gRPC thread, ordered after this call by gRPC (see tsan_handoff.hpp).
    handoff_release(&done);
    generic.UnaryCall(context.get(), "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request,
                      &response, [&](grpc::Status status) {
                        handoff_acquire(&done);
                        done.set_value(status);
                      });
    const grpc::Status status = done.get_future().get();
    ASSERT_TRUE(status.ok()) << status.error_message();
    std::vector<grpc::Slice> slices;
    ASSERT_TRUE(response.Dump(&slices).ok());
    std::string bytes;
    for (const grpc::Slice& s : slices)
      bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
    EXPECT_EQ(bytes, std::string("\x08\x01", 2)) << "HealthCheckResponse { status: SERVING }";
  }
}

// Server reflection lists the services (checked with a generic call, for the same reason).
TEST_F(GrpcServerTest, ReflectionListsTheServices) {
  grpc::GenericStub generic(running_.channel);
  grpc::CompletionQueue queue;
  auto context = make_context();
  auto call = generic.PrepareCall(
      context.get(), "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo", &queue);
  ASSERT_TRUE(call);
  auto wait = [&](std::intptr_t expected) { return next_event(queue, expected); };
  call->StartCall(reinterpret_cast<void*>(1));
  ASSERT_TRUE(wait(1));
  // ServerReflectionRequest { string list_services = 7; } with an empty string.
  grpc::Slice request_slice(std::string("\x3a\x00", 2));
  grpc::ByteBuffer request(&request_slice, 1), response;
  call->Write(request, reinterpret_cast<void*>(2));
  ASSERT_TRUE(wait(2));
  call->Read(&response, reinterpret_cast<void*>(3));
  ASSERT_TRUE(wait(3));
  call->WritesDone(reinterpret_cast<void*>(4));
  wait(4);
  grpc::Status status;
  call->Finish(&status, reinterpret_cast<void*>(5));
  wait(5);
  EXPECT_TRUE(status.ok()) << status.error_message();
  queue.Shutdown();
  void* tag;
  bool ok;
  while (queue.Next(&tag, &ok)) {
  }
  std::vector<grpc::Slice> slices;
  ASSERT_TRUE(response.Dump(&slices).ok());
  std::string bytes;
  for (const grpc::Slice& s : slices)
    bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
  EXPECT_NE(bytes.find("nearpoint.v1.DistanceService"), std::string::npos);
  EXPECT_NE(bytes.find("nearpoint.v1.Diagnostics"), std::string::npos);
  EXPECT_NE(bytes.find("grpc.health.v1.Health"), std::string::npos);
}

// Every method is served on the async generic API and routed by its path (grpc_async.hpp), so
// the answers gRPC's own handlers gave are ours to give: a path no service has is UNIMPLEMENTED
// and names the path; a unary method called without a request message (a client that
// half-closes at once) is INVALID_ARGUMENT, and the server goes on serving.
TEST_F(GrpcServerTest, UnknownMethodsAndUnaryCallsWithoutARequestAreRefusedWithTheReason) {
  grpc::GenericStub generic(running_.channel);
  // One call: no message sent, `writes` ended at once; the status that ends it.
  auto call_without_request = [&](const std::string& path) {
    grpc::CompletionQueue queue;
    auto context = make_context();
    auto call = generic.PrepareCall(context.get(), path, &queue);
    auto wait = [&](std::intptr_t expected) { return next_event(queue, expected); };
    call->StartCall(reinterpret_cast<void*>(1));
    wait(1);
    call->WritesDone(reinterpret_cast<void*>(2));
    wait(2);
    grpc::Status status;
    call->Finish(&status, reinterpret_cast<void*>(3));
    wait(3);
    queue.Shutdown();
    void* tag;
    bool ok;
    while (queue.Next(&tag, &ok)) {
    }
    return status;
  };

  const grpc::Status unknown = call_without_request("/nearpoint.v1.DistanceService/NoSuchMethod");
  EXPECT_EQ(unknown.error_code(), grpc::StatusCode::UNIMPLEMENTED);
  EXPECT_NE(unknown.error_message().find("/nearpoint.v1.DistanceService/NoSuchMethod"),
            std::string::npos)
      << unknown.error_message();
  EXPECT_EQ(call_without_request("/no.such.Service/Method").error_code(),
            grpc::StatusCode::UNIMPLEMENTED);

  const grpc::Status empty = call_without_request("/nearpoint.v1.DistanceService/ListGeometries");
  EXPECT_EQ(empty.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << empty.error_message();
  EXPECT_NE(empty.error_message().find("no request"), std::string::npos) << empty.error_message();

  // Still serving.
  v1::ListGeometriesResponse listed;
  EXPECT_TRUE(stub().ListGeometries(make_context().get(), {}, &listed).ok());
}

// The echo stream the service benchmark uses for the transport floor.
TEST_F(GrpcServerTest, DiagnosticsEchoWritesBackWhatItReads) {
  auto stub = v1::Diagnostics::NewStub(running_.channel);
  auto context = make_context();
  auto stream = stub->Echo(context.get());
  for (std::uint64_t i = 1; i <= 3; ++i) {
    v1::EchoMessage message, echoed;
    message.set_sequence(i);
    message.set_payload(std::string(std::size_t(i) * 10, 'x'));
    ASSERT_TRUE(stream->Write(message));
    ASSERT_TRUE(stream->Read(&echoed));
    EXPECT_EQ(echoed.sequence(), i);
    EXPECT_EQ(echoed.payload(), message.payload());
  }
  stream->WritesDone();
  EXPECT_TRUE(stream->Finish().ok());
}

// ---- malformed messages (issue 21, items 5 and 6) ----

/// A unary call through grpc::GenericStub: arbitrary bytes, as no generated client would send.
grpc::Status raw_unary(grpc::GenericStub& generic, const std::string& method,
                       const std::string& bytes) {
  grpc::Slice slice(bytes);
  grpc::ByteBuffer request(&slice, 1), response;
  std::promise<grpc::Status> done;
  auto context = make_context();
  handoff_release(&done);  // the callback runs on a gRPC thread (see tsan_handoff.hpp)
  generic.UnaryCall(context.get(), method, grpc::StubOptions(), &request, &response,
                    [&](grpc::Status status) {
                      handoff_acquire(&done);
                      done.set_value(status);
                    });
  auto future = done.get_future();
  if (future.wait_for(kCallDeadline + std::chrono::seconds(5)) != std::future_status::ready) {
    ADD_FAILURE() << method << ": no answer";
    context->TryCancel();
  }
  return future.get();
}

/// Bytes that put invalid UTF-8 (0xC3 0x28) into the first string field reachable from `type`
/// (at the top, or one message field down); "" and `path` empty when it has none.
std::string invalid_utf8_bytes(const google::protobuf::Descriptor& type, std::string& path) {
  auto length_delimited = [](int number, const std::string& payload) {
    std::string out;
    out.push_back(char((number << 3) | 2));
    out.push_back(char(payload.size()));
    return out + payload;
  };
  for (int i = 0; i < type.field_count(); ++i) {
    const auto* field = type.field(i);
    if (field->type() == google::protobuf::FieldDescriptor::TYPE_STRING && field->number() < 16) {
      path = field->name();
      return length_delimited(field->number(), "ok\xC3\x28");
    }
  }
  for (int i = 0; i < type.field_count(); ++i) {
    const auto* field = type.field(i);
    if (field->type() != google::protobuf::FieldDescriptor::TYPE_MESSAGE || field->number() >= 16)
      continue;
    std::string inner_path;
    const std::string inner = invalid_utf8_bytes(*field->message_type(), inner_path);
    if (inner.empty() || inner_path.find('.') != std::string::npos) continue;
    path = field->name() + "." + inner_path;
    return length_delimited(field->number(), inner);
  }
  return "";
}

// gRPC's generated handlers parse a unary request before our code runs and answer a request
// that does not parse UNIMPLEMENTED with no message, which users read as "no such method". The
// service takes its methods raw and parses them itself (wire_parse.hpp): every method answers
// INVALID_ARGUMENT naming the message type, and the field when one is to blame. Checked with raw
// bytes from grpc::GenericStub: random bytes, invalid UTF-8 in a string field, 200 nested groups.
TEST_F(GrpcServerTest, MalformedUnaryRequestsAreInvalidArgumentWithAReason) {
  grpc::GenericStub generic(running_.channel);
  const google::protobuf::ServiceDescriptor* found =
      google::protobuf::DescriptorPool::generated_pool()->FindServiceByName(
          v1::DistanceService::service_full_name());
  ASSERT_NE(found, nullptr);
  const google::protobuf::ServiceDescriptor& service = *found;
  std::mt19937 random(21);
  int checked = 0;
  for (int m = 0; m < service.method_count(); ++m) {
    const google::protobuf::MethodDescriptor& method = *service.method(m);
    if (method.client_streaming()) continue;
    const google::protobuf::Descriptor& type = *method.input_type();
    const std::string name = "/" + service.full_name() + "/" + method.name();
    std::unique_ptr<google::protobuf::Message> probe(
        google::protobuf::MessageFactory::generated_factory()->GetPrototype(&type)->New());

    std::vector<std::pair<std::string, std::string>> cases;  // bytes, expected in the message
    std::string random_bytes;
    do {  // bytes that really do not parse as this type (the seed fixes which)
      random_bytes.clear();
      for (int i = 0; i < 64; ++i) random_bytes.push_back(char(random() & 0xFF));
    } while (probe->ParseFromString(random_bytes));
    cases.emplace_back(random_bytes, "");
    std::string path;
    if (const std::string utf8 = invalid_utf8_bytes(type, path); !utf8.empty())
      cases.emplace_back(utf8, "field " + path + " is not valid UTF-8");
    // Field 15 as a group (start tag 0x7B, end tag 0x7C), nested 200 deep: protobuf stops at 100.
    cases.emplace_back(std::string(200, '\x7B') + std::string(200, '\x7C'), "deeper than 100");

    for (const auto& [bytes, reason] : cases) {
      ASSERT_FALSE(probe->ParseFromString(bytes)) << name << ": the case must not parse";
      const grpc::Status status = raw_unary(generic, name, bytes);
      EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT)
          << name << ": " << status.error_message();
      EXPECT_NE(status.error_message().find("request does not parse as " + type.full_name()),
                std::string::npos)
          << name << ": " << status.error_message();
      EXPECT_NE(status.error_message().find(reason), std::string::npos)
          << name << ": " << status.error_message();
      ++checked;
    }
  }
  EXPECT_GE(checked, 6 * 2 + 5);  // six unary methods; all but ListGeometries have a string
  // Well-formed bytes are still served: an empty ListGeometriesRequest.
  EXPECT_TRUE(raw_unary(generic, "/nearpoint.v1.DistanceService/ListGeometries", "").ok());
}

// In gRPC's callback API a stream message that does not parse shows up as OnReadDone(false),
// like the client's half-close, so a valid update, garbage, then another update ended the stream
// OK with one report (the last update neither answered nor refused). The stream parses its
// messages itself: it answers what it read before the garbage, stops reading, and ends
// INVALID_ARGUMENT saying which message did not parse. Checked with a raw stream from
// grpc::GenericStub, for random garbage and for invalid UTF-8 in scene_id.
TEST_F(GrpcServerTest, MalformedStreamMessageEndsTheStreamInvalidArgument) {
  const LocalScene scene = make_scene(stub());
  std::string path;
  const std::string utf8 = invalid_utf8_bytes(*v1::PoseUpdate::descriptor(), path);
  ASSERT_EQ(path, "scene_id");
  for (const auto& [garbage, reason] :
       {std::pair<std::string, std::string>{std::string("\xFF\xFF\xFF\xFF\x0F", 5), "wire format"},
        {utf8, "field scene_id is not valid UTF-8"}}) {
    v1::PoseUpdate probe;
    ASSERT_FALSE(probe.ParseFromString(garbage));
    RawStream stream(running_.channel, "/nearpoint.v1.DistanceService/StreamPoses");
    ASSERT_TRUE(stream.started());
    ASSERT_TRUE(
        stream.write(make_update(scene, 1, trajectory(scene.size(), 1)).SerializeAsString()));
    ASSERT_TRUE(stream.write(garbage));
    // The server may already have ended the stream; this update must then go unread, not OK.
    stream.write(make_update(scene, 3, trajectory(scene.size(), 3)).SerializeAsString());
    std::vector<v1::DistanceReport> reports;
    for (std::string bytes; stream.read(bytes);) {
      reports.emplace_back();
      ASSERT_TRUE(reports.back().ParseFromString(bytes));
    }
    const grpc::Status status = stream.finish();
    ASSERT_EQ(reports.size(), 1u);
    EXPECT_EQ(reports[0].sequence(), 1u);
    expect_matches_local(scene, trajectory(scene.size(), 1), reports[0], false);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_NE(status.error_message().find("message 2 of the stream (after sequence 1) does not "
                                          "parse as nearpoint.v1.PoseUpdate"),
              std::string::npos)
        << status.error_message();
    EXPECT_NE(status.error_message().find(reason), std::string::npos) << status.error_message();
  }
}

}  // namespace
}  // namespace nearpoint::server::testing
