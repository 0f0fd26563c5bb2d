// SPDX-License-Identifier: Apache-2.0
// PENETRATION_MODE_DEPTH and PAIR_STATUS_TOUCHING on the wire (issue 31, item 5): a real
// nearpointd child process on 127.0.0.1:0, spoken to over gRPC with the generated stubs, answers
// overlapping spheres and boxes whose depths are known in closed form; negative thresholds fire
// in depth mode and are refused without it; the engine's touching verdict reaches the wire as
// its own status.
//
// The analytic cases are chosen in dyadic numbers (0.5, 0.25, 0.625 …), so that the depth the
// test expects is exact in double: "the reported interval contains it" is then a statement about
// the server, not about the test's rounding.
#include <cmath>
#include <filesystem>
#include <fstream>

#include "common/child_process.hpp"
#include "evaluation.hpp"
#include "nearpoint/proto/convert.hpp"
#include "scene_fixture.hpp"

namespace nearpoint::server::testing {
namespace {

using ::nearpoint::testkit::ChildProcess;

/// A nearpointd child process on 127.0.0.1:0 and a stub on it.
struct Daemon {
  std::unique_ptr<ChildProcess> process;
  std::shared_ptr<grpc::Channel> channel;
  std::unique_ptr<v1::DistanceService::Stub> stub;
};

Daemon start_daemon() {
  Daemon out;
  const std::string port_file = (std::filesystem::temp_directory_path() /
                                 ("nearpointd-depth.port." + std::to_string(getpid()) + "." +
                                  ::testing::UnitTest::GetInstance()->current_test_info()->name()))
                                    .string();
  std::filesystem::remove(port_file);
  out.process = std::make_unique<ChildProcess>(std::vector<std::string>{
      NEARPOINTD_PATH, "--listen", "127.0.0.1:0", "--port-file", port_file, "--workers", "2"});
  EXPECT_TRUE(out.process->started());
  EXPECT_FALSE(out.process->wait_for_stderr("event=listening", std::chrono::seconds(20)).empty())
      << out.process->stderr_text();
  int port = 0;
  std::ifstream(port_file) >> port;
  std::filesystem::remove(port_file);
  EXPECT_GT(port, 0);
  out.channel =
      grpc::CreateChannel("127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials());
  out.stub = v1::DistanceService::NewStub(out.channel);
  return out;
}

v1::Geometry sphere_geometry(double radius) {
  v1::Geometry g;
  g.set_name("sphere");
  v1::Piece& piece = *g.add_pieces();
  piece.mutable_point();
  piece.set_radius(radius);
  return g;
}

v1::Geometry box_geometry(const Vec3<double>& half, bool as_polytope) {
  v1::Geometry g;
  g.set_name(as_polytope ? "box polytope" : "box");
  v1::Piece& piece = *g.add_pieces();
  if (as_polytope) {
    for (const Vec3<double>& v : box_vertices(half))
      set_vec(v, *piece.mutable_polytope()->add_vertices());
  } else {
    set_vec(half, *piece.mutable_box()->mutable_half_extents());
  }
  return g;
}

void add_object(v1::CreateSceneRequest& request, const std::string& id, const std::string& geometry,
                const Vec3<double>& at) {
  v1::SceneObject& object = *request.add_objects();
  object.set_id(id);
  object.set_geometry_id(geometry);
  set_vec(at, *object.mutable_pose()->mutable_translation());
}

void add_pair(v1::CreateSceneRequest& request, const std::string& a, const std::string& b) {
  v1::ObjectPair& pair = *request.mutable_pair_selection()->mutable_listed_pairs()->add_pairs();
  pair.set_object_a(a);
  pair.set_object_b(b);
}

/// One analytic case: objects a and b, their depth and the unit direction A → B.
struct Expected {
  std::string a, b;
  double depth;
  Vec3<double> direction;
  /// Where each object's deepest point in the other lies, when the witnesses are unique.
  Vec3<double> point_a, point_b;
};

/// The scene: three overlapping pairs in depth mode, far apart from one another.
/// - spheres r 0.5 and 0.25, centres 0.625 apart: depth r1 + r2 − d = 0.125 along +x;
/// - axis-aligned boxes (polytopes) of half extents 0.5 and 0.25, centres (10, 0, 0) and
///   (10.625, 0.125, 0.0625): the faces overlap by 0.125 along x, 0.625 along y, 0.6875 along
///   z, so the depth is 0.125 along +x;
/// - a sphere r 0.5 at (20, 0, 0) and a box (primitive) of half extent 0.5 at (20.875, 0, 0):
///   the sphere's centre is 0.375 outside the box's face, depth 0.5 − 0.375 = 0.125 along +x.
std::vector<Expected> analytic_pairs() {
  return {
      {"s1", "s2", 0.125, {1, 0, 0}, {0.5, 0, 0}, {0.375, 0, 0}},
      {"b1", "b2", 0.125, {1, 0, 0}, {10.5, 0, 0}, {10.375, 0, 0}},  // y, z: faces, not unique
      {"s3", "b3", 0.125, {1, 0, 0}, {20.5, 0, 0}, {20.375, 0, 0}},
  };
}

v1::CreateSceneRequest analytic_scene(v1::DistanceService::Stub& stub, bool depth_default) {
  auto store = [&](const v1::Geometry& geometry) {
    v1::RegisterGeometryRequest request;
    *request.mutable_geometry() = geometry;
    v1::RegisterGeometryResponse response;
    const grpc::Status status = stub.RegisterGeometry(make_context().get(), request, &response);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return response.geometry().geometry_id();
  };
  const std::string big_sphere = store(sphere_geometry(0.5));
  const std::string small_sphere = store(sphere_geometry(0.25));
  const std::string big_box = store(box_geometry({0.5, 0.5, 0.5}, true));
  const std::string small_box = store(box_geometry({0.25, 0.25, 0.25}, true));
  const std::string box = store(box_geometry({0.5, 0.5, 0.5}, false));
  v1::CreateSceneRequest request;
  request.set_name("depth");
  add_object(request, "s1", big_sphere, {0, 0, 0});
  add_object(request, "s2", small_sphere, {0.625, 0, 0});
  add_object(request, "b1", big_box, {10, 0, 0});
  add_object(request, "b2", small_box, {10.625, 0.125, 0.0625});
  add_object(request, "s3", big_sphere, {20, 0, 0});
  add_object(request, "b3", box, {20.875, 0, 0});
  // Face to face, exactly touching: box half 0.5 at (30, 0, 0), box half 0.25 at (30.75, 0, 0).
  add_object(request, "t1", big_box, {30, 0, 0});
  add_object(request, "t2", small_box, {30.75, 0, 0});
  add_pair(request, "s1", "s2");
  add_pair(request, "b1", "b2");
  add_pair(request, "s3", "b3");
  add_pair(request, "t1", "t2");
  add_pair(request, "s1", "b1");  // 9 apart: separated
  if (depth_default) request.mutable_default_options()->set_penetration(v1::PENETRATION_MODE_DEPTH);
  return request;
}

const v1::PairDistance* find_pair(const v1::DistanceReport& report, const std::string& a,
                                  const std::string& b) {
  for (const v1::PairDistance& pair : report.pairs())
    if (pair.object_a() == a && pair.object_b() == b) return &pair;
  return nullptr;
}

Vec3<double> vec(const v1::Vector3& v) {
  return {v.x(), v.y(), v.z()};
}

void expect_analytic(const v1::DistanceReport& report) {
  for (const Expected& want : analytic_pairs()) {
    SCOPED_TRACE(want.a + "-" + want.b);
    const v1::PairDistance* pair = find_pair(report, want.a, want.b);
    ASSERT_NE(pair, nullptr);
    // A depth of 0.125 on shapes of size ~1 is far beyond any bound: the overlap is proven.
    EXPECT_EQ(pair->status(), v1::PAIR_STATUS_INTERSECTING) << pair->DebugString();
    EXPECT_EQ(pair->distance(), 0.0);
    ASSERT_TRUE(pair->has_penetration_depth()) << pair->DebugString();
    ASSERT_TRUE(pair->has_signed_distance());
    // The certified interval contains the exact depth, and the estimate lies in it.
    EXPECT_LE(pair->penetration_depth_lower(), want.depth);
    EXPECT_GE(pair->penetration_depth_upper(), want.depth);
    EXPECT_LE(pair->penetration_depth_lower(), pair->penetration_depth());
    EXPECT_LE(pair->penetration_depth(), pair->penetration_depth_upper());
    // Tight: these are polytopes and spheres, converged to what double allows.
    EXPECT_LT(pair->penetration_depth_upper() - pair->penetration_depth_lower(), 1e-9);
    EXPECT_NEAR(pair->penetration_depth(), want.depth, 1e-9);
    // The signed distance is −depth, with the mirrored interval around −0.125 entirely below 0.
    EXPECT_EQ(pair->signed_distance(), -pair->penetration_depth());
    EXPECT_LE(pair->signed_distance_lower(), -want.depth);
    EXPECT_GE(pair->signed_distance_upper(), -want.depth);
    EXPECT_LT(pair->signed_distance_upper(), 0.0);
    // Direction A → B, and witnesses with point_a − point_b = depth · direction.
    const Vec3<double> direction = vec(pair->depth_direction());
    EXPECT_NEAR((direction - want.direction).norm(), 0.0, 1e-9) << direction.transpose();
    const Vec3<double> a = vec(pair->depth_point_a()), b = vec(pair->depth_point_b());
    EXPECT_NEAR((a - b - pair->penetration_depth() * direction).norm(), 0.0, 1e-9);
    EXPECT_NEAR(a.x(), want.point_a.x(), 1e-9);
    EXPECT_NEAR(b.x(), want.point_b.x(), 1e-9);
    if (want.a[0] == 's') {  // spheres: unique witnesses on the line of centres
      EXPECT_NEAR((a - want.point_a).norm(), 0.0, 1e-9) << a.transpose();
      EXPECT_NEAR((b - want.point_b).norm(), 0.0, 1e-9) << b.transpose();
    }
    EXPECT_TRUE(pair->depth_termination() == v1::DEPTH_TERMINATION_TOLERANCE ||
                pair->depth_termination() == v1::DEPTH_TERMINATION_CLOSED_FORM)
        << v1::DepthTermination_Name(pair->depth_termination());
  }
  // Exactly touching faces: in contact, the signed distance's interval contains 0 (the engine may
  // call this intersecting or touching; either is in contact, neither is separated).
  const v1::PairDistance* touching = find_pair(report, "t1", "t2");
  ASSERT_NE(touching, nullptr);
  EXPECT_TRUE(touching->status() == v1::PAIR_STATUS_INTERSECTING ||
              touching->status() == v1::PAIR_STATUS_TOUCHING)
      << touching->DebugString();
  ASSERT_TRUE(touching->has_signed_distance());
  EXPECT_LE(touching->signed_distance_lower(), 0.0);
  EXPECT_GE(touching->signed_distance_upper(), 0.0);
  if (touching->status() == v1::PAIR_STATUS_INTERSECTING) {  // the verdict agrees with the interval
    EXPECT_LT(touching->signed_distance_lower(), 0.0);
  }
  // Separated: the signed distance is the distance, its interval above 0, the depth 0.
  const v1::PairDistance* apart = find_pair(report, "s1", "b1");
  ASSERT_NE(apart, nullptr);
  EXPECT_EQ(apart->status(), v1::PAIR_STATUS_SEPARATED);
  ASSERT_TRUE(apart->has_signed_distance());
  EXPECT_NEAR(apart->signed_distance(), 9.0, 1e-9);  // 10 − 0.5 − 0.5
  EXPECT_LE(apart->signed_distance_lower(), 9.0);
  EXPECT_GE(apart->signed_distance_upper(), 9.0);
  EXPECT_GE(apart->signed_distance_lower(), 0.0);
  EXPECT_EQ(apart->penetration_depth(), 0.0);
}

// Depth mode as the scene's default and as a query's override: the analytic depths within their
// reported intervals, over gRPC from a real nearpointd.
TEST(DepthOnTheWire, AnalyticDepthsOfSpheresAndBoxesLieInTheReportedIntervals) {
  Daemon daemon = start_daemon();
  ASSERT_TRUE(daemon.stub);
  for (const bool scene_default : {true, false}) {
    SCOPED_TRACE(scene_default ? "scene default" : "query override");
    v1::CreateSceneRequest request = analytic_scene(*daemon.stub, scene_default);
    v1::CreateSceneResponse created;
    grpc::Status status = daemon.stub->CreateScene(make_context().get(), request, &created);
    ASSERT_TRUE(status.ok()) << status.error_message();
    v1::QueryRequest query;
    query.set_scene_id(created.scene_id());
    if (!scene_default) {
      // Without depth first: no depth fields, and the overlap is still intersecting.
      v1::DistanceReport plain;
      status = daemon.stub->Query(make_context().get(), query, &plain);
      ASSERT_TRUE(status.ok()) << status.error_message();
      const v1::PairDistance* spheres = find_pair(plain, "s1", "s2");
      ASSERT_NE(spheres, nullptr);
      EXPECT_EQ(spheres->status(), v1::PAIR_STATUS_INTERSECTING);
      EXPECT_FALSE(spheres->has_signed_distance());
      EXPECT_FALSE(spheres->has_penetration_depth());
      query.mutable_options()->set_penetration(v1::PENETRATION_MODE_DEPTH);
      query.mutable_options()->set_gradient(true);
    }
    v1::DistanceReport report;
    status = daemon.stub->Query(make_context().get(), query, &report);
    ASSERT_TRUE(status.ok()) << status.error_message();
    expect_analytic(report);
    if (!scene_default) {
      // The gradient of the signed distance through contact: moving B (s2) along +x separates
      // the spheres, ∂φ/∂t_B = +direction, ∂φ/∂t_A = −direction.
      const v1::PairDistance* spheres = find_pair(report, "s1", "s2");
      ASSERT_TRUE(spheres->has_gradient()) << spheres->DebugString();
      EXPECT_NEAR(spheres->gradient_b().translation().x(), 1.0, 1e-9);
      EXPECT_NEAR(spheres->gradient_a().translation().x(), -1.0, 1e-9);
    }
  }
  daemon.process->signal(SIGTERM);
  EXPECT_EQ(daemon.process->wait_exit(std::chrono::seconds(15)), 0);
}

// Negative thresholds: ENTER when the pair overlaps deeper than −distance, EXIT past the
// hysteresis; a deeper threshold stays quiet. Without depth mode they are refused, naming the
// field, and a later update may not turn the depth mode off.
TEST(DepthOnTheWire, NegativeThresholdsWatchTheSignedDistance) {
  Daemon daemon = start_daemon();
  ASSERT_TRUE(daemon.stub);
  v1::CreateSceneRequest request = analytic_scene(*daemon.stub, false);
  v1::CreateSceneResponse created;
  ASSERT_TRUE(daemon.stub->CreateScene(make_context().get(), request, &created).ok());

  auto update = [&](std::uint64_t sequence, double s2_x, bool depth) {
    v1::PoseUpdate out;
    out.set_scene_id(created.scene_id());
    out.set_sequence(sequence);
    v1::ObjectPose& pose = *out.add_poses();
    pose.set_object_id("s2");
    set_vec({s2_x, 0, 0}, *pose.mutable_pose()->mutable_translation());
    if (depth) out.mutable_options()->set_penetration(v1::PENETRATION_MODE_DEPTH);
    return out;
  };
  auto watch = [](v1::PoseUpdate& first) {
    v1::Threshold& deep = *first.add_thresholds();
    deep.set_name("deeper than 0.0625");
    deep.set_distance(-0.0625);
    deep.set_hysteresis(0.03125);
    deep.set_object_a("s1");
    deep.set_object_b("s2");
    v1::Threshold& deeper = *first.add_thresholds();
    deeper.set_name("deeper than 0.25");
    deeper.set_distance(-0.25);
    deeper.set_object_a("s1");
    deeper.set_object_b("s2");
  };

  {  // Without the depth mode: refused, naming the threshold's distance.
    StreamClient stream(*daemon.stub);
    v1::PoseUpdate first = update(1, 0.625, false);
    watch(first);
    ASSERT_TRUE(stream.write(first));
    v1::DistanceReport report;
    ASSERT_TRUE(stream.read(report));
    EXPECT_EQ(report.error().code(), v1::ERROR_CODE_INVALID_ARGUMENT);
    EXPECT_EQ(report.error().field(), "thresholds[0].distance") << report.error().message();
    EXPECT_NE(report.error().message().find("PENETRATION_MODE_DEPTH"), std::string::npos)
        << report.error().message();
    EXPECT_TRUE(stream.finish().ok());
  }

  StreamClient stream(*daemon.stub);
  // 1: depth 0.125 (signed −0.125): below −0.0625, ENTER; not below −0.25.
  v1::PoseUpdate first = update(1, 0.625, true);
  watch(first);
  ASSERT_TRUE(stream.write(first));
  v1::DistanceReport report;
  ASSERT_TRUE(stream.read(report));
  ASSERT_FALSE(report.has_error()) << report.error().message();
  ASSERT_EQ(report.events_size(), 1) << report.DebugString();
  EXPECT_EQ(report.events(0).crossing(), v1::THRESHOLD_CROSSING_ENTER);
  EXPECT_EQ(report.events(0).threshold_index(), 0u);
  EXPECT_NEAR(report.events(0).distance(), -0.125, 1e-9);
  EXPECT_EQ(report.events(0).sequence(), 1u);

  // 2: depth 0.046875 (signed −0.046875): within the hysteresis band [−0.0625, −0.03125]: quiet.
  ASSERT_TRUE(stream.write(update(2, 0.703125, true)));
  ASSERT_TRUE(stream.read(report));
  ASSERT_FALSE(report.has_error()) << report.error().message();
  EXPECT_EQ(report.events_size(), 0) << report.DebugString();

  // 3: a later update without the depth mode is refused, and the stream stays open.
  ASSERT_TRUE(stream.write(update(3, 0.703125, false)));
  ASSERT_TRUE(stream.read(report));
  EXPECT_EQ(report.error().code(), v1::ERROR_CODE_INVALID_ARGUMENT);
  EXPECT_EQ(report.error().field(), "options.penetration") << report.error().message();

  // 4: depth 0.015625 (signed −0.015625): above −0.03125, EXIT.
  ASSERT_TRUE(stream.write(update(4, 0.734375, true)));
  ASSERT_TRUE(stream.read(report));
  ASSERT_FALSE(report.has_error()) << report.error().message();
  ASSERT_EQ(report.events_size(), 1) << report.DebugString();
  EXPECT_EQ(report.events(0).crossing(), v1::THRESHOLD_CROSSING_EXIT);
  EXPECT_NEAR(report.events(0).distance(), -0.015625, 1e-9);

  // 5: depth 0.375 (signed −0.375): both thresholds ENTER, in threshold order.
  ASSERT_TRUE(stream.write(update(5, 0.375, true)));
  ASSERT_TRUE(stream.read(report));
  ASSERT_FALSE(report.has_error()) << report.error().message();
  ASSERT_EQ(report.events_size(), 2) << report.DebugString();
  EXPECT_EQ(report.events(0).threshold_index(), 0u);
  EXPECT_EQ(report.events(1).threshold_index(), 1u);
  EXPECT_EQ(report.events(1).crossing(), v1::THRESHOLD_CROSSING_ENTER);
  EXPECT_NEAR(report.events(1).distance(), -0.375, 1e-9);
  EXPECT_TRUE(stream.finish().ok());

  daemon.process->signal(SIGTERM);
  EXPECT_EQ(daemon.process->wait_exit(std::chrono::seconds(15)), 0);
}

// Paddings in depth mode: the signed distance drops by the pair's padding p and the depth grows
// by it, the witnesses move onto the padded surfaces; a pair whose cores are apart but whose
// paddings overlap is intersecting with depth p − d.
TEST(DepthOnTheWire, PaddingShiftsTheSignedDistanceAndTheDepth) {
  Daemon daemon = start_daemon();
  ASSERT_TRUE(daemon.stub);
  v1::RegisterGeometryRequest sphere;
  *sphere.mutable_geometry() = sphere_geometry(0.5);
  v1::RegisterGeometryResponse stored;
  ASSERT_TRUE(daemon.stub->RegisterGeometry(make_context().get(), sphere, &stored).ok());
  const std::string id = stored.geometry().geometry_id();
  v1::CreateSceneRequest request;
  add_object(request, "a", id, {0, 0, 0});
  add_object(request, "b", id, {0.875, 0, 0});  // cores overlap by 0.125
  add_object(request, "c", id, {10, 0, 0});
  add_object(request, "d", id, {11.0625, 0, 0});  // cores 0.0625 apart
  for (int i = 0; i < 4; ++i) request.mutable_objects(i)->set_padding(i % 2 ? 0.09375 : 0.03125);
  add_pair(request, "a", "b");
  add_pair(request, "c", "d");
  request.mutable_default_options()->set_penetration(v1::PENETRATION_MODE_DEPTH);
  v1::CreateSceneResponse created;
  grpc::Status status = daemon.stub->CreateScene(make_context().get(), request, &created);
  ASSERT_TRUE(status.ok()) << status.error_message();
  v1::QueryRequest query;
  query.set_scene_id(created.scene_id());
  v1::DistanceReport report;
  status = daemon.stub->Query(make_context().get(), query, &report);
  ASSERT_TRUE(status.ok()) << status.error_message();
  // p = 0.03125 + 0.09375 = 0.125: depths 0.125 + 0.125 and 0.125 − 0.0625.
  for (const auto& [a, b, depth, x_a, x_b] : {std::tuple{"a", "b", 0.25, 0.53125, 0.28125},
                                              std::tuple{"c", "d", 0.0625, 10.53125, 10.46875}}) {
    SCOPED_TRACE(std::string(a) + "-" + b);
    const v1::PairDistance* pair = find_pair(report, a, b);
    ASSERT_NE(pair, nullptr);
    EXPECT_EQ(pair->status(), v1::PAIR_STATUS_INTERSECTING) << pair->DebugString();
    ASSERT_TRUE(pair->has_penetration_depth());
    EXPECT_LE(pair->penetration_depth_lower(), depth);
    EXPECT_GE(pair->penetration_depth_upper(), depth);
    EXPECT_NEAR(pair->penetration_depth(), depth, 1e-12);
    EXPECT_LE(pair->signed_distance_lower(), -depth);
    EXPECT_GE(pair->signed_distance_upper(), -depth);
    EXPECT_NEAR(pair->signed_distance(), -depth, 1e-12);
    if (pair->depth_direction().x() != 0) {  // the c-d pair's direction needs near points
      EXPECT_NEAR(pair->depth_point_a().x(), x_a, 1e-12);
      EXPECT_NEAR(pair->depth_point_b().x(), x_b, 1e-12);
    }
  }
  daemon.process->signal(SIGTERM);
  EXPECT_EQ(daemon.process->wait_exit(std::chrono::seconds(15)), 0);
}

// The engine's third verdict reaches the wire as PAIR_STATUS_TOUCHING (6), not INTERSECTING, and
// reads back as touching: a constructed engine result through the server's mapping and the one
// proto conversion.
TEST(DepthOnTheWire, TouchingIsItsOwnStatusOnTheWire) {
  DistanceResult<double> engine;
  engine.status = Status::touching;
  EXPECT_EQ(pair_status(engine), model::PairStatus::touching);
  engine.status = Status::intersecting;
  EXPECT_EQ(pair_status(engine), model::PairStatus::intersecting);
  engine.status = Status::separated;
  EXPECT_EQ(pair_status(engine), model::PairStatus::separated);
  engine.termination = Termination::beyond_cutoff;
  EXPECT_EQ(pair_status(engine), model::PairStatus::beyond_cutoff);
  engine.status = Status::invalid_input;
  EXPECT_EQ(pair_status(engine), model::PairStatus::engine_error);

  model::PairAnswer answer;
  answer.status = model::PairStatus::touching;
  answer.has_signed_distance = true;
  answer.signed_distance_lower = -1e-15;
  answer.signed_distance_upper = 2e-15;
  answer.has_penetration_depth = true;
  answer.depth_upper = 1e-15;
  answer.depth_termination = model::DepthTermination::closed_form;
  v1::PairDistance wire;
  proto::to_proto(answer, wire);
  EXPECT_EQ(wire.status(), v1::PAIR_STATUS_TOUCHING);
  EXPECT_EQ(int(wire.status()), 6);
  EXPECT_EQ(wire.depth_termination(), v1::DEPTH_TERMINATION_CLOSED_FORM);
  model::PairAnswer back;
  proto::from_proto(wire, back);
  EXPECT_EQ(back.status, model::PairStatus::touching);
  EXPECT_TRUE(model::in_contact(back.status));
  EXPECT_EQ(back.signed_distance_upper, 2e-15);
  EXPECT_EQ(back.depth_termination, model::DepthTermination::closed_form);
}

}  // namespace
}  // namespace nearpoint::server::testing
