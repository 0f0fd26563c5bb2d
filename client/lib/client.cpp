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

#include "convert.hpp"
#include "nearpoint/model/vocabulary.hpp"
#include "nearpoint_distance.grpc.pb.h"

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

Status from_grpc(const grpc::Status& status) {
  return Status{int(status.error_code()), status.error_message()};
}

// A dropped connection, as opposed to an answer: worth reconnecting for. Behind a proxy two more
// codes mean it: CANCELLED when this client did not cancel (its own cancellations are handled
// before this is asked), and UNKNOWN ("No status received"): HAProxy ends the streams of a
// backend that died with a reset or without any gRPC status, and nearpointd itself never ends
// a call with UNKNOWN.
bool is_connection_loss(const grpc::Status& status) {
  return status.error_code() == grpc::StatusCode::UNAVAILABLE ||
         status.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED ||
         status.error_code() == grpc::StatusCode::CANCELLED ||
         status.error_code() == grpc::StatusCode::UNKNOWN;
}

// Whether `id` may travel as a metadata value (the id rule: printable ASCII without spaces). An
// id that may not is sent without the routing header; the server then refuses it by name.
bool routable(const std::string& id) {
  if (id.empty() || id.size() > 128) return false;
  return std::all_of(id.begin(), id.end(), [](char c) { return c >= 0x21 && c <= 0x7E; });
}

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

class ClientImpl;

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

// ---- Session ----

class SessionImpl final : public Session {
 public:
  SessionImpl(ClientImpl& client, std::string scene_id, std::string server_scene_id,
              SessionOptions options);
  ~SessionImpl() override;

  bool start(Status& error);
  Expected<std::uint64_t> push(const std::vector<ObjectPose>& poses, Clock::time_point deadline,
                               const QueryOptions* options) override;
  Expected<Report> next(Clock::time_point deadline) override;
  Status close(Clock::time_point deadline) override;
  std::uint64_t reconnects() const override { return reconnects_.load(); }
  Status status() const override {
    std::lock_guard lock(mutex_);
    return failure_;
  }
  std::string server_scene_id() const override {
    std::lock_guard lock(mutex_);
    return server_scene_id_;
  }

 private:
  // One gRPC call (one stream). The context outlives the stream (declared first).
  struct Call {
    grpc::ClientContext context;
    std::unique_ptr<grpc::ClientReaderWriter<v1::PoseUpdate, v1::DistanceReport>> stream;
    bool finished = false;  // Finish() was called: no more writes (guarded by write_mutex_)
  };
  struct InFlight {
    std::uint64_t sequence;
    Clock::time_point sent;
  };
  enum class State { connected, reconnecting, closing, closed, failed };

  std::shared_ptr<Call> open_call(const std::string& server_scene_id);
  void read_loop();
  // The server's answer to the update `report.sequence`, which also answers every update before
  // it that is still in flight (coalesced into it).
  void deliver(Report report);
  // To the caller (on_report or next()); the update has already left in_flight_.
  void hand_over(Report report);
  // Gives every update in flight an UNAVAILABLE error report (they will never be answered).
  // Only once the stream is over and no push can add to in_flight_ (state_ not connected).
  void fail_in_flight(const std::string& why);
  bool reconnect(const Status& cause);

  ClientImpl& client_;
  const std::string scene_id_;
  const SessionOptions options_;

  std::mutex push_mutex_;   // serialises push() and close()
  std::mutex write_mutex_;  // serialises Write / WritesDone / Finish on a call
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  State state_ = State::connected;
  bool destroying_ = false;
  std::shared_ptr<Call> call_;
  std::string server_scene_id_;
  std::deque<InFlight> in_flight_;  // sent, not yet answered
  std::size_t outstanding_ = 0;     // pushed, not yet consumed
  std::deque<Report> ready_;
  std::uint64_t next_sequence_ = 1;
  std::map<std::string, ObjectPose> latest_poses_;  // for the resync after a reconnect
  bool resync_ = false;
  bool send_thresholds_ = true;         // on the first update of each stream
  std::uint64_t resumed_sequence_ = 0;  // the first update on a replacing stream (0: none)
  Status failure_;
  std::atomic<std::uint64_t> reconnects_{0};
  std::thread reader_;
};

// ---- Client ----

class ClientImpl final : public Client {
 public:
  ClientImpl(std::string target, ClientOptions options)
      : target_(std::move(target)), options_(options) {
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
    channel_ = grpc::CreateCustomChannel(target_, channel_credentials(options), args);
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

  Expected<Report> query(const std::string& scene_id, const std::vector<ObjectPose>& poses,
                         const QueryOptions& options) override {
    v1::QueryRequest request;
    request.set_scene_id(current_scene_id(scene_id));
    for (const ObjectPose& pose : poses) detail::to_proto(pose, *request.add_poses());
    detail::to_proto(options, *request.mutable_options());
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
    auto session = std::make_unique<SessionImpl>(*this, scene_id, current_scene_id(scene_id),
                                                 std::move(options));
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

  v1::DistanceService::Stub& stub() { return *stub_; }

  std::string current_scene_id(const std::string& scene_id) const {
    return current_id(scenes_, scene_id);
  }

  std::string current_geometry_id(const std::string& geometry_id) const {
    return current_id(geometries_, geometry_id);
  }

  /// Whether this client created `scene_id` (and has not deleted it): it can re-create it.
  bool owns_scene(const std::string& scene_id) const {
    std::lock_guard lock(registry_mutex_);
    return scenes_.originals.count(scene_id) != 0;
  }

  /// Re-creates `scene_id` (as created by this client) and the geometries it uses, after its
  /// server id `stale_server_id` stopped working. Another session on the same scene may have done
  /// it already: then its result is used. Returns the scene's server id now.
  Expected<std::string> replay_scene(const std::string& scene_id,
                                     const std::string& stale_server_id) {
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

// ---- Session implementation ----

SessionImpl::SessionImpl(ClientImpl& client, std::string scene_id, std::string server_scene_id,
                         SessionOptions options)
    : client_(client),
      scene_id_(std::move(scene_id)),
      options_(std::move(options)),
      server_scene_id_(std::move(server_scene_id)) {}

std::shared_ptr<SessionImpl::Call> SessionImpl::open_call(const std::string& server_scene_id) {
  auto call = std::make_shared<Call>();
  if (routable(server_scene_id)) call->context.AddMetadata(kSceneRoutingHeader, server_scene_id);
  call->stream = client_.stub().StreamPoses(&call->context);
  return call;
}

bool SessionImpl::start(Status& /*error*/) {
  // A stream to an unreachable server fails on its first read, which the reader thread handles
  // like any dropped connection (reconnect or fail), so starting cannot fail here.
  call_ = open_call(server_scene_id_);
  reader_ = std::thread([this] { read_loop(); });
  return true;
}

SessionImpl::~SessionImpl() {
  {
    std::lock_guard lock(mutex_);
    destroying_ = true;
    if (call_ && state_ != State::closed && state_ != State::failed) call_->context.TryCancel();
  }
  changed_.notify_all();
  if (reader_.joinable()) reader_.join();
}

void SessionImpl::deliver(Report report) {
  {
    std::lock_guard lock(mutex_);
    // In order: every update up to this report's sequence number is answered now (coalesced
    // ones by this report; they will get none of their own and leave the window here).
    while (!in_flight_.empty() && in_flight_.front().sequence <= report.sequence) {
      if (in_flight_.front().sequence == report.sequence) {
        report.sent = in_flight_.front().sent;
      } else {
        --outstanding_;
      }
      in_flight_.pop_front();
    }
  }
  hand_over(std::move(report));
}

void SessionImpl::hand_over(Report report) {
  report.received = Clock::now();
  {
    std::lock_guard lock(mutex_);
    if (resumed_sequence_ != 0 && report.sequence >= resumed_sequence_) {
      report.resumed = true;  // the first report of the stream that replaced a lost one
      resumed_sequence_ = 0;
    }
    if (!options_.on_report) {
      ready_.push_back(std::move(report));
      changed_.notify_all();
      return;
    }
  }
  options_.on_report(report);
  std::lock_guard lock(mutex_);
  --outstanding_;
  changed_.notify_all();
}

void SessionImpl::fail_in_flight(const std::string& why) {
  std::deque<InFlight> lost;
  {
    std::lock_guard lock(mutex_);
    lost.swap(in_flight_);
  }
  // Each failed update is handed over directly: putting it back into in_flight_ for deliver()
  // to pop once let an update pushed meanwhile sit in front of it, unanswered for good, while
  // the window count went below zero (every later push then waited for a full window).
  for (const InFlight& update : lost) {
    Report report;
    report.sequence = update.sequence;
    report.sent = update.sent;
    report.error = Status::error(kUnavailable, why);
    hand_over(std::move(report));
  }
}

bool SessionImpl::reconnect(const Status& cause) {
  const Clock::time_point give_up = Clock::now() + options_.reconnect_timeout;
  auto backoff = options_.initial_backoff;
  std::string stale;
  {
    std::lock_guard lock(mutex_);
    stale = server_scene_id_;
  }
  Status last = Status::error(kUnavailable, "no attempt made");
  for (;;) {
    {
      std::lock_guard lock(mutex_);
      if (destroying_) return false;
    }
    const Clock::time_point attempt_end = std::min(give_up, Clock::now() + backoff);
    if (client_.wait_connected(attempt_end)) {
      Expected<std::string> server_id = client_.replay_scene(scene_id_, stale);
      if (server_id) {
        auto call = open_call(*server_id);
        const ResumeEvent event{reconnects_.load() + 1, cause, *server_id};
        // Before the new stream is published: no update goes out on it before the caller knows.
        if (options_.on_resumed) options_.on_resumed(event);
        std::lock_guard lock(mutex_);
        call_ = std::move(call);
        server_scene_id_ = *server_id;
        resync_ = true;
        send_thresholds_ = true;
        state_ = State::connected;
        reconnects_.fetch_add(1);
        changed_.notify_all();
        return true;
      }
      last = server_id.status();
      // An answer is final; a lost connection is not (through a proxy also CANCELLED or
      // UNKNOWN: the replica went away during the call, e.g. while it drained).
      if (!is_connection_loss(grpc::Status(grpc::StatusCode(last.code), last.message))) break;
    }
    if (Clock::now() >= give_up) break;
    std::unique_lock lock(mutex_);
    changed_.wait_until(lock, std::min(give_up, Clock::now() + backoff),
                        [&] { return destroying_; });
    backoff = std::min(options_.max_backoff, backoff * 2);
  }
  std::lock_guard lock(mutex_);
  failure_ =
      last.code == kUnavailable || last.ok()
          ? Status::error(kUnavailable, "could not reconnect to " + client_.target() + " within " +
                                            std::to_string(options_.reconnect_timeout.count()) +
                                            " ms: " + last.message)
          : Status::error(last.code, "replaying the scene after a reconnect: " + last.message);
  state_ = State::failed;
  changed_.notify_all();
  return false;
}

void SessionImpl::read_loop() {
  for (;;) {
    std::shared_ptr<Call> call;
    {
      std::lock_guard lock(mutex_);
      call = call_;
    }
    v1::DistanceReport message;
    bool scene_missing = false;
    while (call->stream->Read(&message)) {
      Report report = detail::from_proto(message);
      // The server does not hold our scene (restarted; or a sharding proxy routed the stream to
      // a replica that does not have it): the stream can never work, so replace it.
      const bool missing = report.error.code == kNotFound && report.error_field == "scene_id";
      const bool replaced = missing && options_.reconnect && client_.owns_scene(scene_id_);
      if (replaced && !scene_missing) {
        scene_missing = true;
        {
          // Before the caller sees the report: a push made after it waits for the new stream
          // instead of going out on this one.
          std::lock_guard lock(mutex_);
          if (state_ == State::connected) state_ = State::reconnecting;
        }
        call->context.TryCancel();
      }
      if (replaced)
        // Lost to routing like an update in flight when a replica dies, and answered the same
        // way (UNAVAILABLE: never evaluated, push it again), whichever replica the proxy chose
        // while its ring changed; the server's words stay in the message.
        report.error =
            Status::error(kUnavailable,
                          "not evaluated: the replica that answered does not hold the scene; the "
                          "session re-creates it and resumes the stream (" +
                              report.error.describe() + ")");
      deliver(std::move(report));
    }
    grpc::Status status;
    {
      std::lock_guard write(write_mutex_);
      call->finished = true;
      status = call->stream->Finish();
    }
    if (scene_missing)
      status = grpc::Status(grpc::StatusCode::NOT_FOUND,
                            "the server that answered does not hold the scene (a restarted "
                            "server, or a proxy routing it to another replica); re-creating it");
    bool closing = false;
    {
      std::lock_guard lock(mutex_);
      if (destroying_) {
        state_ = State::closed;
        changed_.notify_all();
        return;
      }
      closing = state_ == State::closing;
      if (closing && status.ok()) {
        state_ = State::closed;
        changed_.notify_all();
      } else if (state_ == State::connected) {
        // The stream is over: from here a push waits (for the next stream, or to be refused)
        // instead of adding to in_flight_ an update that this stream will neither send nor
        // answer, while the updates in flight on it are answered below.
        state_ = State::reconnecting;
      }
    }
    if (closing && status.ok()) {
      fail_in_flight("the stream ended before this update was answered");
      return;
    }
    const bool lost = scene_missing || is_connection_loss(status);
    // A drain answers every update the server read, so the ones still in flight were never
    // evaluated; after a crash nobody knows. The caller needs to tell the two apart.
    if (is_server_drain(from_grpc(status)))
      fail_in_flight("not evaluated: " + client_.target() +
                     " is draining (shutting down) and did not read this update; push it again (" +
                     status.error_message() + ")");
    else
      fail_in_flight(
          lost ? "connection to " + client_.target() +
                     " lost before this update was answered; it may or may not have been "
                     "evaluated (" +
                     from_grpc(status).describe() + ")"
               : "the stream failed before this update was answered: " + status.error_message());
    if (closing || !lost || !options_.reconnect) {
      std::lock_guard lock(mutex_);
      failure_ = status.ok() ? Status::error(kUnavailable, "the server ended the stream")
                             : from_grpc(status);
      state_ = State::failed;
      changed_.notify_all();
      return;
    }
    {
      std::lock_guard lock(mutex_);
      state_ = State::reconnecting;
    }
    if (!reconnect(from_grpc(status))) return;
  }
}

Expected<std::uint64_t> SessionImpl::push(const std::vector<ObjectPose>& poses,
                                          Clock::time_point deadline, const QueryOptions* options) {
  std::lock_guard pushing(push_mutex_);
  std::unique_lock lock(mutex_);
  const bool ready = changed_.wait_until(lock, deadline, [&] {
    return state_ == State::failed || state_ == State::closing || state_ == State::closed ||
           (state_ == State::connected && outstanding_ < options_.max_in_flight);
  });
  if (state_ == State::failed) return failure_;
  if (state_ == State::closing || state_ == State::closed)
    return Status::error(9, "the session is closed");  // FAILED_PRECONDITION
  if (!ready)
    return Status::error(kDeadlineExceeded, state_ == State::reconnecting
                                                ? "still reconnecting"
                                                : "the in-flight window stayed full");
  v1::PoseUpdate update;
  const std::uint64_t sequence = next_sequence_++;
  update.set_scene_id(server_scene_id_);
  update.set_sequence(sequence);
  update.set_flow_control(options_.coalesce ? v1::FLOW_CONTROL_COALESCE : v1::FLOW_CONTROL_BLOCK);
  detail::to_proto(options != nullptr ? *options : options_.options, *update.mutable_options());
  if (send_thresholds_) {
    for (const Threshold& threshold : options_.thresholds)
      detail::to_proto(threshold, *update.add_thresholds());
    send_thresholds_ = false;
  }
  for (const ObjectPose& pose : poses) {
    detail::to_proto(pose, *update.add_poses());
    latest_poses_[pose.object_id] = pose;
  }
  if (resync_) {
    // A new stream starts from the scene's initial poses: send every pose pushed before.
    for (const auto& [id, pose] : latest_poses_) {
      // An init-capture, not the binding itself: clang 14 (the fuzz and sanitizer builds)
      // cannot capture structured bindings.
      const bool listed =
          std::any_of(poses.begin(), poses.end(),
                      [&object_id = id](const ObjectPose& p) { return p.object_id == object_id; });
      if (!listed) detail::to_proto(pose, *update.add_poses());
    }
    resync_ = false;
    resumed_sequence_ = sequence;
  }
  std::shared_ptr<Call> call = call_;
  in_flight_.push_back({sequence, Clock::now()});
  ++outstanding_;
  lock.unlock();
  std::lock_guard write(write_mutex_);
  // A failed write means the stream is gone; the reader thread sees that too and answers this
  // update with an UNAVAILABLE error report.
  if (!call->finished) call->stream->Write(update);
  return sequence;
}

Expected<Report> SessionImpl::next(Clock::time_point deadline) {
  std::unique_lock lock(mutex_);
  changed_.wait_until(lock, deadline, [&] {
    return !ready_.empty() || state_ == State::failed || state_ == State::closed;
  });
  if (!ready_.empty()) {
    Report report = std::move(ready_.front());
    ready_.pop_front();
    --outstanding_;
    changed_.notify_all();
    return report;
  }
  if (state_ == State::failed) return failure_;
  if (state_ == State::closed)
    return Status::error(kOutOfRange, "the session is closed and every report was taken");
  return Status::error(kDeadlineExceeded, "no report arrived in time");
}

Status SessionImpl::close(Clock::time_point deadline) {
  std::lock_guard pushing(push_mutex_);
  std::shared_ptr<Call> call;
  {
    std::unique_lock lock(mutex_);
    changed_.wait_until(lock, deadline, [&] { return state_ != State::reconnecting; });
    if (state_ == State::failed) return failure_;
    if (state_ == State::closed) return {};
    if (state_ == State::reconnecting)
      return Status::error(kDeadlineExceeded, "still reconnecting");
    state_ = State::closing;
    call = call_;
  }
  {
    std::lock_guard write(write_mutex_);
    if (!call->finished) call->stream->WritesDone();
  }
  std::unique_lock lock(mutex_);
  if (!changed_.wait_until(lock, deadline,
                           [&] { return state_ == State::closed || state_ == State::failed; })) {
    call->context.TryCancel();
    changed_.wait(lock, [&] { return state_ == State::closed || state_ == State::failed; });
  }
  return state_ == State::failed ? failure_ : Status{};
}

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
