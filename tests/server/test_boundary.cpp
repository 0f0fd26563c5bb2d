// SPDX-License-Identifier: Apache-2.0
// The service's boundary against requests within every limit that could still not be answered:
// reports larger than the server can send, and ids too long to echo. A real in-process server
// on 127.0.0.1:0 and the generated gRPC client (issue 21, items 3 and 4).
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <sstream>
#include <string>
#include <tuple>

#include "nearpoint/server/log.hpp"
#include "report_size.hpp"
#include "scene_fixture.hpp"

namespace nearpoint::server::testing {
namespace {

/// The issue's shape: 447 objects select 99 681 pairs, just under --max-pairs-per-scene.
constexpr int kObjects = 447;
constexpr int kPairs = kObjects * (kObjects - 1) / 2;

/// An id of exactly `length` bytes, unique per `index`.
std::string padded_id(int index, std::size_t length) {
  std::string id = "o" + std::to_string(index) + "-";
  id.resize(length, 'x');
  return id;
}

/// `kObjects` unit spheres on a grid (all separated), ids of `id_length` bytes, all pairs.
v1::CreateSceneRequest sphere_grid(const std::string& geometry_id, std::size_t id_length) {
  v1::CreateSceneRequest request;
  for (int i = 0; i < kObjects; ++i) {
    v1::SceneObject& object = *request.add_objects();
    object.set_id(padded_id(i, id_length));
    object.set_geometry_id(geometry_id);
    v1::Vector3& t = *object.mutable_pose()->mutable_translation();
    t.set_x(3.0 * (i % 20));
    t.set_y(3.0 * (i / 20));
  }
  return request;
}

std::string register_sphere(v1::DistanceService::Stub& stub) {
  v1::RegisterGeometryRequest request;
  v1::Piece& piece = *request.mutable_geometry()->add_pieces();
  piece.mutable_point();
  piece.set_radius(1.0);
  v1::RegisterGeometryResponse response;
  const grpc::Status status = stub.RegisterGeometry(make_context().get(), request, &response);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return response.geometry().geometry_id();
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// ---- item 3: reports larger than a message ----

// Guards the creation-time bound on a scene's report size (SceneService::create_scene with
// ServiceLimits::max_report_bytes = --max-message-bytes): 447 objects with 120-byte ids are
// within every count limit, but each report would take ~30 MB, more than the 16 MiB the server
// sends. The scene used to be accepted and then every Query failed with "Sent message larger
// than max" and every stream update went unanswered; now CreateScene refuses it, naming the
// limit, the bound and what would fit. The same pairs with short ids fit and are answered whole.
TEST(ReportLimits, SceneWhoseReportsCannotBeSentIsRefusedAtCreation) {
  RunningServer running = start_server();  // the default --max-message-bytes, 16 MiB
  ASSERT_TRUE(running.server);
  v1::DistanceService::Stub& stub = *running.stub;
  const std::string sphere = register_sphere(stub);

  v1::CreateSceneResponse created;
  const grpc::Status refused =
      stub.CreateScene(make_context().get(), sphere_grid(sphere, 120), &created);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  const std::string& message = refused.error_message();
  EXPECT_TRUE(contains(message, "--max-message-bytes")) << message;
  EXPECT_TRUE(contains(message, std::to_string(16u << 20) + " bytes")) << message;
  EXPECT_TRUE(contains(message, std::to_string(kPairs) + " pairs")) << message;
  EXPECT_TRUE(contains(message, "object ids up to 120 bytes")) << message;
  EXPECT_TRUE(contains(message, "fewer pairs")) << message;

  // 8-byte ids: the same 99 681 pairs fit, and a Query is answered with every pair.
  ASSERT_TRUE(stub.CreateScene(make_context().get(), sphere_grid(sphere, 8), &created).ok());
  EXPECT_EQ(created.pair_count(), std::uint32_t(kPairs));
  v1::QueryRequest query;
  query.set_scene_id(created.scene_id());
  v1::DistanceReport report;
  const grpc::Status answered = stub.Query(make_context().get(), query, &report);
  ASSERT_TRUE(answered.ok()) << answered.error_message();
  EXPECT_EQ(report.pairs_size(), kPairs);
}

// Issue 22 item 6: reports bounded by the mode, not the scene. The scene whose all-pairs report
// cannot be sent (120-byte ids, ~30 MB) is refused in that mode with a message that names the
// limit and the modes that would fit; asked for with one of them as its default (the global
// minimum, one pair), the same scene is accepted and answered, a request asking for all pairs
// on it is refused naming the mode, and within-cutoff with a finite cutoff (what is near: here
// nothing within 0.5 m) is answered too. The refusal used to name no mode: the client could only
// shrink the scene.
TEST(ReportLimits, ASceneTooLargeForAllPairsIsAcceptedInAModeThatFits) {
  RunningServer running = start_server();
  ASSERT_TRUE(running.server);
  v1::DistanceService::Stub& stub = *running.stub;
  const std::string sphere = register_sphere(stub);
  v1::CreateSceneRequest request = sphere_grid(sphere, 120);
  v1::CreateSceneResponse created;
  const grpc::Status refused = stub.CreateScene(make_context().get(), request, &created);
  ASSERT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  const std::string& message = refused.error_message();
  EXPECT_TRUE(contains(message, "in REPORT_MODE_ALL_PAIRS")) << message;
  EXPECT_TRUE(contains(message, "--max-message-bytes")) << message;
  EXPECT_TRUE(contains(message, "Report modes that fit: REPORT_MODE_NEAREST_PER_OBJECT"))
      << message;
  EXPECT_TRUE(contains(message, "REPORT_MODE_GLOBAL_MINIMUM")) << message;
  EXPECT_TRUE(contains(
      message, "REPORT_MODE_WITHIN_CUTOFF (--mode within-cutoff) with a finite distance_cutoff"))
      << message;
  // CHANGED's first report holds every pair: refused the same way.
  request.mutable_default_options()->set_report_mode(v1::REPORT_MODE_CHANGED);
  EXPECT_EQ(stub.CreateScene(make_context().get(), request, &created).error_code(),
            grpc::StatusCode::RESOURCE_EXHAUSTED);

  request.mutable_default_options()->set_report_mode(v1::REPORT_MODE_GLOBAL_MINIMUM);
  const grpc::Status accepted = stub.CreateScene(make_context().get(), request, &created);
  ASSERT_TRUE(accepted.ok()) << accepted.error_message();
  v1::QueryRequest query;
  query.set_scene_id(created.scene_id());
  v1::DistanceReport report;
  ASSERT_TRUE(stub.Query(make_context().get(), query, &report).ok());
  EXPECT_EQ(report.report_mode(), v1::REPORT_MODE_GLOBAL_MINIMUM);
  EXPECT_EQ(report.pairs_size(), 1);
  EXPECT_DOUBLE_EQ(report.pairs(0).distance(), 1.0);  // neighbours 3 m apart, radius 1

  query.mutable_options()->set_report_mode(v1::REPORT_MODE_ALL_PAIRS);
  const grpc::Status all = stub.Query(make_context().get(), query, &report);
  EXPECT_EQ(all.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_TRUE(contains(all.error_message(), "options: ")) << all.error_message();
  EXPECT_TRUE(contains(all.error_message(), "in REPORT_MODE_ALL_PAIRS")) << all.error_message();
  EXPECT_TRUE(contains(all.error_message(), "REPORT_MODE_NEAREST_PER_OBJECT"))
      << all.error_message();

  query.mutable_options()->set_report_mode(v1::REPORT_MODE_WITHIN_CUTOFF);
  query.mutable_options()->set_distance_cutoff(0.5);
  const grpc::Status near = stub.Query(make_context().get(), query, &report);
  ASSERT_TRUE(near.ok()) << near.error_message();
  EXPECT_EQ(report.pairs_size(), 0);
  EXPECT_EQ(report.counts().pairs_pruned() + report.counts().pairs_evaluated(),
            std::uint32_t(kPairs));
}

// Guards the per-request check (SceneService::query, PoseStream::prepare): a scene that fits
// with its default options would not with near points on (40-byte ids: ~14 MB without, ~21 MB
// with). A Query asking for them is refused naming the options and the limit (it used to fail
// with "Sent message larger than max"), and a stream update asking for them gets an error
// report with its sequence number (it used to get no report at all) while the stream goes on.
TEST(ReportLimits, RequestsAskingForMoreThanFitsAreAnsweredWithAnError) {
  RunningServer running = start_server();
  ASSERT_TRUE(running.server);
  v1::DistanceService::Stub& stub = *running.stub;
  const std::string sphere = register_sphere(stub);
  v1::CreateSceneResponse created;
  ASSERT_TRUE(stub.CreateScene(make_context().get(), sphere_grid(sphere, 40), &created).ok());

  v1::QueryRequest query;
  query.set_scene_id(created.scene_id());
  query.mutable_options()->set_near_points(true);
  v1::DistanceReport report;
  const grpc::Status refused = stub.Query(make_context().get(), query, &report);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_TRUE(contains(refused.error_message(), "options: ")) << refused.error_message();
  EXPECT_TRUE(contains(refused.error_message(), "with near points")) << refused.error_message();
  EXPECT_TRUE(contains(refused.error_message(), "--max-message-bytes")) << refused.error_message();

  StreamClient stream(stub, std::chrono::seconds(60));
  v1::PoseUpdate update;
  update.set_scene_id(created.scene_id());
  update.set_sequence(7);
  update.mutable_options()->set_near_points(true);
  ASSERT_TRUE(stream.write(update));
  update.set_sequence(8);
  update.clear_options();
  ASSERT_TRUE(stream.write(update));
  v1::DistanceReport first, second;
  ASSERT_TRUE(stream.read(first)) << "the update asking for near points got no report";
  EXPECT_EQ(first.sequence(), 7u);
  ASSERT_TRUE(first.has_error());
  EXPECT_EQ(first.error().code(), v1::ERROR_CODE_RESOURCE_EXHAUSTED);
  EXPECT_EQ(first.error().field(), "options");
  EXPECT_TRUE(contains(first.error().message(), "--max-message-bytes")) << first.error().message();
  ASSERT_TRUE(stream.read(second));
  EXPECT_EQ(second.sequence(), 8u);
  EXPECT_FALSE(second.has_error()) << second.error().message();
  EXPECT_EQ(second.pairs_size(), kPairs);
  EXPECT_TRUE(stream.finish().ok());
}

// Guards the send-time backstop in the gRPC service (check_report_fits): when a report turns out
// larger than the server's send limit anyway — here a SceneService configured with a larger
// report limit than the gRPC server's message limit — the update is answered with an error
// report carrying its sequence number instead of nothing (the stream used to end CANCELLED
// with the update unanswered), the stream goes on, and a Query gets RESOURCE_EXHAUSTED with a
// message naming the limit.
TEST(ReportLimits, AReportTooLargeToSendIsReplacedByAnErrorReport) {
  // The scene service keeps its default report limit (16 MiB); the gRPC server sends 1 MiB.
  auto scenes = std::make_shared<SceneService>(ServiceLimits{}, 2);
  ServerConfig config = test_config();
  config.max_message_bytes = 1u << 20;
  auto started = GrpcServer::start(config, scenes);
  ASSERT_TRUE(started) << started.error().describe();
  const std::string address = "127.0.0.1:" + std::to_string(started.value()->port());
  grpc::ChannelArguments arguments;
  arguments.SetMaxReceiveMessageSize(64 << 20);
  auto channel = grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), arguments);
  auto stub = v1::DistanceService::NewStub(channel);

  // 100 objects with 100-byte ids: 4950 pairs, ~1.1 MB per report.
  const std::string sphere = register_sphere(*stub);
  v1::CreateSceneRequest request;
  for (int i = 0; i < 100; ++i) {
    v1::SceneObject& object = *request.add_objects();
    object.set_id(padded_id(i, 100));
    object.set_geometry_id(sphere);
    object.mutable_pose()->mutable_translation()->set_x(3.0 * i);
  }
  v1::CreateSceneResponse created;
  ASSERT_TRUE(stub->CreateScene(make_context().get(), request, &created).ok());

  // On StreamPoses, and on StreamPoseBatches with both updates in one message.
  for (const std::size_t batch : {0u, 2u}) {
    StreamClient stream(*stub, kCallDeadline, batch);
    for (std::uint64_t sequence : {11u, 12u}) {
      v1::PoseUpdate update;
      update.set_scene_id(created.scene_id());
      update.set_sequence(sequence);
      ASSERT_TRUE(stream.write(update));
    }
    for (std::uint64_t sequence : {11u, 12u}) {
      v1::DistanceReport report;
      ASSERT_TRUE(stream.read(report)) << "update " << sequence << " got no report";
      EXPECT_EQ(report.sequence(), sequence);
      ASSERT_TRUE(report.has_error());
      EXPECT_EQ(report.error().code(), v1::ERROR_CODE_RESOURCE_EXHAUSTED);
      EXPECT_TRUE(contains(report.error().message(), "--max-message-bytes"))
          << report.error().message();
    }
    EXPECT_TRUE(stream.finish().ok());
  }

  v1::QueryRequest query;
  query.set_scene_id(created.scene_id());
  v1::DistanceReport report;
  const grpc::Status refused = stub->Query(make_context().get(), query, &report);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_TRUE(contains(refused.error_message(), "--max-message-bytes")) << refused.error_message();
}

// Guards report_size.hpp against the proto: on a report whose every field holds its longest
// value, protobuf's own size stays within the bound, and within a few bytes per pair of it (a
// bound that loose would refuse scenes that fit). If a field is added to PairDistance or
// DistanceReport the field counts fail first: the bound must learn the new field.
TEST(ReportLimits, TheReportSizeBoundHoldsForWorstCaseReports) {
  namespace size = report_size;
  EXPECT_EQ(v1::PairDistance::descriptor()->field_count(), 35);
  EXPECT_EQ(v1::DistanceReport::descriptor()->field_count(), 10);
  EXPECT_EQ(v1::JointDerivative::descriptor()->field_count(), 3);
  EXPECT_EQ(v1::JointLimitViolation::descriptor()->field_count(), 4);
  EXPECT_EQ(v1::ThresholdEvent::descriptor()->field_count(), 7);
  EXPECT_EQ(v1::ReportTiming::descriptor()->field_count(), 4);
  EXPECT_EQ(v1::ReportCounts::descriptor()->field_count(), 3);

  auto fill = [](v1::Vector3& v) {
    v.set_x(-1.5e300);
    v.set_y(2.5e-300);
    v.set_z(3.25);
  };
  for (const auto& [near_points, penetration, gradient, depth] :
       {std::tuple{false, false, false, false}, std::tuple{true, false, false, false},
        std::tuple{true, true, true, false}, std::tuple{false, true, true, false},
        std::tuple{false, false, false, true}, std::tuple{true, true, true, true}}) {
    for (const std::size_t id_length : {std::size_t(1), std::size_t(127), std::size_t(128)}) {
      constexpr int kPairCount = 50;
      v1::DistanceReport report;
      report.set_sequence(~std::uint64_t(0));
      report.set_coalesced_updates(~std::uint32_t(0));
      report.set_coalesced_from_sequence(~std::uint64_t(0));
      report.mutable_counts()->set_pairs_evaluated(~0u);
      report.mutable_counts()->set_pairs_pruned(~0u);
      report.mutable_counts()->set_pairs_unmoved(~0u);
      report.set_report_mode(
          v1::ReportMode(v1::ReportMode_descriptor()
                             ->value(v1::ReportMode_descriptor()->value_count() - 1)
                             ->number()));
      v1::ReportTiming& timing = *report.mutable_timing();
      timing.set_server_us(1.5), timing.set_queue_us(1.5), timing.set_evaluation_us(1.5);
      timing.set_geometry_us(1.5);
      std::size_t bound = size::kReportEnvelope;
      // Events: one per pair, the threshold's name up to a name's 256 bytes.
      for (int i = 0; i < kPairCount; ++i) {
        const std::size_t name_length = std::size_t(i % 2 ? 256 : 1);
        v1::ThresholdEvent& event = *report.add_events();
        event.set_threshold(std::string(name_length, 'n'));
        event.set_threshold_index(~0u);
        event.set_object_a(std::string(id_length, 'a'));
        event.set_object_b(std::string(id_length, 'b'));
        event.set_crossing(v1::THRESHOLD_CROSSING_EXIT);
        event.set_distance(1.5);
        event.set_sequence(~std::uint64_t(0));
        bound += size::event_entry(name_length, id_length, id_length);
      }
      for (int i = 0; i < kPairCount; ++i) {
        v1::PairDistance& pair = *report.add_pairs();
        pair.set_object_a(std::string(id_length, 'a'));
        pair.set_object_b(std::string(id_length, 'b'));
        pair.set_status(v1::PAIR_STATUS_ENGINE_ERROR);
        pair.set_distance(1.5), pair.set_distance_lower_bound(1.5), pair.set_error_bound(1.5);
        pair.set_iterations(~0u), pair.set_piece_pairs_evaluated(~0u);
        pair.set_piece_a(~0u), pair.set_piece_b(~0u);
        pair.set_warm_started(true);
        if (near_points) {
          pair.set_has_near_points(true);
          fill(*pair.mutable_point_a()), fill(*pair.mutable_point_b());
          fill(*pair.mutable_normal());
        }
        if (penetration) {
          pair.set_has_penetration_bound(true);
          pair.set_penetration_bound(1.5);
        }
        if (gradient) {
          pair.set_has_gradient(true);
          for (v1::PoseGradient* g : {pair.mutable_gradient_a(), pair.mutable_gradient_b()})
            fill(*g->mutable_translation()), fill(*g->mutable_rotation());
        }
        if (depth) {
          pair.set_has_signed_distance(true);
          pair.set_signed_distance(-1.5), pair.set_signed_distance_lower(-1.5);
          pair.set_signed_distance_upper(-1.5);
          pair.set_has_penetration_depth(true);
          pair.set_penetration_depth(1.5), pair.set_penetration_depth_lower(1.5);
          pair.set_penetration_depth_upper(1.5);
          fill(*pair.mutable_depth_point_a()), fill(*pair.mutable_depth_point_b());
          fill(*pair.mutable_depth_direction());
          pair.set_depth_termination(
              v1::DepthTermination(v1::DepthTermination_descriptor()
                                       ->value(v1::DepthTermination_descriptor()->value_count() - 1)
                                       ->number()));
          pair.set_depth_iterations(~0u);
        }
        bound += size::kPairEntryOverhead + size::kPairFixed +
                 size::pair_ids(id_length, id_length) +
                 size::pair_options(near_points, penetration, gradient, depth);
      }
      const std::size_t actual = report.ByteSizeLong();
      SCOPED_TRACE(::testing::Message() << "near points " << near_points << ", penetration "
                                        << penetration << ", gradient " << gradient << ", depth "
                                        << depth << ", ids " << id_length << " bytes");
      EXPECT_LE(actual, bound);
      EXPECT_LE(bound - actual, std::size_t(kPairCount) * 1 + 4);
    }
  }
  // Robot scenes: a joint gradient entry and a limit violation, names of 1 and 128 bytes.
  for (const std::size_t name_length : {std::size_t(1), std::size_t(128)}) {
    v1::PairDistance pair;
    v1::JointDerivative& d = *pair.add_joint_gradient();
    d.set_joint(std::string(name_length, 'j'));
    d.set_coordinate(~0u);
    d.set_value(1.5);
    EXPECT_LE(pair.ByteSizeLong(), size::joint_derivative_entry(name_length));
    v1::DistanceReport report;
    v1::JointLimitViolation& v = *report.add_joint_limit_violations();
    v.set_joint(std::string(name_length, 'j'));
    v.set_position(1.5), v.set_lower(1.5), v.set_upper(1.5);
    EXPECT_LE(report.ByteSizeLong(), size::joint_limit_entry(name_length));
  }
}

// ---- item 4: ids echoed without bound ----

// Guards the id rule (check_id at validation) and the short quoting of ids in messages
// (`quoted`) and logs: an 8 kB and a 10 MB unknown scene id used to be copied whole into the
// status message — the first made the client fail with "received initial metadata size exceeds
// limit" instead of an answer, the second wrote a 10 MB log line. Now both get INVALID_ARGUMENT
// with a message of a few hundred bytes quoting a 64-byte prefix and the length, every log line
// stays short, and the next call on the same channel works. A well-formed unknown id still
// gets NOT_FOUND, quoted whole.
TEST(IdLimits, LongUnknownIdsGetAShortErrorAndTheChannelKeepsWorking) {
  RunningServer running = start_server();
  ASSERT_TRUE(running.server);
  v1::DistanceService::Stub& stub = *running.stub;
  const std::string sphere = register_sphere(stub);
  v1::CreateSceneRequest create;
  for (const char* id : {"a", "b"}) {
    v1::SceneObject& object = *create.add_objects();
    object.set_id(id);
    object.set_geometry_id(sphere);
    object.mutable_pose()->mutable_translation()->set_x(id[0] == 'a' ? 0 : 5);
  }
  v1::CreateSceneResponse created;
  ASSERT_TRUE(stub.CreateScene(make_context().get(), create, &created).ok());

  ::testing::internal::CaptureStderr();  // the server's log lines (fd 2)
  for (const std::size_t length : {std::size_t(8192), std::size_t(10u << 20)}) {
    SCOPED_TRACE(length);
    const std::string id(length, 's');
    v1::QueryRequest query;
    query.set_scene_id(id);
    v1::DistanceReport report;
    const grpc::Status status = stub.Query(make_context().get(), query, &report);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_LT(status.error_message().size(), 300u) << status.error_message().substr(0, 300);
    EXPECT_TRUE(contains(status.error_message(), "(" + std::to_string(length) + " bytes)"))
        << status.error_message().substr(0, 300);

    v1::DeleteSceneRequest remove;
    remove.set_scene_id(id);
    v1::DeleteSceneResponse removed;
    const grpc::Status deleted = stub.DeleteScene(make_context().get(), remove, &removed);
    EXPECT_EQ(deleted.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_LT(deleted.error_message().size(), 300u);

    StreamClient stream(stub);
    v1::PoseUpdate update;
    update.set_scene_id(id);
    update.set_sequence(1);
    ASSERT_TRUE(stream.write(update));
    ASSERT_TRUE(stream.read(report));
    EXPECT_EQ(report.sequence(), 1u);
    EXPECT_EQ(report.error().code(), v1::ERROR_CODE_INVALID_ARGUMENT);
    EXPECT_LT(report.error().message().size(), 300u);
    EXPECT_TRUE(stream.finish().ok());

    // An object id of the same length in a pose: the same rule.
    query.set_scene_id(created.scene_id());
    query.add_poses()->set_object_id(id);
    const grpc::Status object = stub.Query(make_context().get(), query, &report);
    EXPECT_EQ(object.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_EQ(object.error_message().rfind("poses[0].object_id: ", 0), 0u);
    EXPECT_LT(object.error_message().size(), 300u);

    // The next call on the same channel works.
    v1::QueryRequest valid;
    valid.set_scene_id(created.scene_id());
    const grpc::Status answered = stub.Query(make_context().get(), valid, &report);
    ASSERT_TRUE(answered.ok()) << answered.error_message();
    EXPECT_EQ(report.pairs_size(), 1);
  }
  const std::string log = ::testing::internal::GetCapturedStderr();
  EXPECT_TRUE(contains(log, "event=request_rejected")) << log.substr(0, 2000);
  std::istringstream lines(log);
  std::size_t longest = 0;
  for (std::string line; std::getline(lines, line);) longest = std::max(longest, line.size());
  EXPECT_LT(longest, 1000u);
  EXPECT_LT(log.size(), 20'000u);

  v1::QueryRequest unknown;
  unknown.set_scene_id("no-such-scene");
  v1::DistanceReport report;
  const grpc::Status status = stub.Query(make_context().get(), unknown, &report);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(status.error_message(), "scene_id: no scene 'no-such-scene'");
}

// Guards the character sets (check_id, check_name): ids are printable ASCII without spaces and
// names UTF-8 text without control characters, on every kind of id and name, so that nothing a
// client names can break a log line, a message or a report; the error names the field.
TEST(IdLimits, IdsAndNamesOutsideTheirCharacterSetsAreRejectedNamingTheField) {
  RunningServer running = start_server();
  ASSERT_TRUE(running.server);
  v1::DistanceService::Stub& stub = *running.stub;
  const std::string sphere = register_sphere(stub);

  v1::RegisterGeometryRequest geometry;
  geometry.mutable_geometry()->add_pieces()->mutable_point();
  geometry.mutable_geometry()->set_name("arm\n level=error event=forged");
  v1::RegisterGeometryResponse registered;
  grpc::Status status = stub.RegisterGeometry(make_context().get(), geometry, &registered);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message().rfind("geometry.name: ", 0), 0u) << status.error_message();
  geometry.mutable_geometry()->set_name("Greifer \xC3\x84 links");  // UTF-8 text is a fine name
  EXPECT_TRUE(stub.RegisterGeometry(make_context().get(), geometry, &registered).ok());

  v1::RemoveGeometryRequest remove;
  remove.set_geometry_id(std::string(200, 'g'));
  v1::RemoveGeometryResponse removed;
  status = stub.RemoveGeometry(make_context().get(), remove, &removed);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message().rfind("geometry_id: ", 0), 0u) << status.error_message();

  struct Case {
    const char* what;
    std::function<void(v1::CreateSceneRequest&)> mutate;
    const char* field;
  };
  const std::vector<Case> cases = {
      {"object id with a space", [](auto& r) { r.mutable_objects(0)->set_id("left arm"); },
       "objects[0].id: "},
      {"object id with a newline", [](auto& r) { r.mutable_objects(1)->set_id("b\nc"); },
       "objects[1].id: "},
      {"object id of 129 bytes",
       [](auto& r) { r.mutable_objects(1)->set_id(std::string(129, 'o')); }, "objects[1].id: "},
      {"geometry id of 10 kB",
       [](auto& r) { r.mutable_objects(0)->set_geometry_id(std::string(10000, 'g')); },
       "objects[0].geometry_id: "},
      {"scene id with a tab", [](auto& r) { r.set_scene_id("cell\t1"); }, "scene_id: "},
      {"scene name with an escape", [](auto& r) { r.set_name("cell \x1b[2J"); }, "name: "},
      {"scene name of 257 bytes", [](auto& r) { r.set_name(std::string(257, 'n')); }, "name: "},
      {"listed pair naming a 1 MB id",
       [](auto& r) {
         v1::ObjectPair& pair = *r.mutable_pair_selection()->mutable_listed_pairs()->add_pairs();
         pair.set_object_a("a");
         pair.set_object_b(std::string(1u << 20, 'b'));
       },
       "pair_selection.listed_pairs.pairs[0].object_b: "},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    v1::CreateSceneRequest create;
    for (const char* id : {"a", "b"}) {
      v1::SceneObject& object = *create.add_objects();
      object.set_id(id);
      object.set_geometry_id(sphere);
    }
    c.mutate(create);
    v1::CreateSceneResponse created;
    status = stub.CreateScene(make_context().get(), create, &created);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_EQ(status.error_message().rfind(c.field, 0), 0u) << status.error_message();
    EXPECT_LT(status.error_message().size(), 400u);
    EXPECT_EQ(status.error_message().find('\n'), std::string::npos);
  }
}

// Guards the log's own backstop (LogLine::kv): whatever a caller passes, a value is cut at 1 kB
// with its length, and control characters are escaped, so that one line stays one bounded write
// that no value can split or forge (a carriage return, a terminal escape, a newline).
TEST(IdLimits, LogValuesAreCappedAndControlCharactersEscaped) {
  ::testing::internal::CaptureStderr();
  log_warn("test_event").kv("huge", std::string(10u << 20, 'v')).kv("sly", "a\rb\x1b[2Jc\nd");
  const std::string log = ::testing::internal::GetCapturedStderr();
  EXPECT_LT(log.size(), 1300u);
  EXPECT_EQ(std::count(log.begin(), log.end(), '\n'), 1) << log;
  EXPECT_TRUE(contains(log, "(" + std::to_string(10u << 20) + " bytes)\"")) << log;
  EXPECT_TRUE(contains(log, R"(sly="a\x0db\x1b[2Jc\nd")")) << log;
}

}  // namespace
}  // namespace nearpoint::server::testing
