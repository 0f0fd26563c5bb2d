// SPDX-License-Identifier: Apache-2.0
// Shared pieces of the server tests: geometries built twice from the same numbers (as a wire
// message for the server, as an engine Compound for the local check), poses, client contexts with
// deadlines, and an in-process server on 127.0.0.1:0.
#pragma once

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "common/random_hull.hpp"
#include "nearpoint/compound.hpp"
#include "nearpoint/server/server.hpp"
#include "nearpoint_diagnostics.grpc.pb.h"
#include "nearpoint_distance.grpc.pb.h"

namespace nearpoint::server::testing {

using namespace ::nearpoint::model;  // the scene model's types, unqualified in the tests

namespace v1 = ::nearpoint::v1;

/// Every client call gets a deadline: a broken stream fails the test instead of hanging it.
inline constexpr std::chrono::seconds kCallDeadline{20};

inline std::unique_ptr<grpc::ClientContext> make_context(
    std::chrono::seconds deadline = kCallDeadline) {
  auto context = std::make_unique<grpc::ClientContext>();
  context->set_deadline(std::chrono::system_clock::now() + deadline);
  return context;
}

/// A geometry in both forms: the message sent to the server and the engine's compound.
struct TestGeometry {
  std::string label;
  v1::Geometry message;
  Compound<double> local;
};

inline void set_vec(const Vec3<double>& v, v1::Vector3& out) {
  out.set_x(v.x());
  out.set_y(v.y());
  out.set_z(v.z());
}

/// A unit quaternion (w, x, y, z) for `angle` radians about `axis`.
inline Eigen::Quaterniond axis_angle(double angle, Vec3<double> axis) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis.normalized()));
}

inline void set_pose(const Eigen::Quaterniond& q, const Vec3<double>& t, v1::Pose& out) {
  out.mutable_rotation()->set_w(q.w());
  out.mutable_rotation()->set_x(q.x());
  out.mutable_rotation()->set_y(q.y());
  out.mutable_rotation()->set_z(q.z());
  set_vec(t, *out.mutable_translation());
}

/// A pose in both forms.
struct TestPose {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Vec3<double> translation = Vec3<double>::Zero();
  Pose<double> local() const { return Pose<double>::from_quaternion(rotation, translation); }
  void to_message(v1::Pose& out) const { set_pose(rotation, translation, out); }
};

/// One polytope piece from a vertex list (radius 0, identity offset).
inline TestGeometry polytope_geometry(std::string label, const std::vector<Vec3<double>>& vertices,
                                      double radius = 0) {
  TestGeometry g;
  g.label = label;
  g.message.set_name(label);
  v1::Piece& piece = *g.message.add_pieces();
  for (const Vec3<double>& v : vertices) set_vec(v, *piece.mutable_polytope()->add_vertices());
  piece.set_radius(radius);
  std::vector<Piece<double>> pieces;
  pieces.push_back({Shape<double>(Polytope<double>(vertices), radius), Pose<double>{}});
  g.local = Compound<double>(std::move(pieces));
  return g;
}

/// The 8 corners of a box with the given half extents, as a polytope.
inline std::vector<Vec3<double>> box_vertices(const Vec3<double>& half) {
  std::vector<Vec3<double>> out;
  for (int i = 0; i < 8; ++i)
    out.emplace_back(i & 1 ? half.x() : -half.x(), i & 2 ? half.y() : -half.y(),
                     i & 4 ? half.z() : -half.z());
  return out;
}

/// A cylinder as the paper models it: an n-gon prism about z.
inline std::vector<Vec3<double>> prism_vertices(int sides, double radius, double half_height) {
  std::vector<Vec3<double>> out;
  for (int k = 0; k < sides; ++k) {
    const double angle = 2 * std::numbers::pi * k / sides;
    out.emplace_back(radius * std::cos(angle), radius * std::sin(angle), -half_height);
    out.emplace_back(radius * std::cos(angle), radius * std::sin(angle), half_height);
  }
  return out;
}

using testkit::random_hull_vertices;

/// A two-piece geometry: a capsule (segment with radius) and a rounded box placed beside it by
/// a rotated offset — exercises compounds, primitives, radii and offsets together.
inline TestGeometry arm_geometry() {
  TestGeometry g;
  g.label = "arm";
  g.message.set_name("arm");
  const Vec3<double> a(-0.4, 0, 0), b(0.4, 0, 0);
  v1::Piece& capsule = *g.message.add_pieces();
  set_vec(a, *capsule.mutable_segment()->mutable_a());
  set_vec(b, *capsule.mutable_segment()->mutable_b());
  capsule.set_radius(0.1);
  const Vec3<double> half(0.15, 0.1, 0.2);
  const Eigen::Quaterniond q = axis_angle(0.5, Vec3<double>(0, 0, 1));
  const Vec3<double> t(0.55, 0.1, 0);
  v1::Piece& box = *g.message.add_pieces();
  set_vec(half, *box.mutable_box()->mutable_half_extents());
  box.set_radius(0.02);
  set_pose(q, t, *box.mutable_offset());
  std::vector<Piece<double>> pieces;
  pieces.push_back({Shape<double>::capsule(a, b, 0.1), Pose<double>{}});
  pieces.push_back({Shape<double>(Box<double>{half}, 0.02), Pose<double>::from_quaternion(q, t)});
  g.local = Compound<double>(std::move(pieces));
  return g;
}

/// An in-process server on 127.0.0.1:0 and a channel to it.
struct RunningServer {
  std::unique_ptr<GrpcServer> server;
  std::shared_ptr<grpc::Channel> channel;
  std::unique_ptr<v1::DistanceService::Stub> stub;
  std::string address;
};

inline ServerConfig test_config() {
  ServerConfig config;
  config.listen = "127.0.0.1:0";
  config.workers = 2;
  config.drain_timeout = std::chrono::milliseconds(5000);
  return config;
}

inline RunningServer start_server(const ServerConfig& config = test_config()) {
  RunningServer running;
  auto started = GrpcServer::start(config);
  if (!started) {
    ADD_FAILURE() << "server did not start: " << started.error().describe();
    return running;
  }
  running.server = std::move(started.value());
  running.address = "127.0.0.1:" + std::to_string(running.server->port());
  grpc::ChannelArguments arguments;
  arguments.SetMaxReceiveMessageSize(64 << 20);
  arguments.SetMaxSendMessageSize(64 << 20);
  running.channel =
      grpc::CreateCustomChannel(running.address, grpc::InsecureChannelCredentials(), arguments);
  running.stub = v1::DistanceService::NewStub(running.channel);
  return running;
}

/// Registers `geometry` and returns its id (fails the test on error).
inline std::string register_geometry(v1::DistanceService::Stub& stub,
                                     const TestGeometry& geometry) {
  v1::RegisterGeometryRequest request;
  *request.mutable_geometry() = geometry.message;
  v1::RegisterGeometryResponse response;
  const grpc::Status status = stub.RegisterGeometry(make_context().get(), request, &response);
  EXPECT_TRUE(status.ok()) << geometry.label << ": " << status.error_message();
  return response.geometry().geometry_id();
}

/// The bytes of a received message.
inline std::string bytes_of(const grpc::ByteBuffer& buffer) {
  std::vector<grpc::Slice> slices;
  std::string bytes;
  if (!buffer.Valid() || !buffer.Dump(&slices).ok()) return bytes;
  for (const grpc::Slice& s : slices)
    bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
  return bytes;
}

/// A bidirectional call through grpc::GenericStub, one operation at a time, every wait bounded:
/// bytes in, bytes out, so a test can send what no generated client would.
class RawStream {
 public:
  RawStream(const std::shared_ptr<grpc::Channel>& channel, const std::string& method)
      : generic_(channel), context_(make_context()) {
    call_ = generic_.PrepareCall(context_.get(), method, &queue_);
    call_->StartCall(tag());
    started_ = wait();
  }
  ~RawStream() {
    context_->TryCancel();
    queue_.Shutdown();
    void* ignored;
    bool ok;
    while (queue_.Next(&ignored, &ok)) {
    }
  }
  bool started() const { return started_; }
  bool write(const std::string& bytes) {
    grpc::Slice slice(bytes);
    grpc::ByteBuffer buffer(&slice, 1);
    call_->Write(buffer, tag());
    return wait();
  }
  bool read(std::string& bytes) {
    grpc::ByteBuffer buffer;
    call_->Read(&buffer, tag());
    if (!wait()) return false;
    bytes = bytes_of(buffer);
    return true;
  }
  /// The client's half-close: no more writes.
  bool writes_done() {
    call_->WritesDone(tag());
    return wait();
  }
  grpc::Status finish() {
    grpc::Status status;
    call_->Finish(&status, tag());
    wait();
    return status;
  }

 private:
  void* tag() { return reinterpret_cast<void*>(++last_tag_); }
  bool wait() {
    void* got = nullptr;
    bool ok = false;
    const auto deadline = std::chrono::system_clock::now() + kCallDeadline;
    if (queue_.AsyncNext(&got, &ok, deadline) != grpc::CompletionQueue::GOT_EVENT) {
      ADD_FAILURE() << "no completion within the deadline";
      return false;
    }
    EXPECT_EQ(reinterpret_cast<std::intptr_t>(got), last_tag_);
    return ok;
  }

  grpc::GenericStub generic_;
  std::unique_ptr<grpc::ClientContext> context_;
  grpc::CompletionQueue queue_;
  std::unique_ptr<grpc::GenericClientAsyncReaderWriter> call_;
  std::intptr_t last_tag_ = 0;
  bool started_ = false;
};

}  // namespace nearpoint::server::testing
