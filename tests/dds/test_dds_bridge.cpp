// SPDX-License-Identifier: Apache-2.0
// The DDS bridge in-process: a SceneService with the bridge on a test domain, and a real DDS
// client (the one `nearpoint stream --dds` uses) publishing samples to it. The answers are checked
// against the engine's own distance, computed here from the same numbers. Needs no gRPC.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <map>
#include <numbers>
#include <thread>
#include <tuple>

#include "common/held_workers.hpp"
#include "common/random_hull.hpp"
#include "dds_bridge.hpp"
#include "dds_test_support.hpp"
#include "nearpoint/compound.hpp"
#include "nearpoint/server/scene_service.hpp"

namespace nearpoint::dds_testing {
namespace {

using testkit::random_hull_vertices;

using model::GeometryInput;
using model::PieceInput;
using server::DdsBridge;
using server::DdsConfig;
using server::SceneService;
using server::ServiceLimits;

/// A geometry in both forms: the scene API's input and the engine's compound.
struct Geometry {
  GeometryInput input;
  Compound<double> local;
};

Geometry polytope(const std::vector<Vec3<double>>& vertices) {
  Geometry g;
  g.input.name = "polytope";
  PieceInput& piece = g.input.pieces.emplace_back();
  model::PolytopeInput shape;
  shape.vertices = vertices;
  piece.shape = shape;
  std::vector<Piece<double>> pieces;
  pieces.push_back({Shape<double>(Polytope<double>(vertices)), Pose<double>{}});
  g.local = Compound<double>(std::move(pieces));
  return g;
}

/// A capsule and a rounded box beside it (two pieces, a primitive, radii and an offset).
Geometry arm() {
  Geometry g;
  g.input.name = "arm";
  const Vec3<double> a(-0.4, 0, 0), b(0.4, 0, 0), half(0.15, 0.1, 0.2), offset(0.55, 0.1, 0);
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.5, Vec3<double>::UnitZ()));
  PieceInput& capsule = g.input.pieces.emplace_back();
  capsule.shape = Segment<double>{a, b};
  capsule.radius = 0.1;
  PieceInput& box = g.input.pieces.emplace_back();
  box.shape = Box<double>{half};
  box.radius = 0.02;
  box.offset.rotation_wxyz = {q.w(), q.x(), q.y(), q.z()};
  box.offset.translation = offset;
  std::vector<Piece<double>> pieces;
  pieces.push_back({Shape<double>::capsule(a, b, 0.1), Pose<double>{}});
  pieces.push_back(
      {Shape<double>(Box<double>{half}, 0.02), Pose<double>::from_quaternion(q, offset)});
  g.local = Compound<double>(std::move(pieces));
  return g;
}

/// A scene on the service, with the local compounds of its objects.
struct TestScene {
  std::string scene_id;
  std::vector<std::string> ids;
  std::vector<Compound<double>> local;
};

TestScene create_scene(SceneService& service, std::vector<Geometry> geometries) {
  TestScene scene;
  model::SceneInput input;
  input.name = "dds-test";
  for (std::size_t i = 0; i < geometries.size(); ++i) {
    auto registered = service.register_geometry(geometries[i].input);
    EXPECT_TRUE(registered.ok()) << registered.error().describe();
    if (!registered) return scene;
    model::ObjectInput& object = input.objects.emplace_back();
    object.id = "object-" + std::to_string(i);
    object.geometry_id = registered->geometry_id;
    object.pose.translation = Vec3<double>(2.0 * double(i), 0, 0);
    scene.ids.push_back(object.id);
    scene.local.push_back(std::move(geometries[i].local));
  }
  auto created = service.create_scene(input);
  EXPECT_TRUE(created.ok()) << created.error().describe();
  if (created) scene.scene_id = created->scene_id;
  return scene;
}

/// A server-side SceneService with the bridge started on `domain`.
struct Server {
  std::unique_ptr<SceneService> scenes;
  std::unique_ptr<DdsBridge> bridge;
  std::string prefix;
};

Server start(std::uint32_t domain, const std::string& test, ServiceLimits limits = {},
             std::size_t workers = 2) {
  Server server;
  server.scenes = std::make_unique<SceneService>(limits, workers);
  server.prefix = unique_prefix(test);
  DdsConfig config;
  config.domain_id = domain;
  config.topic_prefix = server.prefix;
  auto started = DdsBridge::start(*server.scenes, config);
  EXPECT_TRUE(started.ok()) << started.error().describe();
  if (started) server.bridge = std::move(started.value());
  return server;
}

/// Poses of every object at step k: object i circles its start, turning, so pairs come within
/// reach of each other and move smoothly (warm starts apply).
std::vector<UpdateMessage::Pose> path_poses(const TestScene& scene, int k) {
  std::vector<UpdateMessage::Pose> poses;
  for (std::size_t i = 0; i < scene.ids.size(); ++i) {
    const double t = 0.05 * k + double(i);
    const Eigen::Quaterniond q(
        Eigen::AngleAxisd(0.3 * t, Vec3<double>(1, 0.5 * double(i), 1).normalized()));
    UpdateMessage::Pose& pose = poses.emplace_back();
    pose.object_id = scene.ids[i];
    pose.rotation_wxyz = {q.w(), q.x(), q.y(), q.z()};
    pose.translation = {1.6 * double(i) + 0.4 * std::cos(t), 0.4 * std::sin(t), 0.1 * double(i)};
  }
  return poses;
}

/// Update `sequence` of the scene's path, path_poses at step `sequence`.
UpdateMessage path_update(const TestScene& scene, std::uint64_t sequence) {
  UpdateMessage update;
  update.scene_id = scene.scene_id;
  update.sequence = sequence;
  update.poses = path_poses(scene, int(sequence));
  return update;
}

/// Publishes update `sequence` of the scene's path (path_poses at step `sequence`); false (and
/// a test failure) when DDS refuses it.
bool publish_path_step(cli::DdsPoseClient& client, const TestScene& scene, std::uint64_t sequence) {
  UpdateMessage update = path_update(scene, sequence);
  std::string error;
  const bool published = client.publish(update.sample(), error);
  EXPECT_TRUE(published) << error;
  return published;
}

Pose<double> to_pose(const UpdateMessage::Pose& pose) {
  const auto& q = pose.rotation_wxyz;
  return Pose<double>::from_quaternion(
      Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized(),
      Vec3<double>(pose.translation[0], pose.translation[1], pose.translation[2]));
}

/// Checks each pair of `report` against the engine's distance at `poses` (within both certified
/// bounds, intersecting alike); returns how many of its pairs were warm-started.
int expect_engine_distances(const ReceivedReport& report, const TestScene& scene,
                            const std::vector<UpdateMessage::Pose>& poses) {
  int warm = 0;
  for (const ReceivedPair& pair : report.pairs) {
    const std::size_t a = std::size_t(pair.object_a.back() - '0');
    const std::size_t b = std::size_t(pair.object_b.back() - '0');
    const auto truth =
        distance(scene.local[a], to_pose(poses[a]), scene.local[b], to_pose(poses[b])).nearest;
    EXPECT_NEAR(pair.distance, truth.distance, pair.error_bound + truth.error_bound + 1e-12)
        << pair.object_a << "/" << pair.object_b;
    EXPECT_EQ(pair.status == 2, truth.status == Status::intersecting)
        << pair.object_a << "/" << pair.object_b;
    warm += pair.warm_started;
  }
  return warm;
}

// The whole path of a DDS stream: every update answered once, in order, each pair's distance
// equal to the engine's within the certified bounds, and warm starts used after the first.
TEST(DdsBridge, StreamAnswersEveryUpdateWithTheCoresDistances) {
  Server server = start(kDomainStream, "stream");
  ASSERT_TRUE(server.bridge);
  const TestScene scene =
      create_scene(*server.scenes, {polytope(random_hull_vertices(7, 40, 0.7)), arm(),
                                    polytope(random_hull_vertices(8, 12, 0.5))});
  ASSERT_FALSE(scene.scene_id.empty());
  auto client = connect(kDomainStream, server.prefix);
  ASSERT_TRUE(client);

  constexpr int kUpdates = 40;
  constexpr int kWindow = 4;
  std::map<std::uint64_t, std::vector<UpdateMessage::Pose>> sent;
  std::vector<ReceivedReport> reports;
  std::string error;
  int next = 1;
  while (reports.size() < std::size_t(kUpdates)) {
    while (next <= kUpdates && next - 1 - int(reports.size()) < kWindow) {
      UpdateMessage update;
      update.scene_id = scene.scene_id;
      update.sequence = std::uint64_t(next);
      update.poses = path_poses(scene, next);
      sent[update.sequence] = update.poses;
      ASSERT_TRUE(client->publish(update.sample(), error)) << error;
      ++next;
    }
    const std::size_t before = reports.size();
    for (ReceivedReport& report : collect_reports(*client, 1)) reports.push_back(std::move(report));
    ASSERT_GT(reports.size(), before) << "no report after " << before;
  }

  int warm = 0;
  for (std::size_t k = 0; k < reports.size(); ++k) {
    const ReceivedReport& report = reports[k];
    SCOPED_TRACE("report " + std::to_string(k));
    ASSERT_EQ(report.sequence, k + 1) << "reports are complete and in sequence order";
    ASSERT_EQ(report.status, 0u) << report.error_field << ": " << report.message;
    EXPECT_EQ(report.client_id, "test");
    EXPECT_EQ(report.coalesced_updates, 0u);
    ASSERT_EQ(report.pairs.size(), 3u);
    // The counts cross DDS too: every pair counted once, nothing reused in the first report.
    EXPECT_EQ(report.pairs_evaluated + report.pairs_pruned + report.pairs_unmoved, 3u);
    if (k == 0) {
      EXPECT_EQ(report.pairs_unmoved, 0u);
    }
    warm += expect_engine_distances(report, scene, sent.at(report.sequence));
  }
  EXPECT_GT(warm, kUpdates) << "the stream's caches warm-start its later updates";
  server.bridge->shutdown();  // the counters are final once every evaluation has ended
  EXPECT_EQ(server.bridge->stats().reports_written, std::uint64_t(kUpdates));
  EXPECT_EQ(server.bridge->stats().updates_taken, std::uint64_t(kUpdates));
}

// Bad samples are answered with an error report on the report topic naming the sequence number
// and the field, and the server — and the stream — go on. The id and name rules are gRPC's
// (check_id, check_name before a sample's strings become a stream key, a log value or a report
// key): a 10 kB scene id, an object id with a space and a client id with a line break are
// refused as malformed, every message quoting at most a short prefix.
TEST(DdsBridge, BadSamplesGetErrorReportsAndTheStreamGoesOn) {
  Server server = start(kDomainBadSamples, "bad");
  ASSERT_TRUE(server.bridge);
  const TestScene scene =
      create_scene(*server.scenes, {arm(), polytope(random_hull_vertices(3, 20, 0.5))});
  auto client = connect(kDomainBadSamples, server.prefix);
  ASSERT_TRUE(client);
  std::string error;

  struct Case {
    const char* what;
    std::uint32_t status;  // 0: accepted
    const char* field;
  };
  const Case cases[] = {
      {"unknown scene", 5, "scene_id"},
      {"good", 0, ""},
      {"NaN translation", 3, "poses[0].pose.translation.x"},
      {"unknown object", 5, "poses[0].object_id"},
      {"sequence not increasing", 3, "sequence"},
      {"quaternion far from unit", 3, "poses[0].pose.rotation"},
      {"unknown penetration mode", 3, "options.penetration"},
      {"infinite rotation", 3, "poses[0].pose.rotation.w"},
      {"scene id of 10 kB", 3, "scene_id"},
      {"object id with a space", 3, "poses[0].object_id"},
      {"client id with a line break", 3, "client_id"},
      {"good again", 0, ""},
  };
  std::uint64_t sequence = 0;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    UpdateMessage update;
    update.scene_id = scene.scene_id;
    update.sequence = ++sequence;
    update.poses = path_poses(scene, int(sequence));
    const std::string what = c.what;
    if (what == "unknown scene") update.scene_id = "no-such-scene";
    if (what == "NaN translation") update.poses[0].translation[0] = std::nan("");
    if (what == "unknown object") update.poses[0].object_id = "ghost";
    if (what == "sequence not increasing") update.sequence = 2;  // the last accepted one
    if (what == "quaternion far from unit") update.poses[0].rotation_wxyz = {2, 0, 0, 0};
    if (what == "unknown penetration mode") update.options.penetration = 9;
    if (what == "infinite rotation") update.poses[0].rotation_wxyz[0] = INFINITY;
    if (what == "scene id of 10 kB") update.scene_id = std::string(10'000, 's');
    if (what == "object id with a space") update.poses[0].object_id = "left arm";
    if (what == "client id with a line break") update.client_id = "robot\nlevel=error";
    ASSERT_TRUE(client->publish(update.sample(), error)) << error;
    const std::vector<ReceivedReport> reports = collect_reports(*client, 1);
    ASSERT_EQ(reports.size(), 1u) << "every sample is answered, bad ones included";
    EXPECT_EQ(reports[0].sequence, update.sequence);
    EXPECT_EQ(reports[0].status, c.status) << reports[0].message;
    EXPECT_EQ(reports[0].error_field, c.field) << reports[0].message;
    if (c.status == 0) {
      EXPECT_EQ(reports[0].pairs.size(), 1u);
    } else {
      EXPECT_TRUE(reports[0].pairs.empty());
      EXPECT_FALSE(reports[0].message.empty());
      EXPECT_LT(reports[0].message.size(), 300u) << reports[0].message.substr(0, 300);
    }
  }
  server.bridge->shutdown();
  EXPECT_EQ(server.bridge->stats().updates_rejected, 10u);
}

// PENETRATION_MODE_DEPTH over DDS: spheres of radius 1.25 and 1, centres 2 apart, overlap by
// exactly 0.25; the report's sample carries the signed distance and the depth with intervals
// containing it, the direction and witnesses; a negative threshold fires ENTER with the signed
// distance; the depth fields stay unset without the mode.
TEST(DdsBridge, DepthModeReportsCarryTheSignedDistanceAndTheDepth) {
  Server server = start(kDomainDepth, "depth");
  ASSERT_TRUE(server.bridge);
  auto sphere = [](double radius) {
    Geometry g;
    g.input.name = "sphere";
    PieceInput& piece = g.input.pieces.emplace_back();
    piece.shape = Point{};
    piece.radius = radius;
    std::vector<Piece<double>> pieces;
    pieces.push_back({Shape<double>(Point{}, radius), Pose<double>{}});
    g.local = Compound<double>(std::move(pieces));
    return g;
  };
  const TestScene scene = create_scene(*server.scenes, {sphere(1.25), sphere(1.0)});
  auto client = connect(kDomainDepth, server.prefix);
  ASSERT_TRUE(client);
  std::string error;
  UpdateMessage update;
  update.scene_id = scene.scene_id;
  update.sequence = 1;
  update.options.penetration = 3;  // PENETRATION_MODE_DEPTH
  update.thresholds.push_back({"deep", scene.ids[0], scene.ids[1], -0.125, 0, 0});
  ASSERT_TRUE(client->publish(update.sample(), error)) << error;
  std::vector<ReceivedReport> reports = collect_reports(*client, 1);
  ASSERT_EQ(reports.size(), 1u);
  ASSERT_EQ(reports[0].status, 0u) << reports[0].error_field << ": " << reports[0].message;
  ASSERT_EQ(reports[0].pairs.size(), 1u);
  const ReceivedPair& pair = reports[0].pairs[0];
  EXPECT_EQ(pair.status, 2);  // intersecting
  ASSERT_TRUE(pair.has_penetration_depth);
  ASSERT_TRUE(pair.has_signed_distance);
  EXPECT_LE(pair.depth_lower, 0.25);
  EXPECT_GE(pair.depth_upper, 0.25);
  EXPECT_NEAR(pair.depth, 0.25, 1e-12);
  EXPECT_EQ(pair.signed_distance, -pair.depth);
  EXPECT_LE(pair.signed_distance_lower, -0.25);
  EXPECT_GE(pair.signed_distance_upper, -0.25);
  EXPECT_NEAR(pair.depth_direction[0], 1.0, 1e-12);
  EXPECT_NEAR(pair.depth_point_a[0], 1.25, 1e-12);  // A's deepest point in B
  EXPECT_NEAR(pair.depth_point_b[0], 1.0, 1e-12);   // B's deepest point in A
  EXPECT_TRUE(pair.depth_termination == 1 || pair.depth_termination == 2)
      << int(pair.depth_termination);
  ASSERT_EQ(reports[0].events.size(), 1u);
  EXPECT_EQ(reports[0].events[0].crossing, 1);  // enter
  EXPECT_NEAR(reports[0].events[0].distance, -0.25, 1e-12);

  // A later update without the depth mode: refused (the threshold needs it), naming the field.
  UpdateMessage plain;
  plain.scene_id = scene.scene_id;
  plain.sequence = 2;
  plain.options.penetration = 1;  // none
  ASSERT_TRUE(client->publish(plain.sample(), error)) << error;
  reports = collect_reports(*client, 1);
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_EQ(reports[0].status, 3u);
  EXPECT_EQ(reports[0].error_field, "options.penetration") << reports[0].message;
  server.bridge->shutdown();
}

/// Waits (at most 20 s) until the bridge has taken `count` updates.
void wait_taken(const DdsBridge& bridge, std::uint64_t count) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (bridge.stats().updates_taken < count && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
}

/// Takes the client's reports until they account for updates 1 … `updates`, each answering
/// exactly the updates after the previous report's: its own and those merged into it
/// (coalesced_from_sequence … sequence). Fails the test on an error report, a gap or a timeout.
std::vector<ReceivedReport> collect_accounted(cli::DdsPoseClient& client, std::uint64_t updates) {
  std::vector<ReceivedReport> reports;
  std::uint64_t accounted = 0;
  while (accounted < updates) {
    std::vector<ReceivedReport> got = collect_reports(client, 1, std::chrono::seconds(20));
    if (got.empty()) {
      ADD_FAILURE() << "missing reports after sequence " << accounted;
      break;
    }
    for (ReceivedReport& report : got) {
      EXPECT_EQ(report.status, 0u) << report.error_field << ": " << report.message;
      const std::uint64_t first =
          report.coalesced_updates > 0 ? report.coalesced_from_sequence : report.sequence;
      EXPECT_EQ(first, accounted + 1) << "report " << report.sequence;
      EXPECT_EQ(report.sequence - first, report.coalesced_updates) << "report " << report.sequence;
      accounted = report.sequence;
      reports.push_back(std::move(report));
    }
  }
  EXPECT_EQ(accounted, updates);
  return reports;
}

/// Update `s` of the threshold tests: object-1 on object-0 (intersecting) for even s, 20 m away
/// for odd s, asking for the global minimum; the first names a threshold on that pair.
UpdateMessage toggle_update(const TestScene& scene, std::uint64_t s) {
  UpdateMessage update;
  update.scene_id = scene.scene_id;
  update.sequence = s;
  update.options.report_mode = 4;  // global minimum
  update.poses = {{scene.ids[1], {1, 0, 0, 0}, {s % 2 ? 20.0 : 0.0, 0, 0}}};
  if (s == 1) update.thresholds = {{"touch", scene.ids[0], scene.ids[1], 0.05, 0.01, 0}};
  return update;
}

/// The reports of toggle_update 1 … `updates`: each names its mode, holds the global minimum at
/// most, and every ENTER and EXIT comes once, in order, with the sequence number of its update.
void expect_toggle_events(const std::vector<ReceivedReport>& reports, const TestScene& scene,
                          std::uint64_t updates) {
  std::vector<std::pair<std::uint64_t, std::uint8_t>> events;
  for (const ReceivedReport& report : reports) {
    EXPECT_EQ(report.report_mode, 4u);
    EXPECT_LE(report.pairs.size(), 1u);  // the global minimum only
    for (const ReceivedReport::Event& e : report.events) {
      EXPECT_EQ(e.threshold, "touch");
      EXPECT_EQ(e.object_a, scene.ids[0]);
      EXPECT_EQ(e.object_b, scene.ids[1]);
      events.emplace_back(e.sequence, e.crossing);
    }
  }
  ASSERT_EQ(events.size(), std::size_t(updates - 1));
  for (std::size_t e = 0; e < events.size(); ++e) {
    EXPECT_EQ(events[e].first, e + 2);
    EXPECT_EQ(events[e].second, e % 2 ? 2 : 1);  // enter, exit, enter, …
  }
}

// A publisher faster than the server: DDS cannot hold it back, so updates beyond --max-in-flight
// waiting ones are merged into the newest, and its report says which. Every update is accounted
// for exactly once, and the reports still come in sequence order.
TEST(DdsBridge, UpdatesFasterThanTheServerAreMergedAndReportedSo) {
  ServiceLimits limits;
  limits.max_in_flight_per_stream = 2;
  // Every evaluation on the pool (--no-inline-evaluation), which the test holds: small ones
  // would otherwise run on the bridge thread, which nothing holds.
  limits.inline_evaluation = false;
  Server server = start(kDomainOverload, "overload", limits, /*workers=*/1);
  ASSERT_TRUE(server.bridge);
  const TestScene scene =
      create_scene(*server.scenes, {polytope(random_hull_vertices(40, 60, 0.9)), arm(),
                                    polytope(random_hull_vertices(41, 60, 0.9))});
  ASSERT_FALSE(scene.scene_id.empty());
  auto client = connect(kDomainOverload, server.prefix);
  ASSERT_TRUE(client);

  // "Slower than the publisher" must not depend on how fast the engine is today: the only
  // worker is held until the bridge has taken every update.
  testkit::HeldWorkers held(*server.scenes, scene.scene_id);
  ASSERT_TRUE(held.held());

  constexpr std::uint64_t kUpdates = 30;
  for (std::uint64_t s = 1; s <= kUpdates; ++s) ASSERT_TRUE(publish_path_step(*client, scene, s));
  wait_taken(*server.bridge, kUpdates);
  held.release();
  ASSERT_EQ(server.bridge->stats().updates_taken, kUpdates) << "the bridge took every update";

  // Each report answers its own update and the merged ones before it: exactly the sequence
  // numbers after the previous report's.
  const std::vector<ReceivedReport> reports = collect_accounted(*client, kUpdates);
  for (const ReceivedReport& report : reports) EXPECT_EQ(report.pairs.size(), 3u);
  // Update 1 went to the (held) pool at once; of the 29 after it, at most max_in_flight = 2
  // waited, so exactly 1 + 2 reports answer all 30 and 27 updates were merged.
  EXPECT_EQ(reports.size(), 3u);
  server.bridge->shutdown();
  EXPECT_EQ(server.bridge->stats().updates_coalesced, kUpdates - 3);
  EXPECT_EQ(server.bridge->stats().reports_written, 3u);
}

// A small scene's updates are evaluated on the bridge thread, which then writes their reports
// (PoseStream::evaluates_inline, as on gRPC): no worker wake-up and hand-back per update. With
// every worker of the pool held, a stream is still answered, in order and without merges; were
// its evaluations handed to the pool, no report would come until the workers are released.
TEST(DdsBridge, SmallUpdatesAreAnsweredByTheBridgeThreadWhileThePoolIsBusy) {
  Server server = start(kDomainInline, "inline", {}, /*workers=*/1);
  ASSERT_TRUE(server.bridge);
  const TestScene scene =
      create_scene(*server.scenes, {polytope(random_hull_vertices(9, 30, 0.7)), arm()});
  ASSERT_FALSE(scene.scene_id.empty());
  auto client = connect(kDomainInline, server.prefix);
  ASSERT_TRUE(client);
  testkit::HeldWorkers held(*server.scenes, scene.scene_id);
  ASSERT_TRUE(held.held());

  constexpr std::uint64_t kUpdates = 12;
  std::vector<ReceivedReport> reports;
  for (std::uint64_t s = 1; s <= kUpdates; ++s) {
    ASSERT_TRUE(publish_path_step(*client, scene, s));
    if (s % 3 == 0) {  // a window of three in flight
      while (reports.size() < s) {
        std::vector<ReceivedReport> got = collect_reports(*client, 1, std::chrono::seconds(10));
        ASSERT_FALSE(got.empty()) << "no report for sequence " << reports.size() + 1
                                  << " while the pool is held";
        for (ReceivedReport& report : got) reports.push_back(std::move(report));
      }
    }
  }
  ASSERT_EQ(reports.size(), kUpdates);
  for (std::size_t k = 0; k < reports.size(); ++k) {
    EXPECT_EQ(reports[k].sequence, k + 1);
    EXPECT_EQ(reports[k].status, 0u) << reports[k].message;
    EXPECT_EQ(reports[k].coalesced_updates, 0u);
    EXPECT_EQ(reports[k].pairs.size(), 1u);
  }
  held.release();
  server.bridge->shutdown();
  EXPECT_EQ(server.bridge->stats().reports_written, kUpdates);
}

// Modes and threshold events over DDS, through merged updates: the same as gRPC. While the only
// worker is held, a client publishes twelve updates that put object-1 on object-0 and take it
// away again, naming a threshold on that pair in the first and asking for the global minimum;
// every ENTER and EXIT arrives once, in order, with its own sequence number, even though most
// updates were merged, and the reports say which mode chose their pairs.
TEST(DdsBridge, ModesAndThresholdEventsSurviveMergedUpdates) {
  ServiceLimits limits;
  limits.max_in_flight_per_stream = 2;
  limits.inline_evaluation = false;  // the held pool makes updates wait (see above)
  Server server = start(kDomainEvents, "events", limits, /*workers=*/1);
  ASSERT_TRUE(server.bridge);
  const TestScene scene = create_scene(*server.scenes, {arm(), arm(), arm()});
  ASSERT_FALSE(scene.scene_id.empty());
  auto client = connect(kDomainEvents, server.prefix);
  ASSERT_TRUE(client);
  testkit::HeldWorkers held(*server.scenes, scene.scene_id);
  ASSERT_TRUE(held.held());

  constexpr std::uint64_t kUpdates = 12;
  std::string error;
  for (std::uint64_t s = 1; s <= kUpdates; ++s)
    ASSERT_TRUE(client->publish(toggle_update(scene, s).sample(), error)) << error;
  wait_taken(*server.bridge, kUpdates);
  held.release();
  ASSERT_EQ(server.bridge->stats().updates_taken, kUpdates);

  const std::vector<ReceivedReport> reports = collect_accounted(*client, kUpdates);
  EXPECT_LT(reports.size(), std::size_t(kUpdates));  // updates were merged
  expect_toggle_events(reports, scene, kUpdates);
  server.bridge->shutdown();
}

// Two clients on one scene are two streams: each gets exactly its own reports, with its own
// sequence numbers and caches.
TEST(DdsBridge, ClientsSharingASceneGetTheirOwnReports) {
  Server server = start(kDomainSharedScene, "shared");
  ASSERT_TRUE(server.bridge);
  const TestScene scene =
      create_scene(*server.scenes, {arm(), polytope(random_hull_vertices(5, 30, 0.6))});
  auto first = connect(kDomainSharedScene, server.prefix);
  auto second = connect(kDomainSharedScene, server.prefix);
  ASSERT_TRUE(first && second);
  std::string error;
  // Fewer than --max-in-flight (8) per stream, so that none is merged.
  constexpr std::uint64_t kUpdates = 6;
  for (std::uint64_t s = 1; s <= kUpdates; ++s) {
    for (auto* client : {first.get(), second.get()}) {
      UpdateMessage update;
      update.scene_id = scene.scene_id;
      update.client_id = client == first.get() ? "first" : "second";
      update.sequence = s;  // both streams count from 1: they are independent
      update.poses = path_poses(scene, int(s) + (client == first.get() ? 0 : 50));
      ASSERT_TRUE(client->publish(update.sample(), error)) << error;
    }
  }
  for (auto* client : {first.get(), second.get()}) {
    const std::vector<ReceivedReport> reports = collect_reports(*client, kUpdates);
    ASSERT_EQ(reports.size(), kUpdates);
    for (std::uint64_t k = 0; k < kUpdates; ++k) {
      EXPECT_EQ(reports[k].sequence, k + 1);
      EXPECT_EQ(reports[k].status, 0u) << reports[k].message;
      EXPECT_EQ(reports[k].client_id, client == first.get() ? "first" : "second");
    }
    // Nothing else addressed to this client is left over.
    EXPECT_TRUE(collect_reports(*client, 1, std::chrono::milliseconds(200)).empty());
  }
  EXPECT_EQ(server.bridge->stats().open_streams, 2u);
}

// ---- batches: PoseUpdateBatch_ in, DistanceReportBatch_ out ----

// A batched stream is the unbatched one with other framing: every update of every batch gets
// its own report with its own sequence number, in order, with the engine's distances and warm
// starts, and the reports travel several to a sample (the point of batching). Were a batch's
// updates answered as one, or its reports written one per sample, this fails.
TEST(DdsBridge, BatchesAreAnsweredUpdateByUpdateInOrder) {
  Server server = start(kDomainBatchStream, "batch_stream");
  ASSERT_TRUE(server.bridge);
  const TestScene scene =
      create_scene(*server.scenes, {polytope(random_hull_vertices(7, 40, 0.7)), arm(),
                                    polytope(random_hull_vertices(8, 12, 0.5))});
  ASSERT_FALSE(scene.scene_id.empty());
  auto client = connect(kDomainBatchStream, server.prefix, /*batched=*/true);
  ASSERT_TRUE(client);

  constexpr std::uint64_t kBatch = 4;
  constexpr std::uint64_t kUpdates = 40;  // ten batches, two in flight: within --max-in-flight
  std::map<std::uint64_t, std::vector<UpdateMessage::Pose>> sent;
  std::vector<ReceivedReport> reports;
  std::string error;
  std::uint64_t next = 1;
  while (reports.size() < kUpdates) {
    while (next <= kUpdates && next - 1 - reports.size() + kBatch <= 2 * kBatch) {
      BatchMessage batch;
      for (std::uint64_t k = 0; k < kBatch; ++k) {
        batch.updates.push_back(path_update(scene, next + k));
        sent[next + k] = batch.updates.back().poses;
      }
      ASSERT_TRUE(client->publish_batch(batch.sample(), error)) << error;
      next += kBatch;
    }
    const std::size_t before = reports.size();
    for (ReceivedReport& report : collect_reports(*client, 1)) reports.push_back(std::move(report));
    ASSERT_GT(reports.size(), before) << "no report after " << before;
  }
  ASSERT_EQ(reports.size(), kUpdates);
  int warm = 0;
  for (std::size_t k = 0; k < reports.size(); ++k) {
    const ReceivedReport& report = reports[k];
    SCOPED_TRACE("report " + std::to_string(k));
    ASSERT_EQ(report.sequence, k + 1) << "reports are complete and in sequence order";
    ASSERT_EQ(report.status, 0u) << report.error_field << ": " << report.message;
    EXPECT_EQ(report.coalesced_updates, 0u);
    ASSERT_EQ(report.pairs.size(), 3u);
    warm += expect_engine_distances(report, scene, sent.at(report.sequence));
  }
  EXPECT_GT(warm, int(kUpdates)) << "the stream's caches warm-start its later updates";
  EXPECT_LT(client->report_samples(), kUpdates) << "reports travel several to a sample";
  server.bridge->shutdown();
  EXPECT_EQ(server.bridge->stats().reports_written, kUpdates);
  EXPECT_EQ(server.bridge->stats().updates_taken, kUpdates);
}

// A batch's bad updates are answered in their place: each rejected update gets its error report
// between the reports of the updates around it, with its own sequence number and field, and the
// updates after it are evaluated as if it had never come (the sequence check compares with the
// last accepted one). An update with a malformed scene id belongs to no stream; its error report
// comes on the batch report topic too. The stream goes on with the next batch.
TEST(DdsBridge, RejectedUpdatesMidBatchAreAnsweredInPlace) {
  Server server = start(kDomainBatchErrors, "batch_errors");
  ASSERT_TRUE(server.bridge);
  const TestScene scene =
      create_scene(*server.scenes, {arm(), polytope(random_hull_vertices(3, 20, 0.5))});
  auto client = connect(kDomainBatchErrors, server.prefix, /*batched=*/true);
  ASSERT_TRUE(client);
  std::string error;

  BatchMessage batch;
  for (std::uint64_t s = 1; s <= 7; ++s) batch.updates.push_back(path_update(scene, s));
  batch.updates[1].poses[0].translation[0] = std::nan("");  // 2: NaN
  batch.updates[3].sequence = 3;                            // 4: not after 3, the last accepted
  batch.updates[4].poses[0].object_id = "ghost";            // 5: unknown object
  batch.updates[5].scene_id = std::string(10'000, 's');     // 6: malformed scene id
  ASSERT_TRUE(client->publish_batch(batch.sample(), error)) << error;
  std::vector<ReceivedReport> reports = collect_reports(*client, 7);
  ASSERT_EQ(reports.size(), 7u) << "every update of the batch is answered";

  // The malformed scene id's report (sequence 6) is not on the stream; the others are, in order.
  std::vector<std::tuple<std::uint64_t, std::uint32_t, std::string>> stream;
  std::size_t malformed = 0;
  for (const ReceivedReport& report : reports) {
    if (report.sequence == 6) {
      ++malformed;
      EXPECT_EQ(report.status, 3u);
      EXPECT_EQ(report.error_field, "scene_id") << report.message;
      EXPECT_LT(report.message.size(), 300u);
      continue;
    }
    stream.emplace_back(report.sequence, report.status, report.error_field);
    if (report.status == 0) {
      EXPECT_EQ(report.pairs.size(), 1u);
    }
  }
  EXPECT_EQ(malformed, 1u);
  const std::vector<std::tuple<std::uint64_t, std::uint32_t, std::string>> expected{
      {1, 0, ""},         {2, 3, "poses[0].pose.translation.x"}, {3, 0, ""},
      {3, 3, "sequence"}, {5, 5, "poses[0].object_id"},          {7, 0, ""}};
  EXPECT_EQ(stream, expected);

  BatchMessage after;
  after.updates.push_back(path_update(scene, 8));
  after.updates.push_back(path_update(scene, 9));
  ASSERT_TRUE(client->publish_batch(after.sample(), error)) << error;
  reports = collect_reports(*client, 2);
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_EQ(reports[0].sequence, 8u);
  EXPECT_EQ(reports[1].sequence, 9u);
  EXPECT_EQ(reports[0].status, 0u) << reports[0].message;
  EXPECT_EQ(reports[1].status, 0u) << reports[1].message;
  server.bridge->shutdown();
  EXPECT_EQ(server.bridge->stats().updates_rejected, 4u);
  EXPECT_EQ(server.bridge->stats().updates_taken, 9u);
}

/// What a held_batch run saw: the scene, the reports (accounting for every update, see
/// collect_accounted) and the bridge's counters after its shutdown.
struct HeldBatchRun {
  TestScene scene;
  std::vector<ReceivedReport> reports;
  server::DdsBridgeStats stats;
};

/// Publishes updates 1 … Σ`batches` (make(scene, s)) as consecutive batches of those sizes to a
/// bridge whose only worker is held (max_in_flight 2, every evaluation on the pool), and releases
/// the worker once the bridge has taken them all: batches arriving faster than the server
/// answers, for certain.
template <class Make>
HeldBatchRun held_batches(std::uint32_t domain, const std::string& name,
                          std::vector<Geometry> geometries,
                          const std::vector<std::uint64_t>& batches, Make make) {
  std::uint64_t updates = 0;
  for (const std::uint64_t size : batches) updates += size;
  HeldBatchRun run;
  ServiceLimits limits;
  limits.max_in_flight_per_stream = 2;
  limits.inline_evaluation = false;  // the held pool makes updates wait
  Server server = start(domain, name, limits, /*workers=*/1);
  if (!server.bridge) return run;
  run.scene = create_scene(*server.scenes, std::move(geometries));
  auto client = connect(domain, server.prefix, /*batched=*/true);
  if (run.scene.scene_id.empty() || !client) return run;
  testkit::HeldWorkers held(*server.scenes, run.scene.scene_id);
  EXPECT_TRUE(held.held());
  std::uint64_t next = 1;
  for (const std::uint64_t size : batches) {
    BatchMessage batch;
    for (std::uint64_t k = 0; k < size; ++k) batch.updates.push_back(make(run.scene, next++));
    std::string error;
    EXPECT_TRUE(client->publish_batch(batch.sample(), error)) << error;
  }
  wait_taken(*server.bridge, updates);
  held.release();
  EXPECT_EQ(server.bridge->stats().updates_taken, updates) << "the bridge took every update";
  run.reports = collect_accounted(*client, updates);
  server.bridge->shutdown();
  run.stats = server.bridge->stats();
  return run;
}

// A batch is admitted whole when it arrives while fewer than max_in_flight updates wait (as
// gRPC's BLOCK reads a batch whole), and merged update by update when it arrives while that many
// wait. The only worker is held, max_in_flight = 2: the first batch of 30 finds the stream idle
// and all 30 are answered on their own (merged down to the limit, 27 would have been lost to
// merging with no overload at all); the second finds 29 waiting, so each of its 20 updates is
// merged into the newest waiting one, overload counted in updates as with 20 samples. Every
// update is accounted for once, in order.
TEST(DdsBridge, BatchedUpdatesFasterThanTheServerAreMergedCountingUpdates) {
  const HeldBatchRun run = held_batches(kDomainBatchOverload, "batch_overload",
                                        {polytope(random_hull_vertices(40, 60, 0.9)), arm(),
                                         polytope(random_hull_vertices(41, 60, 0.9))},
                                        {30, 20}, path_update);
  EXPECT_EQ(run.reports.size(), 30u);
  EXPECT_EQ(run.stats.updates_coalesced, 20u);
  EXPECT_EQ(run.stats.reports_written, 30u);
  ASSERT_FALSE(run.reports.empty());
  EXPECT_EQ(run.reports.back().sequence, 50u) << "the last report absorbed the second batch";
}

// Thresholds through batches: two batches put object-1 on object-0 and take it away again,
// twelve times in turn, naming a threshold in the first update. Every ENTER and EXIT arrives
// once, in order, with the sequence number of the update that crossed, also when updates were
// merged (max_in_flight 2, the worker held: the second batch finds the first waiting), as for
// unbatched updates.
TEST(DdsBridge, ThresholdEventsOfBatchedUpdatesKeepTheirSequenceNumbers) {
  constexpr std::uint64_t kUpdates = 12;
  const HeldBatchRun run = held_batches(kDomainBatchEvents, "batch_events", {arm(), arm(), arm()},
                                        {6, 6}, toggle_update);
  EXPECT_LT(run.reports.size(), std::size_t(kUpdates));  // updates were merged
  expect_toggle_events(run.reports, run.scene, kUpdates);
  EXPECT_EQ(run.stats.write_failures, 0u);
}

// A batch of more than kMaxUpdatesPerBatch updates is refused whole with one clear error report
// (RESOURCE_EXHAUSTED, field "updates", naming the count and the limit) and none of its updates
// is read: the same sequence numbers are accepted afterwards. Meanwhile the bridge serves another
// client, and the refused one's next batch.
TEST(DdsBridge, AnOversizedBatchGetsOneErrorAndTheBridgeServesOthers) {
  Server server = start(kDomainBatchOversized, "batch_oversized");
  ASSERT_TRUE(server.bridge);
  const TestScene scene =
      create_scene(*server.scenes, {arm(), polytope(random_hull_vertices(5, 30, 0.6))});
  ASSERT_FALSE(scene.scene_id.empty());
  auto batched = connect(kDomainBatchOversized, server.prefix, /*batched=*/true);
  auto single = connect(kDomainBatchOversized, server.prefix);
  ASSERT_TRUE(batched && single);
  std::string error;

  const std::uint64_t oversized = dds::kMaxUpdatesPerBatch + 1;
  BatchMessage big;
  for (std::uint64_t s = 1; s <= oversized; ++s) big.updates.push_back(path_update(scene, s));
  ASSERT_TRUE(batched->publish_batch(big.sample(), error)) << error;
  std::vector<ReceivedReport> reports = collect_reports(*batched, 1);
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_EQ(reports[0].sequence, 1u);
  EXPECT_EQ(reports[0].status, 8u);  // RESOURCE_EXHAUSTED
  EXPECT_EQ(reports[0].error_field, "updates");
  EXPECT_NE(reports[0].message.find(std::to_string(oversized) + " updates"), std::string::npos)
      << reports[0].message;
  EXPECT_NE(reports[0].message.find("at most " + std::to_string(dds::kMaxUpdatesPerBatch)),
            std::string::npos)
      << reports[0].message;
  EXPECT_TRUE(collect_reports(*batched, 1, std::chrono::milliseconds(300)).empty())
      << "one error report for the whole batch";

  ASSERT_TRUE(single->publish(path_update(scene, 1).sample(), error)) << error;
  reports = collect_reports(*single, 1);
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_EQ(reports[0].status, 0u) << reports[0].message;

  BatchMessage fits;
  for (std::uint64_t s = 1; s <= 3; ++s) fits.updates.push_back(path_update(scene, s));
  ASSERT_TRUE(batched->publish_batch(fits.sample(), error)) << error;
  reports = collect_reports(*batched, 3);
  ASSERT_EQ(reports.size(), 3u);
  for (std::uint64_t k = 0; k < 3; ++k) {
    EXPECT_EQ(reports[k].sequence, k + 1) << "none of the refused batch's updates was read";
    EXPECT_EQ(reports[k].status, 0u) << reports[k].message;
  }
  server.bridge->shutdown();
  EXPECT_EQ(server.bridge->stats().updates_rejected, oversized);
}

// Shutdown drains a batched stream: every update already taken is answered — the reports held
// for the stream's batch included — before the bridge deletes its writers. The shutdown starts
// while the only worker is still held, so the answers come after it began.
TEST(DdsBridge, ShutdownAnswersEveryBatchedUpdateTaken) {
  ServiceLimits limits;
  limits.inline_evaluation = false;
  Server server = start(kDomainBatchShutdown, "batch_shutdown", limits, /*workers=*/1);
  ASSERT_TRUE(server.bridge);
  const TestScene scene =
      create_scene(*server.scenes, {arm(), polytope(random_hull_vertices(6, 30, 0.6))});
  ASSERT_FALSE(scene.scene_id.empty());
  auto client = connect(kDomainBatchShutdown, server.prefix, /*batched=*/true);
  ASSERT_TRUE(client);
  testkit::HeldWorkers held(*server.scenes, scene.scene_id);
  ASSERT_TRUE(held.held());

  constexpr std::uint64_t kUpdates = 6;  // within --max-in-flight (8): none merged
  BatchMessage batch;
  for (std::uint64_t s = 1; s <= kUpdates; ++s) batch.updates.push_back(path_update(scene, s));
  std::string error;
  ASSERT_TRUE(client->publish_batch(batch.sample(), error)) << error;
  wait_taken(*server.bridge, kUpdates);
  ASSERT_EQ(server.bridge->stats().updates_taken, kUpdates);
  std::thread stopping([&] { server.bridge->shutdown(); });
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // let the shutdown begin
  held.release();
  stopping.join();
  const std::vector<ReceivedReport> reports = collect_reports(*client, kUpdates);
  ASSERT_EQ(reports.size(), kUpdates);
  for (std::uint64_t k = 0; k < kUpdates; ++k) {
    EXPECT_EQ(reports[k].sequence, k + 1);
    EXPECT_EQ(reports[k].status, 0u) << reports[k].message;
    EXPECT_EQ(reports[k].coalesced_updates, 0u);
  }
  EXPECT_EQ(server.bridge->stats().reports_written, kUpdates);
}

// Without CYCLONEDDS_URI, Cyclone would use the external interface and multicast: both ends
// refuse to start, saying why.
TEST(DdsBridge, RefusesToStartWithoutAConfiguration) {
  const char* saved = std::getenv("CYCLONEDDS_URI");
  ASSERT_NE(saved, nullptr) << "ctest sets CYCLONEDDS_URI for every DDS test";
  const std::string uri = saved;
  unsetenv("CYCLONEDDS_URI");
  SceneService scenes(ServiceLimits{}, 1);
  DdsConfig config;
  config.domain_id = kDomainNoConfiguration;
  auto started = DdsBridge::start(scenes, config);
  cli::DdsPoseClient::Config client_config;
  client_config.domain_id = kDomainNoConfiguration;
  std::string error;
  auto client = cli::DdsPoseClient::create(client_config, error);
  setenv("CYCLONEDDS_URI", uri.c_str(), 1);
  ASSERT_FALSE(started.ok());
  EXPECT_EQ(started.error().field, "CYCLONEDDS_URI");
  EXPECT_NE(started.error().message.find("cyclonedds-loopback.xml"), std::string::npos);
  EXPECT_EQ(client, nullptr);
  EXPECT_NE(error.find("CYCLONEDDS_URI is not set"), std::string::npos) << error;
}

}  // namespace
}  // namespace nearpoint::dds_testing
