// SPDX-License-Identifier: Apache-2.0
#include "nearpoint/client/client.hpp"

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <fstream>
#include <map>
#include <mutex>
#include <random>
#include <thread>

#include "channel.hpp"
#include "convert.hpp"
#include "nearpoint/model/vocabulary.hpp"
#include "nearpoint_distance.grpc.pb.h"
#include "session.hpp"

namespace nearpoint::client {

namespace v1 = ::nearpoint::v1;

// ---- small pieces ----

std::string Status::code_name() const {
  return model::status_code_name(code);
}

std::string Status::describe() const {
  return message.empty() ? code_name() : code_name() + ": " + message;
}

// The spellings are model/vocabulary.hpp's string literals, so their data() ends in a NUL.
const char* to_string(PairStatus status) {
  return model::spelling_of(status).data();
}

const char* to_string(DepthTermination termination) {
  return model::spelling_of(termination).data();
}

const char* to_string(ReportMode mode) {
  // A report's mode is never unspecified; an older server's 0 means its reports hold every pair.
  const std::string_view spelling = model::spelling_of(mode);
  return (spelling.empty() ? model::spelling_of(ReportMode::all_pairs) : spelling).data();
}

const char* to_string(Crossing crossing) {
  return model::spelling_of(crossing).data();
}

model::PoseInput to_pose_input(const Eigen::Quaterniond& rotation,
                               const Eigen::Vector3d& translation) {
  model::PoseInput pose;
  pose.rotation_wxyz = {rotation.w(), rotation.x(), rotation.y(), rotation.z()};
  pose.translation = translation;
  return pose;
}

model::PoseInput to_pose_input(const Eigen::Isometry3d& pose) {
  return to_pose_input(Eigen::Quaterniond(pose.rotation()), pose.translation());
}

Piece polytope_piece(std::vector<Eigen::Vector3d> vertices, const Eigen::Isometry3d& offset) {
  Piece piece;
  piece.shape = model::PolytopeInput{std::move(vertices)};
  piece.offset = to_pose_input(offset);
  return piece;
}

ObjectPose::ObjectPose(std::string id, const Eigen::Isometry3d& pose)
    : object_id(std::move(id)), rotation(pose.rotation()), translation(pose.translation()) {}

bool is_server_drain(const Status& status) {
  // The server's drain status (see nearpoint.v1.DistanceService.StreamPoses) and the reports
  // made from it below both carry the word.
  return status.code == kUnavailable && status.message.find("draining") != std::string::npos;
}
namespace {

using detail::from_grpc;
using detail::routable;

// "s-" and 16 random hex digits: a scene id the client can route by before the scene exists.
std::string random_scene_id() {
  static std::mutex mutex;
  static std::mt19937_64 engine = [] {
    std::random_device device;
    std::seed_seq seed{device(), device(), device(), device(),
                       unsigned(Clock::now().time_since_epoch().count())};
    return std::mt19937_64(seed);
  }();
  std::uint64_t value;
  {
    std::lock_guard lock(mutex);
    value = engine();
  }
  constexpr char kHex[] = "0123456789abcdef";
  std::string id = "s-";
  for (int shift = 60; shift >= 0; shift -= 4) id.push_back(kHex[(value >> shift) & 15]);
  return id;
}

// NOT_FOUND for the scene itself (its field is "scene_id"), not for an object or geometry.
bool is_scene_not_found(const Status& status) {
  return status.code == kNotFound && status.message.rfind("scene_id:", 0) == 0;
}

// Plaintext, or TLS with the token as call credentials (which gRPC attaches to every call on
// the channel and refuses to send over an insecure one).
std::shared_ptr<grpc::ChannelCredentials> channel_credentials(const ClientOptions& options) {
  if (!options.uses_tls()) return grpc::InsecureChannelCredentials();
  grpc::SslCredentialsOptions ssl;
  ssl.pem_root_certs = options.tls_ca_pem;
  ssl.pem_private_key = options.tls_key_pem;
  ssl.pem_cert_chain = options.tls_cert_pem;
  auto credentials = grpc::SslCredentials(ssl);
  if (options.token.empty()) return credentials;
  return grpc::CompositeChannelCredentials(credentials,
                                           grpc::AccessTokenCredentials(options.token));
}

bool read_whole_file(const std::string& path, std::string& out) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  out.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  return !in.bad();
}

}  // namespace

std::shared_ptr<grpc::Channel> detail::make_channel(const std::string& target,
                                                    const ClientOptions& options) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(options.max_message_bytes);
  args.SetMaxSendMessageSize(options.max_message_bytes);
  // Reconnect to a restarted server within a fraction of a second rather than gRPC's default
  // backoff (1 s growing to 120 s): sessions replay their scene as soon as it is back.
  // GRPC_ARG_MIN_RECONNECT_BACKOFF_MS stays at gRPC's default (20 s) on purpose: gRPC also
  // takes it as the time a connection attempt may take (TCP connect and the HTTP/2 SETTINGS
  // exchange). At 100 ms, a busy or slow server (a loaded machine, a sanitizer build) failed
  // first calls with "connection attempt timed out before receiving SETTINGS frame". A refused
  // connection still fails at once, so reconnecting is no slower.
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 100);
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 1000);
  // Detect a silently dead peer on long streams.
  args.SetInt(GRPC_ARG_KEEPALIVE_TIME_MS, 20000);
  args.SetInt(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, 10000);
  if (options.uses_tls() && !options.tls_server_name.empty())
    args.SetSslTargetNameOverride(options.tls_server_name);
  return grpc::CreateCustomChannel(target, channel_credentials(options), args);
}

// The id rule: printable ASCII without spaces, at most 128 bytes.
bool detail::routable(const std::string& id) {
  if (id.empty() || id.size() > 128) return false;
  return std::all_of(id.begin(), id.end(), [](char c) { return c >= 0x21 && c <= 0x7E; });
}

namespace {

// ---- Client ----

class ClientImpl final : public Client, public detail::SessionHost {
 public:
  ClientImpl(std::string target, ClientOptions options)
      : target_(std::move(target)), options_(options) {
    channel_ = detail::make_channel(target_, options);
    stub_ = v1::DistanceService::NewStub(channel_);
  }

  /// A unary call's context; with the routing header when the call concerns `routing_scene`.
  std::unique_ptr<grpc::ClientContext> context(const std::string& routing_scene = {}) const {
    auto context = std::make_unique<grpc::ClientContext>();
    context->set_deadline(std::chrono::system_clock::now() + options_.call_timeout);
    if (routable(routing_scene)) context->AddMetadata(kSceneRoutingHeader, routing_scene);
    return context;
  }

  Expected<GeometryInfo> register_raw(const Geometry& geometry) {
    v1::RegisterGeometryRequest request;
    detail::to_proto(geometry, *request.mutable_geometry());
    v1::RegisterGeometryResponse response;
    const grpc::Status status = stub_->RegisterGeometry(context().get(), request, &response);
    if (!status.ok()) return from_grpc(status);
    return detail::from_proto(response.geometry());
  }

  Expected<GeometryInfo> register_geometry(const Geometry& geometry) override {
    Expected<GeometryInfo> info = register_raw(geometry);
    if (info) remember(geometries_, info->geometry_id, geometry);
    return info;
  }

  Status remove_geometry(const std::string& geometry_id) override {
    v1::RemoveGeometryRequest request;
    request.set_geometry_id(current_geometry_id(geometry_id));
    v1::RemoveGeometryResponse response;
    return from_grpc(stub_->RemoveGeometry(context().get(), request, &response));
  }

  Expected<std::vector<GeometryInfo>> list_geometries() override {
    v1::ListGeometriesResponse response;
    const grpc::Status status =
        stub_->ListGeometries(context().get(), v1::ListGeometriesRequest{}, &response);
    if (!status.ok()) return from_grpc(status);
    std::vector<GeometryInfo> out;
    for (const v1::GeometryInfo& info : response.geometries())
      out.push_back(detail::from_proto(info));
    return out;
  }

  Expected<ServerInfo> server_info() override {
    v1::ServerInfo response;
    const grpc::Status status =
        stub_->GetServerInfo(context().get(), v1::GetServerInfoRequest{}, &response);
    if (!status.ok()) return from_grpc(status);
    ServerInfo info;
    info.version = response.version();
    info.build = {response.build().grpc(), response.build().dds(), response.build().metrics()};
    const v1::ServerInfo::Transports& t = response.transports();
    info.transports = {t.grpc_listen(), t.grpc_port(),  t.tls(),        t.token_required(),
                       t.dds(),         t.dds_domain(), t.dds_prefix(), t.metrics_listen(),
                       t.metrics_port()};
    const v1::ServerInfo::Limits& l = response.limits();
    info.limits = {l.max_geometries(),
                   l.max_pieces_per_geometry(),
                   l.max_vertices_per_geometry(),
                   l.max_scenes(),
                   l.max_objects_per_scene(),
                   l.max_pairs_per_scene(),
                   l.max_piece_pairs_per_scene(),
                   l.max_streams(),
                   l.max_in_flight_per_stream(),
                   l.max_concurrent_queries(),
                   l.max_message_bytes(),
                   l.workers()};
    return info;
  }

  /// CreateScene with the routing header, carrying inline every geometry of this client's that
  /// the scene uses (keyed by the id the objects name), so that the scene is whole on whichever
  /// replica the header leads to. Other geometry ids go as they are.
  Expected<SceneInfo> create_raw(Scene scene) {
    std::map<std::string, Geometry> sent;
    {
      std::lock_guard lock(registry_mutex_);
      for (SceneObject& object : scene.objects) {
        const auto ours = geometries_.originals.find(object.geometry_id);
        if (ours != geometries_.originals.end()) {
          sent.emplace(object.geometry_id, ours->second);
          continue;
        }
        const auto current = geometries_.current.find(object.geometry_id);
        if (current != geometries_.current.end()) object.geometry_id = current->second;
      }
    }
    v1::CreateSceneRequest request;
    detail::to_proto(scene, request);
    for (const auto& [key, geometry] : sent)
      detail::to_proto(geometry, (*request.mutable_geometries())[key]);
    v1::CreateSceneResponse response;
    const grpc::Status status =
        stub_->CreateScene(context(scene.requested_id).get(), request, &response);
    if (!status.ok()) return from_grpc(status);
    SceneInfo info{response.scene_id(), response.pair_count(), {}};
    std::lock_guard lock(registry_mutex_);
    for (const auto& [key, id] : response.geometry_ids()) {
      info.geometry_ids.emplace(key, id);
      if (sent.count(key)) geometries_.current[key] = id;
    }
    return info;
  }

  Expected<SceneInfo> create_scene(const Scene& scene) override {
    Scene chosen = scene;
    if (chosen.requested_id.empty()) chosen.requested_id = random_scene_id();
    Expected<SceneInfo> info = create_raw(chosen);
    if (info) remember(scenes_, info->scene_id, chosen);
    return info;
  }

  Status delete_scene(const std::string& scene_id) override {
    v1::DeleteSceneRequest request;
    request.set_scene_id(current_scene_id(scene_id));
    v1::DeleteSceneResponse response;
    const grpc::Status status =
        stub_->DeleteScene(context(request.scene_id()).get(), request, &response);
    if (status.ok()) {
      std::lock_guard lock(registry_mutex_);
      scenes_.originals.erase(scene_id);
    }
    return from_grpc(status);
  }

  Expected<std::vector<SceneSummary>> list_scenes() override {
    v1::ListScenesResponse response;
    const grpc::Status status =
        stub_->ListScenes(context().get(), v1::ListScenesRequest{}, &response);
    if (!status.ok()) return from_grpc(status);
    std::vector<SceneSummary> out;
    for (const v1::SceneSummary& scene : response.scenes()) {
      SceneSummary& summary = out.emplace_back();
      summary.scene_id = scene.scene_id();
      summary.name = scene.name();
      summary.pair_count = scene.pair_count();
      for (const v1::SceneObject& object : scene.objects())
        summary.objects.push_back(detail::from_proto(object));
    }
    return out;
  }

  Expected<Report> query(const std::string& scene_id, const std::vector<ObjectPose>& poses,
                         const QueryOptions& options) override {
    v1::QueryRequest request;
    request.set_scene_id(current_scene_id(scene_id));
    for (const ObjectPose& pose : poses) detail::to_proto(pose, *request.add_poses());
    detail::to_proto(options, *request.mutable_options());
    return run_query(scene_id, request);
  }

  Expected<Report> query_joints(const std::string& scene_id, const JointPositions& joints,
                                const QueryOptions& options,
                                const std::vector<ObjectPose>& poses) override {
    v1::QueryRequest request;
    request.set_scene_id(current_scene_id(scene_id));
    for (const ObjectPose& pose : poses) detail::to_proto(pose, *request.add_poses());
    proto::to_proto(joints, *request.mutable_joints());
    detail::to_proto(options, *request.mutable_options());
    return run_query(scene_id, request);
  }

  Expected<Report> run_query(const std::string& scene_id, v1::QueryRequest& request) {
    v1::DistanceReport response;
    Clock::time_point sent = Clock::now();
    grpc::Status status = stub_->Query(context(request.scene_id()).get(), request, &response);
    if (!status.ok() && is_scene_not_found(from_grpc(status)) && owns_scene(scene_id)) {
      // Our scene is not where the call went (a restarted server; behind a sharding proxy, a
      // replica that came back and took its share of the ring again): re-create it, ask again.
      Expected<std::string> replayed = replay_scene(scene_id, request.scene_id());
      if (!replayed) return replayed.status();
      request.set_scene_id(*replayed);
      response.Clear();
      sent = Clock::now();
      status = stub_->Query(context(request.scene_id()).get(), request, &response);
    }
    if (!status.ok()) return from_grpc(status);
    Report report = detail::from_proto(response);
    report.sent = sent;
    report.received = Clock::now();
    return report;
  }

  Expected<std::unique_ptr<Session>> open_session(const std::string& scene_id,
                                                  SessionOptions options) override {
    if (options.max_in_flight == 0) options.max_in_flight = 1;
    auto session = std::make_unique<detail::SessionImpl>(
        *this, scene_id, current_scene_id(scene_id), std::move(options));
    Status error;
    if (!session->start(error)) return error;
    return std::unique_ptr<Session>(std::move(session));
  }

  bool wait_connected(Clock::time_point deadline) override {
    const auto system_deadline =
        std::chrono::system_clock::now() +
        std::chrono::duration_cast<std::chrono::system_clock::duration>(deadline - Clock::now());
    return channel_->WaitForConnected(system_deadline);
  }

  const std::string& target() const override { return target_; }

  Expected<std::string> health(const std::string& service) override {
    // The health messages by hand (two fields in all) through the generic stub, rather than a
    // generated copy of grpc/health/v1/health.proto: HealthCheckRequest{1: service} and
    // HealthCheckResponse{1: status enum}.
    if (service.size() > 127)
      return Status::error(3 /* INVALID_ARGUMENT */, "health: the service name is too long");
    std::string request_bytes;
    if (!service.empty()) {
      request_bytes.push_back('\x0a');
      request_bytes.push_back(static_cast<char>(service.size()));
      request_bytes += service;
    }
    grpc::Slice slice(request_bytes);
    grpc::ByteBuffer request(&slice, 1);
    grpc::ByteBuffer response;
    grpc::GenericStub stub(channel_);
    auto context = this->context();
    // A completion queue drained here, not the callback API: the response and status are then
    // filled in this thread, where ThreadSanitizer sees them (a callback on gRPC's own,
    // uninstrumented thread handing them over through a promise was reported as a race).
    grpc::CompletionQueue queue;
    auto call =
        stub.PrepareUnaryCall(context.get(), "/grpc.health.v1.Health/Check", request, &queue);
    call->StartCall();
    grpc::Status status;
    call->Finish(&response, &status, &queue);  // the tag: any pointer, one call
    void* tag = nullptr;
    bool ok = false;
    const bool got = queue.Next(&tag, &ok);
    queue.Shutdown();
    for (void* rest = nullptr; queue.Next(&rest, &ok);) {
    }
    if (!got) return Status::error(13 /* INTERNAL */, "health: the call never completed");
    if (!status.ok()) return from_grpc(status);
    std::vector<grpc::Slice> slices;
    if (!response.Dump(&slices).ok())
      return Status::error(13 /* INTERNAL */, "health: unreadable response");
    std::string bytes;
    for (const grpc::Slice& part : slices)
      bytes.append(reinterpret_cast<const char*>(part.begin()), part.size());
    // Field 1, varint; absent = 0 (UNKNOWN). The enum's values are all below 128.
    int value = 0;
    if (bytes.size() >= 2 && bytes[0] == '\x08') value = static_cast<unsigned char>(bytes[1]);
    switch (value) {
      case 1:
        return std::string("SERVING");
      case 2:
        return std::string("NOT_SERVING");
      case 3:
        return std::string("SERVICE_UNKNOWN");
      default:
        return std::string("UNKNOWN");
    }
  }

  // ---- for sessions ----

  v1::DistanceService::Stub& stub() override { return *stub_; }

  std::string current_scene_id(const std::string& scene_id) const {
    return current_id(scenes_, scene_id);
  }

  std::string current_geometry_id(const std::string& geometry_id) const {
    return current_id(geometries_, geometry_id);
  }

  /// Whether this client created `scene_id` (and has not deleted it): it can re-create it.
  bool owns_scene(const std::string& scene_id) const override {
    std::lock_guard lock(registry_mutex_);
    return scenes_.originals.count(scene_id) != 0;
  }

  /// Re-creates `scene_id` (as created by this client) and the geometries it uses, after its
  /// server id `stale_server_id` stopped working. Another session on the same scene may have done
  /// it already: then its result is used. Returns the scene's server id now.
  Expected<std::string> replay_scene(const std::string& scene_id,
                                     const std::string& stale_server_id) override {
    std::lock_guard replay(replay_mutex_);
    Scene scene;
    {
      std::lock_guard lock(registry_mutex_);
      const auto found = scenes_.originals.find(scene_id);
      // Not ours (preloaded, or another client's): nothing to replay; the id is all we know.
      if (found == scenes_.originals.end()) return stale_server_id;
      if (scenes_.current[scene_id] != stale_server_id) return scenes_.current[scene_id];
      scene = found->second;
    }
    // The server may have restarted (ids forgotten) or merely dropped the connection, or a
    // sharding proxy may now route the scene to another replica; either way creating it again is
    // correct: create_raw sends this client's geometries inline (content ids: the same ids
    // again), and a server still holding the scene answers an identical request as it did the
    // first time.
    Expected<SceneInfo> created = create_raw(scene);
    if (!created) {
      // A server holding our scene answers the same request with OK (idempotent creation), so
      // ALREADY_EXISTS means another scene holds the id there: never stream to it in our stead.
      if (created.status().code == kAlreadyExists)
        return Status::error(kAlreadyExists, "the server holds another scene under the id '" +
                                                 scene.requested_id +
                                                 "': " + created.status().message);
      return created.status();
    }
    const std::string server_id = created->scene_id;
    std::lock_guard lock(registry_mutex_);
    scenes_.current[scene_id] = server_id;
    return server_id;
  }

 private:
  // What this client created of one kind, by the id the server first returned (for replay), and
  // the id each has on the server now (a replay gives new ones).
  template <class Value>
  struct Created {
    std::map<std::string, Value> originals;
    std::map<std::string, std::string> current;
  };

  template <class Value>
  void remember(Created<Value>& created, const std::string& id, const Value& value) {
    std::lock_guard lock(registry_mutex_);
    created.originals[id] = value;
    created.current[id] = id;
  }

  /// The server's id now for `id`; `id` itself when this client did not create it.
  template <class Value>
  std::string current_id(const Created<Value>& created, const std::string& id) const {
    std::lock_guard lock(registry_mutex_);
    const auto found = created.current.find(id);
    return found == created.current.end() ? id : found->second;
  }

  std::string target_;
  ClientOptions options_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::DistanceService::Stub> stub_;

  mutable std::mutex registry_mutex_;
  Created<Geometry> geometries_;  // guarded by registry_mutex_
  Created<Scene> scenes_;         // guarded by registry_mutex_
  std::mutex replay_mutex_;
};

}  // namespace

Status load_credentials(ClientOptions& options, const std::string& tls_ca_file,
                        const std::string& tls_cert_file, const std::string& tls_key_file,
                        const std::string& token_file) {
  constexpr int kInvalidArgument = 3;
  if (tls_cert_file.empty() != tls_key_file.empty())
    return Status::error(kInvalidArgument,
                         "a client certificate and its key go together (--tls-cert, --tls-key)");
  const std::pair<const std::string*, std::string*> files[] = {
      {&tls_ca_file, &options.tls_ca_pem},
      {&tls_cert_file, &options.tls_cert_pem},
      {&tls_key_file, &options.tls_key_pem},
      {&token_file, &options.token},
  };
  for (const auto& [path, field] : files) {
    if (path->empty()) continue;
    if (!read_whole_file(*path, *field))
      return Status::error(kInvalidArgument, "cannot read '" + *path + "'");
  }
  if (!token_file.empty()) {
    std::string& token = options.token;
    const auto first = token.find_first_not_of(" \t\r\n");
    if (first == std::string::npos)
      return Status::error(kInvalidArgument, "the token file '" + token_file + "' is empty");
    token = token.substr(first, token.find_last_not_of(" \t\r\n") - first + 1);
  }
  return Status{};
}

std::unique_ptr<Client> Client::connect(const std::string& target, ClientOptions options) {
  return std::make_unique<ClientImpl>(target, options);
}

}  // namespace nearpoint::client
