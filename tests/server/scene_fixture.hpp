// SPDX-License-Identifier: Apache-2.0
// A scene of paper-like polytopes (a box, cylinders modelled as prisms, random hulls) plus a
// two-piece "arm", registered on a server, with a smooth trajectory and the local check of every
// reported distance against the engine.
#pragma once

#include <map>

#include "nearpoint/distance.hpp"
#include "server_test_support.hpp"

namespace nearpoint::server::testing {

using namespace ::nearpoint::model;  // the scene model's types, unqualified in the tests

struct LocalScene {
  std::vector<TestGeometry> geometries;
  std::vector<std::string> geometry_ids;
  /// Object i uses geometries[object_geometry[i]].
  std::vector<std::string> object_ids;
  std::vector<int> object_geometry;
  std::map<std::string, int> object_index;
  std::string scene_id;
  std::uint32_t pair_count = 0;

  const Compound<double>& compound(int object) const {
    return geometries[std::size_t(object_geometry[std::size_t(object)])].local;
  }
  std::size_t size() const { return object_ids.size(); }
};

/// Geometries: box (8 vertices), 16-gon prism (32), 10-gon prism (20), random hulls of 40 and 20
/// points, the arm. Objects: one per geometry plus a second box (geometries are shared).
inline LocalScene make_scene(v1::DistanceService::Stub& stub,
                             const v1::QueryOptions& default_options = {}) {
  LocalScene scene;
  scene.geometries.push_back(polytope_geometry("box", box_vertices(Vec3<double>(0.5, 0.3, 0.2))));
  scene.geometries.push_back(polytope_geometry("cylinder16", prism_vertices(16, 0.4, 0.5)));
  scene.geometries.push_back(polytope_geometry("cylinder10", prism_vertices(10, 0.3, 0.25), 0.05));
  scene.geometries.push_back(polytope_geometry("hull40", random_hull_vertices(11, 40, 0.6)));
  scene.geometries.push_back(polytope_geometry("hull20", random_hull_vertices(12, 20, 0.45)));
  scene.geometries.push_back(arm_geometry());
  for (const TestGeometry& g : scene.geometries)
    scene.geometry_ids.push_back(register_geometry(stub, g));

  v1::CreateSceneRequest request;
  request.set_name("paper-like");
  const int uses[] = {0, 1, 2, 3, 4, 5, 0};
  for (std::size_t i = 0; i < std::size(uses); ++i) {
    const std::string id = scene.geometries[std::size_t(uses[i])].label + "-" + std::to_string(i);
    scene.object_ids.push_back(id);
    scene.object_geometry.push_back(uses[i]);
    scene.object_index[id] = int(i);
    v1::SceneObject& object = *request.add_objects();
    object.set_id(id);
    object.set_geometry_id(scene.geometry_ids[std::size_t(uses[i])]);
  }
  *request.mutable_default_options() = default_options;
  v1::CreateSceneResponse response;
  const grpc::Status status = stub.CreateScene(make_context().get(), request, &response);
  EXPECT_TRUE(status.ok()) << status.error_message();
  scene.scene_id = response.scene_id();
  scene.pair_count = response.pair_count();
  return scene;
}

/// Object poses at `step` of a smooth trajectory: objects on a circle of radius 0.8 (neighbours
/// about 0.7 m apart, so pairs come and go in contact), each swaying and turning; `phase` gives a
/// different trajectory; everything is offset far from the origin, as in site coordinates.
inline std::vector<TestPose> trajectory(std::size_t objects, int step, double phase = 0) {
  std::vector<TestPose> poses(objects);
  const Vec3<double> site(1000.0, -500.0, 20.0);
  for (std::size_t i = 0; i < objects; ++i) {
    const double t = 0.03 * step + phase;
    const double theta = 2 * std::numbers::pi * double(i) / double(objects);
    const double k = double(i);
    poses[i].translation = site + 0.8 * Vec3<double>(std::cos(theta), std::sin(theta), 0) +
                           Vec3<double>(0.4 * std::sin(1.3 * t + k),
                                        0.4 * std::cos(0.7 * t + 2 * k), 0.2 * std::sin(t + 3 * k));
    poses[i].rotation = axis_angle((0.4 + 0.1 * k) * t + k, Vec3<double>(1 + k, 2 - k, 0.5 + k));
  }
  return poses;
}

inline v1::PoseUpdate make_update(const LocalScene& scene, std::uint64_t sequence,
                                  const std::vector<TestPose>& poses) {
  v1::PoseUpdate update;
  update.set_scene_id(scene.scene_id);
  update.set_sequence(sequence);
  for (std::size_t i = 0; i < poses.size(); ++i) {
    v1::ObjectPose& pose = *update.add_poses();
    pose.set_object_id(scene.object_ids[i]);
    poses[i].to_message(*pose.mutable_pose());
  }
  return update;
}

struct CheckStats {
  int pairs = 0;
  int intersecting = 0;
  int warm_started = 0;
};

/// Every pair of `report` against the engine run here on the same poses (cold start): distances
/// agree within the sum of both certified error bounds, verdicts agree, near points are
/// consistent.
inline void expect_matches_local(const LocalScene& scene, const std::vector<TestPose>& poses,
                                 const v1::DistanceReport& report, bool near_points,
                                 CheckStats* stats = nullptr) {
  ASSERT_FALSE(report.has_error()) << report.error().field() << ": " << report.error().message();
  ASSERT_EQ(report.pairs_size(), int(scene.size() * (scene.size() - 1) / 2));
  DistanceOptions<double> options;
  options.near_points = near_points;
  for (const v1::PairDistance& pair : report.pairs()) {
    const int a = scene.object_index.at(pair.object_a());
    const int b = scene.object_index.at(pair.object_b());
    const CompoundResult<double> local =
        distance(scene.compound(a), poses[std::size_t(a)].local(), scene.compound(b),
                 poses[std::size_t(b)].local(), options);
    const double tolerance = pair.error_bound() + local.nearest.error_bound + 1e-12;
    SCOPED_TRACE(pair.object_a() + " / " + pair.object_b() + " at sequence " +
                 std::to_string(report.sequence()));
    ASSERT_TRUE(pair.status() == v1::PAIR_STATUS_SEPARATED ||
                pair.status() == v1::PAIR_STATUS_INTERSECTING)
        << v1::PairStatus_Name(pair.status()) << " " << pair.message();
    EXPECT_NEAR(pair.distance(), local.nearest.distance, tolerance);
    if (local.nearest.distance > tolerance) {
      EXPECT_EQ(pair.status(), v1::PAIR_STATUS_SEPARATED);
    }
    if (pair.status() == v1::PAIR_STATUS_INTERSECTING) {
      EXPECT_EQ(pair.distance(), 0.0);
    }
    EXPECT_LE(pair.distance_lower_bound(), pair.distance());
    EXPECT_EQ(pair.has_near_points(), near_points);
    if (near_points && pair.status() == v1::PAIR_STATUS_SEPARATED) {
      const Vec3<double> pa(pair.point_a().x(), pair.point_a().y(), pair.point_a().z());
      const Vec3<double> pb(pair.point_b().x(), pair.point_b().y(), pair.point_b().z());
      const Vec3<double> n(pair.normal().x(), pair.normal().y(), pair.normal().z());
      EXPECT_NEAR((pb - pa).norm(), pair.distance(), 1e-9);
      EXPECT_NEAR(n.norm(), 1.0, 1e-9);
      if (pair.distance() > 1e-6) {
        EXPECT_NEAR((pb - pa).dot(n), pair.distance(), 1e-9);
      }
    }
    if (stats) {
      ++stats->pairs;
      stats->intersecting += pair.status() == v1::PAIR_STATUS_INTERSECTING;
      stats->warm_started += pair.warm_started();
    }
  }
}

/// A bidirectional pose stream through the generated sync client, with a deadline: StreamPoses
/// (`batch` 0, the default), or StreamPoseBatches sending `batch` updates per message — write()
/// buffers until `batch` are there, flush() and writes_done() send what is buffered — whose
/// reports read() hands out one by one. The same test then drives either RPC.
class StreamClient {
 public:
  explicit StreamClient(v1::DistanceService::Stub& stub,
                        std::chrono::seconds deadline = kCallDeadline, std::size_t batch = 0)
      : context_(make_context(deadline)), batch_(batch) {
    if (batch_ == 0)
      stream_ = stub.StreamPoses(context_.get());
    else
      batch_stream_ = stub.StreamPoseBatches(context_.get());
  }

  bool write(const v1::PoseUpdate& update) {
    if (batch_ == 0) return stream_->Write(update);
    *buffered_.add_updates() = update;
    return buffered_.updates_size() < int(batch_) || flush();
  }
  /// Sends the buffered updates as one batch (if any).
  bool flush() {
    if (batch_ == 0 || buffered_.updates_size() == 0) return true;
    const bool written = batch_stream_->Write(buffered_);
    buffered_.Clear();
    return written;
  }
  bool read(v1::DistanceReport& report) {
    if (batch_ == 0) return stream_->Read(&report);
    while (next_report_ == received_.reports_size()) {
      if (!batch_stream_->Read(&received_)) return false;
      ++messages_read_;
      next_report_ = 0;
    }
    report = received_.reports(next_report_++);
    return true;
  }
  bool writes_done() {
    if (!flush()) return false;
    return batch_ == 0 ? stream_->WritesDone() : batch_stream_->WritesDone();
  }
  /// Half-closes, reads what is left (into `rest` if given) and returns the call's status.
  grpc::Status finish(std::vector<v1::DistanceReport>* rest = nullptr) {
    writes_done();
    v1::DistanceReport report;
    while (read(report))
      if (rest) rest->push_back(report);
    return batch_ == 0 ? stream_->Finish() : batch_stream_->Finish();
  }
  /// Reads until the server ends the stream (without half-closing) and returns its status.
  grpc::Status read_to_end(std::vector<v1::DistanceReport>& out) {
    v1::DistanceReport report;
    while (read(report)) out.push_back(report);
    return batch_ == 0 ? stream_->Finish() : batch_stream_->Finish();
  }
  grpc::ClientContext& context() { return *context_; }
  /// StreamPoseBatches: the DistanceReportBatch messages read so far.
  std::size_t messages_read() const { return messages_read_; }

 private:
  std::unique_ptr<grpc::ClientContext> context_;
  const std::size_t batch_;
  std::unique_ptr<grpc::ClientReaderWriter<v1::PoseUpdate, v1::DistanceReport>> stream_;
  std::unique_ptr<grpc::ClientReaderWriter<v1::PoseUpdateBatch, v1::DistanceReportBatch>>
      batch_stream_;
  v1::PoseUpdateBatch buffered_;
  v1::DistanceReportBatch received_;
  int next_report_ = 0;
  std::size_t messages_read_ = 0;
};

}  // namespace nearpoint::server::testing
