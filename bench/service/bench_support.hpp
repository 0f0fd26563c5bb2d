// SPDX-License-Identifier: Apache-2.0
// What the service benchmarks (nearpoint_service_bench, nearpoint_dds_bench) share besides the
// scene itself (bench_scene.hpp): the gRPC messages that set the scene up and move it, and the
// statistics and machine description they print.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <ctime>
#include <fstream>
#include <string>
#include <vector>

#include "bench_scene.hpp"
#include "nearpoint/model/percentile.hpp"
#include "nearpoint_distance.grpc.pb.h"

namespace bench_support {

namespace v1 = ::nearpoint::v1;

inline double micros(std::chrono::steady_clock::duration d) {
  return std::chrono::duration<double, std::micro>(d).count();
}

/// The q-quantile (0.5: median) of `values`, nearest rank; 0 for none.
using ::nearpoint::model::percentile;

/// Now, as "2026-01-31 12:00 UTC", for the results' header.
inline std::string utc_date() {
  const std::time_t now = std::time(nullptr);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
  return date;
}

/// The CPU's name from /proc/cpuinfo, for the results' header.
inline std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown";
}

inline void set_vec(const bench_scene::Vec3& v, v1::Vector3& out) {
  out.set_x(v.x());
  out.set_y(v.y());
  out.set_z(v.z());
}

/// The update that moves the 10 objects "object-0" … "object-9" to their poses at `step`
/// (bench_scene::object_pose); no options.
inline v1::PoseUpdate pose_update(const std::string& scene, std::uint64_t sequence, int step,
                                  double phase) {
  v1::PoseUpdate update;
  update.set_scene_id(scene);
  update.set_sequence(sequence);
  for (int i = 0; i < 10; ++i) {
    const auto [q, position] = bench_scene::object_pose(i, step, phase);
    v1::ObjectPose& pose = *update.add_poses();
    pose.set_object_id("object-" + std::to_string(i));
    v1::Quaternion& rotation = *pose.mutable_pose()->mutable_rotation();
    rotation.set_w(q.w());
    rotation.set_x(q.x());
    rotation.set_y(q.y());
    rotation.set_z(q.z());
    set_vec(position, *pose.mutable_pose()->mutable_translation());
  }
  return update;
}

/// Registers bench_scene's polytopes and creates the scene of "object-0" … "object-9" (one
/// polytope each) through `stub`, each call with a 10 s deadline. "" on success, else what failed.
inline std::string create_scene(v1::DistanceService::Stub& stub, const std::string& name,
                                v1::CreateSceneResponse& scene) {
  v1::CreateSceneRequest create;
  create.set_name(name);
  const std::vector<std::vector<bench_scene::Vec3>> polytopes = bench_scene::paper_like_polytopes();
  for (std::size_t i = 0; i < polytopes.size(); ++i) {
    v1::RegisterGeometryRequest request;
    request.mutable_geometry()->set_name("polytope-" + std::to_string(polytopes[i].size()));
    v1::Piece& piece = *request.mutable_geometry()->add_pieces();
    for (const bench_scene::Vec3& v : polytopes[i])
      set_vec(v, *piece.mutable_polytope()->add_vertices());
    v1::RegisterGeometryResponse response;
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    if (const grpc::Status status = stub.RegisterGeometry(&context, request, &response);
        !status.ok())
      return "register: " + status.error_message();
    v1::SceneObject& object = *create.add_objects();
    object.set_id("object-" + std::to_string(i));
    object.set_geometry_id(response.geometry().geometry_id());
  }
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  if (const grpc::Status status = stub.CreateScene(&context, create, &scene); !status.ok())
    return "scene: " + status.error_message();
  return {};
}

}  // namespace bench_support
