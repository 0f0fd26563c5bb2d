// SPDX-License-Identifier: Apache-2.0
// nearpoint_stream_demo: the smallest complete client of nearpointd. It registers three
// geometries (a box as a polytope, a capsule, a cylinder), creates a scene, streams a box sliding
// past the other two, prints one line per report and deletes its scene. It talks to the wire API
// (the generated nearpoint.v1 stubs) directly, as a client in another language would; the
// `nearpoint` CLI and nearpoint::client do the same for real use.
//
//   nearpoint_stream_demo [--target HOST:PORT] [--updates 40]   (--help for more)
#include <grpcpp/grpcpp.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "nearpoint_distance.grpc.pb.h"

namespace v1 = ::nearpoint::v1;

namespace {

void set_vec(double x, double y, double z, v1::Vector3& out) {
  out.set_x(x);
  out.set_y(y);
  out.set_z(z);
}

std::unique_ptr<grpc::ClientContext> context_with_deadline(int seconds) {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(seconds));
  return context;
}

bool check(const grpc::Status& status, const char* what) {
  if (status.ok()) return true;
  std::fprintf(stderr, "%s failed: %s (%d)\n", what, status.error_message().c_str(),
               int(status.error_code()));
  return false;
}

std::string register_geometry(v1::DistanceService::Stub& stub, const v1::Geometry& geometry) {
  v1::RegisterGeometryRequest request;
  *request.mutable_geometry() = geometry;
  v1::RegisterGeometryResponse response;
  if (!check(stub.RegisterGeometry(context_with_deadline(10).get(), request, &response),
             "RegisterGeometry"))
    std::exit(1);
  std::printf("registered %-8s as %s (bounding radius %.3f m)\n", geometry.name().c_str(),
              response.geometry().geometry_id().c_str(), response.geometry().bounding_radius());
  return response.geometry().geometry_id();
}

}  // namespace

int main(int argc, char** argv) {
  // The same default as the nearpoint CLI: $NEARPOINT_TARGET, else the server's default address.
  const char* env_target = std::getenv("NEARPOINT_TARGET");
  std::string target =
      env_target != nullptr && *env_target != '\0' ? env_target : "127.0.0.1:50051";
  int updates = 40;
  CLI::App app(
      "The smallest complete client of nearpointd: registers a cube, a capsule and a cylinder, "
      "creates a scene, streams the cube past the other two (one line per report) and deletes "
      "the scene.",
      "nearpoint_stream_demo");
  app.add_option("--target", target,
                 "nearpointd address host:port (default $NEARPOINT_TARGET or 127.0.0.1:50051)")
      ->capture_default_str();
  app.add_option("--updates", updates, "Pose updates to stream")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  auto stub =
      v1::DistanceService::NewStub(grpc::CreateChannel(target, grpc::InsecureChannelCredentials()));

  // A 1 m cube as a polytope (its 8 corners), a capsule and a cylinder (primitives).
  v1::Geometry cube;
  cube.set_name("cube");
  v1::Polytope& corners = *cube.add_pieces()->mutable_polytope();
  for (int i = 0; i < 8; ++i)
    set_vec(i & 1 ? 0.5 : -0.5, i & 2 ? 0.5 : -0.5, i & 4 ? 0.5 : -0.5, *corners.add_vertices());
  v1::Geometry capsule;
  capsule.set_name("capsule");
  v1::Piece& rod = *capsule.add_pieces();
  set_vec(0, 0, -0.5, *rod.mutable_segment()->mutable_a());
  set_vec(0, 0, 0.5, *rod.mutable_segment()->mutable_b());
  rod.set_radius(0.2);
  v1::Geometry cylinder;
  cylinder.set_name("cylinder");
  cylinder.add_pieces()->mutable_cylinder()->set_radius(0.3);
  cylinder.mutable_pieces(0)->mutable_cylinder()->set_half_height(0.6);

  v1::CreateSceneRequest scene;
  scene.set_name("demo");
  scene.mutable_default_options()->set_near_points(true);
  const std::pair<const char*, const v1::Geometry*> objects[] = {
      {"mover", &cube}, {"post", &capsule}, {"drum", &cylinder}};
  const double x_positions[] = {0, 0, 3};
  for (int i = 0; i < 3; ++i) {
    v1::SceneObject& object = *scene.add_objects();
    object.set_id(objects[i].first);
    object.set_geometry_id(register_geometry(*stub, *objects[i].second));
    set_vec(x_positions[i], i == 0 ? -2 : 0, 0, *object.mutable_pose()->mutable_translation());
  }
  v1::CreateSceneResponse created;
  if (!check(stub->CreateScene(context_with_deadline(10).get(), scene, &created), "CreateScene"))
    return 1;
  std::printf("scene %s: %u pairs\n\n", created.scene_id().c_str(), created.pair_count());

  // Stream: the cube slides along x from -1 to 4 at y = -1, turning about z; one report each.
  auto context = context_with_deadline(60);
  auto stream = stub->StreamPoses(context.get());
  for (int step = 0; step < updates; ++step) {
    const double s = double(step) / std::max(1, updates - 1);
    v1::PoseUpdate update;
    update.set_scene_id(created.scene_id());
    update.set_sequence(std::uint64_t(step) + 1);
    v1::ObjectPose& pose = *update.add_poses();
    pose.set_object_id("mover");
    const double angle = 1.5 * s;  // radians about z
    v1::Quaternion& q = *pose.mutable_pose()->mutable_rotation();
    q.set_w(std::cos(angle / 2));
    q.set_z(std::sin(angle / 2));
    set_vec(-1 + 5 * s, -1.0, 0, *pose.mutable_pose()->mutable_translation());
    v1::DistanceReport report;
    if (!stream->Write(update) || !stream->Read(&report)) break;
    if (report.has_error()) {
      std::printf("seq %llu rejected: %s: %s\n", (unsigned long long)report.sequence(),
                  report.error().field().c_str(), report.error().message().c_str());
      continue;
    }
    std::printf("seq %3llu (%5.0f µs on the server)", (unsigned long long)report.sequence(),
                report.timing().server_us());
    for (const v1::PairDistance& pair : report.pairs())
      std::printf(
          "  %s-%s %s %.3f m%s", pair.object_a().c_str(), pair.object_b().c_str(),
          pair.status() == v1::PAIR_STATUS_INTERSECTING || pair.status() == v1::PAIR_STATUS_TOUCHING
              ? "HIT"
              : "d=",
          pair.distance(), pair.warm_started() ? "*" : "");
    std::printf("\n");
  }
  stream->WritesDone();
  const grpc::Status status = stream->Finish();
  // The scene was made for this run only: leave the server as it was found.
  v1::DeleteSceneRequest remove;
  remove.set_scene_id(created.scene_id());
  v1::DeleteSceneResponse removed;
  const bool deleted =
      check(stub->DeleteScene(context_with_deadline(10).get(), remove, &removed), "DeleteScene");
  std::printf(
      "\nstream ended: %s (* = warm-started from the previous update; smooth shapes such as "
      "the cylinder have no vertices to cache)\n",
      status.ok() ? "OK" : status.error_message().c_str());
  return status.ok() && deleted ? 0 : 1;
}
