// SPDX-License-Identifier: Apache-2.0
// nearpoint::client — the C++ client of nearpointd (gRPC, nearpoint.v1.DistanceService).
//
//   auto client = nearpoint::client::Client::connect("127.0.0.1:50051");
//   auto box = client->register_geometry(nearpoint::client::box_geometry("box", {0.5, 0.5, 0.5}));
//   Scene scene;  scene.objects = {{"a", box->geometry_id}, {"b", box->geometry_id}};
//   auto created = client->create_scene(scene);
//   auto session = client->open_session(created->scene_id);
//   (*session)->push({{"a", Eigen::Isometry3d(Eigen::Translation3d(3, 0, 0))}});
//   auto report = (*session)->next(std::chrono::steady_clock::now() + std::chrono::seconds(5));
//
// Errors are values: every call returns a Status or an Expected<T> carrying the gRPC status code
// (by name) and the server's message, which names the offending field. Nothing throws.
//
// Geometries and scenes are described with the scene API's plain structs (model/scene_types.hpp:
// the same structs the server and the file formats use, Eigen vectors inside); poses at this API
// are Eigen::Isometry3d or an Eigen::Quaterniond with an Eigen::Vector3d.
//
// Thread safety: a Client may be used from any number of threads at once. A Session may be pushed
// to from any thread (pushes are serialised, and numbered in the order they are serialised), and
// its reports consumed by one thread at a time through next(), or by the callback, which runs on
// the session's own reader thread.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include <Eigen/Geometry>

#include "nearpoint/model/scene_types.hpp"
#include "nearpoint/model/vocabulary.hpp"

namespace nearpoint::client {

using Clock = std::chrono::steady_clock;

/// OK, or a failure: the gRPC status code and the message (from the server, or from the client
/// when it never reached one).
struct Status {
  /// grpc::StatusCode value: 0 OK, 3 INVALID_ARGUMENT, 4 DEADLINE_EXCEEDED, 5 NOT_FOUND,
  /// 6 ALREADY_EXISTS, 8 RESOURCE_EXHAUSTED, 11 OUT_OF_RANGE, 14 UNAVAILABLE, …
  int code = 0;
  std::string message;

  bool ok() const { return code == 0; }
  /// "OK", "INVALID_ARGUMENT", "UNAVAILABLE", … ("CODE_<n>" outside gRPC's codes).
  std::string code_name() const;
  /// "CODE_NAME: message".
  std::string describe() const;

  static Status error(int code, std::string message) { return {code, std::move(message)}; }
};

// The codes callers test for, by name from model/vocabulary.hpp's status table.
inline constexpr int kDeadlineExceeded = model::status_code_number("DEADLINE_EXCEEDED");
inline constexpr int kNotFound = model::status_code_number("NOT_FOUND");
inline constexpr int kAlreadyExists = model::status_code_number("ALREADY_EXISTS");
inline constexpr int kOutOfRange = model::status_code_number("OUT_OF_RANGE");
inline constexpr int kUnavailable = model::status_code_number("UNAVAILABLE");
static_assert(kDeadlineExceeded > 0 && kNotFound > 0 && kAlreadyExists > 0 && kOutOfRange > 0 &&
              kUnavailable > 0);

/// True for the end of a stream by a draining server (SIGTERM: UNAVAILABLE, "draining"), and for
/// the error reports of the updates it had not read: those were never evaluated and can be sent
/// again as they are. Any other UNAVAILABLE is a lost connection: an update without a report
/// may or may not have been evaluated.
bool is_server_drain(const Status& status);

/// A value or the Status that prevented it.
template <class T>
class [[nodiscard]] Expected {
 public:
  Expected(T value) : state_(std::move(value)) {}
  Expected(Status status) : state_(std::move(status)) {}
  bool ok() const { return state_.index() == 0; }
  explicit operator bool() const { return ok(); }
  T& value() { return std::get<0>(state_); }
  const T& value() const { return std::get<0>(state_); }
  T& operator*() { return value(); }
  const T& operator*() const { return value(); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  /// The failure; an OK Status when ok().
  Status status() const { return ok() ? Status{} : std::get<1>(state_); }

 private:
  std::variant<T, Status> state_;
};

// The request side: the scene API's plain structs (see model/scene_types.hpp and the .proto files
// for every field's unit and frame).
using Geometry = model::GeometryInput;
using Piece = model::PieceInput;
using GeometryInfo = model::GeometryInfo;
using Scene = model::SceneInput;
using SceneObject = model::ObjectInput;
using PairSelection = model::PairSelectionInput;
using QueryOptions = model::QueryOptionsInput;
using PenetrationMode = model::PenetrationMode;
using ReportMode = model::ReportMode;
using ReportCounts = model::ReportCounts;
/// A watched distance of a session (see nearpoint.v1.Threshold): ENTER below `distance`, EXIT
/// above `distance + hysteresis`, on a pair (object_a, object_b), an object's pairs (object_a),
/// or every pair; `groups` filters by SceneObject.group.
using Threshold = model::ThresholdInput;
using SceneInfo = model::SceneInfo;
/// A scene's robot (nearpoint.v1.Robot; robots::Robot::to_scene or `nearpoint scene create
/// robot.urdf` build one), and joint positions by name for Session::push_joints.
using Robot = model::RobotInput;
using JointPositions = model::JointPositionsInput;
using JointDerivative = model::JointDerivative;
using JointLimitViolation = model::JointLimitViolation;

/// One live scene on the server (nearpoint.v1.SceneSummary): its objects as created (body names
/// are not kept by the server and come back empty).
struct SceneSummary {
  std::string scene_id;
  std::string name;
  std::size_t pair_count = 0;
  std::vector<SceneObject> objects;
};

/// Conversions between Eigen poses and the plain structs' (w, x, y, z) + translation.
model::PoseInput to_pose_input(const Eigen::Isometry3d& pose);
model::PoseInput to_pose_input(const Eigen::Quaterniond& rotation,
                               const Eigen::Vector3d& translation);
/// One polytope piece (the convex hull of `vertices`, geometry frame).
Piece polytope_piece(std::vector<Eigen::Vector3d> vertices,
                     const Eigen::Isometry3d& offset = Eigen::Isometry3d::Identity());

/// The pose of one scene object: geometry frame → world frame.
struct ObjectPose {
  std::string object_id;
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  ObjectPose() = default;
  ObjectPose(std::string id, const Eigen::Isometry3d& pose);
  ObjectPose(std::string id, const Eigen::Quaterniond& q, const Eigen::Vector3d& t)
      : object_id(std::move(id)), rotation(q), translation(t) {}
};

// ---- answers ----

using PairStatus = model::PairStatus;
/// The status as the CLI prints it: separated, intersecting, touching, beyond_cutoff, …
/// (model/vocabulary.hpp). "In contact" is intersecting or touching: model::in_contact(status).
const char* to_string(PairStatus status);
using DepthTermination = model::DepthTermination;
/// closed_form, tolerance, iteration_limit or degenerate ("" for unspecified or unknown).
const char* to_string(DepthTermination termination);
/// The mode's name as the CLI spells it: all, within-cutoff, nearest, global, changed.
const char* to_string(ReportMode mode);

/// One object pair's answer (see nearpoint.v1.PairDistance): the engine's answer as the model
/// holds it (world frame, metres; near points with options.near_points, d⁻ with penetration =
/// bound, the signed distance and the penetration depth with their certified intervals with
/// penetration = depth, the gradient with options.gradient, each behind its has_ flag), the pair
/// named by the objects' ids.
struct PairDistance : model::PairAnswer {
  std::string object_a, object_b;
  /// For engine_error: the server's reason.
  std::string message;
  /// Robot scenes with gradients: ∂distance/∂q of each joint coordinate that moves one of the
  /// two objects (others: 0).
  std::vector<JointDerivative> joint_gradient;
};

using Crossing = model::Crossing;
/// "enter" or "exit".
const char* to_string(Crossing crossing);

/// A watched pair crossed a threshold (see nearpoint.v1.ThresholdEvent).
struct ThresholdEvent {
  /// Threshold::name and its index in SessionOptions::thresholds.
  std::string threshold;
  std::uint32_t threshold_index = 0;
  std::string object_a, object_b;
  Crossing crossing = Crossing::enter;
  /// The distance that crossed, metres (0 when intersecting or touching, the signed distance
  /// with penetration = depth; beyond the cutoff, its lower bound).
  double distance = 0;
  /// The update whose poses crossed (an absorbed one's when the server coalesced updates).
  std::uint64_t sequence = 0;
};

/// Server-side timing, microseconds (see nearpoint.v1.ReportTiming).
using ReportTiming = model::ReportTiming;

/// The answer to one update or query.
struct Report {
  std::uint64_t sequence = 0;
  /// Not OK when the update was rejected (the server's code and "field: message") or never
  /// answered (UNAVAILABLE: the connection dropped while it was in flight). Then `pairs` is empty.
  Status error;
  std::string error_field;
  std::vector<PairDistance> pairs;
  ReportTiming timing;
  std::uint32_t coalesced_updates = 0;
  std::uint64_t coalesced_from_sequence = 0;
  /// Pairs evaluated, pruned by the broad phase, skipped as unmoved (see nearpoint.v1).
  ReportCounts counts;
  /// Which pairs `pairs` holds: all selected ones, or those within the cutoff.
  ReportMode mode = ReportMode::all_pairs;
  /// Threshold crossings (sessions with SessionOptions::thresholds), oldest update first.
  std::vector<ThresholdEvent> events;
  /// Robot scenes: the joints outside their limits at this update's positions.
  std::vector<JointLimitViolation> joint_limit_violations;
  /// Client side: when the update was handed to the transport and when the report arrived.
  Clock::time_point sent, received;
  /// The first report of a stream that replaced a lost one (see ResumeEvent): the scene was
  /// re-created from this client's copy (perhaps on another replica), the server's warm-start
  /// caches restarted cold and REPORT_MODE_CHANGED's baseline restarted (this report carries
  /// every pair).
  bool resumed = false;
};

/// The routing header of every call about one scene (nearpoint.v1.DistanceService, "Routing
/// key"): a proxy that hashes it sends all of them to the replica that holds the scene.
inline constexpr const char* kSceneRoutingHeader = "x-nearpoint-scene";

/// A session replaced its lost stream: the connection dropped, or through a sharding proxy the
/// scene's replica died (its streams end UNAVAILABLE or CANCELLED) or the proxy routed the scene
/// to a replica that does not hold it (NOT_FOUND). Every update in flight then got an
/// UNAVAILABLE error report; the session re-registered the scene's geometries and re-created the
/// scene (idempotently), opened a new stream and re-sends the latest poses with the next push.
struct ResumeEvent {
  /// Session::reconnects() after this one.
  std::uint64_t reconnects = 0;
  /// How the old stream ended.
  Status cause;
  /// The scene's id on the server now.
  std::string server_scene_id;
};

// ---- streaming ----

struct SessionOptions {
  /// Updates pushed but not yet consumed (answered and taken by next() or the callback). push()
  /// blocks while this many are outstanding: back-pressure, so memory stays bounded.
  std::size_t max_in_flight = 32;
  /// Sent with every update: overrides of the scene's default options.
  QueryOptions options;
  /// Ask the server to merge updates that arrive while it is busy (FLOW_CONTROL_COALESCE).
  bool coalesce = false;
  /// Stream on StreamPoseBatches (nearpoint.v1): push_batch() sends its pose sets in one message
  /// and reports that are ready together arrive in one, which saves gRPC's cost per message for
  /// clients that send at a high rate. Reports, sequence numbers and flow control are the same.
  /// Off: StreamPoses, where push_batch() sends one message per pose set. A server older than
  /// StreamPoseBatches fails the session UNIMPLEMENTED.
  bool batched = false;
  /// Watched thresholds: sent with the stream's first update (and again on the first update
  /// after a reconnect: the new stream starts with every watch outside, so a pair already inside
  /// gets a second ENTER).
  std::vector<Threshold> thresholds;
  /// When set, every report is handed here, on the session's reader thread, in order; next() is
  /// then not used. When empty, reports queue for next().
  std::function<void(const Report&)> on_report;
  /// On a dropped connection (UNAVAILABLE): reconnect, replay the scene's geometry registration
  /// and creation, and go on. Updates in flight at the drop get an UNAVAILABLE error report; when
  /// the server drained (is_server_drain), that report says the update was never evaluated.
  bool reconnect = true;
  /// Called on the session's reader thread each time a lost stream was replaced, before any
  /// update goes out on the new one. The first report after it has Report::resumed set.
  std::function<void(const ResumeEvent&)> on_resumed;
  /// Give up (the session fails with UNAVAILABLE) after this long without a working connection.
  std::chrono::milliseconds reconnect_timeout{30000};
  std::chrono::milliseconds initial_backoff{50};
  std::chrono::milliseconds max_backoff{2000};
};

/// One pose stream on one scene. Create with Client::open_session.
class Session {
 public:
  virtual ~Session() = default;

  /// Sends one update: the poses that changed (objects not listed keep their last pose). Blocks
  /// while `max_in_flight` updates are outstanding or while reconnecting, until `deadline`.
  /// Returns the update's sequence number (1, 2, …), or DEADLINE_EXCEEDED, or the session's
  /// failure. Per-update option overrides replace the session's options when given.
  virtual Expected<std::uint64_t> push(const std::vector<ObjectPose>& poses,
                                       Clock::time_point deadline = Clock::time_point::max(),
                                       const QueryOptions* options = nullptr) = 0;

  /// Sends one update per pose set, in order, each as push() would (its own sequence number and
  /// report), in one message when SessionOptions::batched. Blocks until the whole batch fits in
  /// `max_in_flight` (a batch larger than the window waits for an empty one). Returns the first
  /// update's sequence number; the others follow it consecutively.
  virtual Expected<std::uint64_t> push_batch(const std::vector<std::vector<ObjectPose>>& pose_sets,
                                             Clock::time_point deadline = Clock::time_point::max(),
                                             const QueryOptions* options = nullptr) = 0;

  /// Robot scenes: sends joint positions by name (joints not named keep theirs) instead of the
  /// poses of the objects the robot carries; otherwise as push().
  virtual Expected<std::uint64_t> push_joints(const JointPositions& joints,
                                              Clock::time_point deadline = Clock::time_point::max(),
                                              const QueryOptions* options = nullptr) = 0;

  /// The next report, in sequence order. DEADLINE_EXCEEDED when none arrives by `deadline`;
  /// OUT_OF_RANGE once the session is closed and every report has been taken; the session's
  /// failure after its reports are drained.
  virtual Expected<Report> next(Clock::time_point deadline) = 0;

  /// Ends the stream after every pushed update is answered (waits until `deadline`; then
  /// cancels). Reports not yet taken stay available to next(). OK, or the stream's failure.
  virtual Status close(Clock::time_point deadline = Clock::time_point::max()) = 0;

  /// How many times the session reconnected after a dropped connection.
  virtual std::uint64_t reconnects() const = 0;
  /// OK while the session works; its permanent failure otherwise.
  virtual Status status() const = 0;
  /// The scene's id on the server now (it changes when a reconnect re-created the scene).
  virtual std::string server_scene_id() const = 0;
};

struct ClientOptions {
  /// Deadline of each unary call (register, create, query, …).
  std::chrono::milliseconds call_timeout{10000};
  /// Largest message sent or received: by default the server's (--max-message-bytes), so that
  /// every report it can send arrives.
  int max_message_bytes = static_cast<int>(model::kDefaultMaxMessageBytes);
  /// TLS (nearpointd --tls-cert): on when `tls` is set or any PEM below is given. The server's
  /// certificate is checked against `tls_ca_pem`, or the system's roots when it is empty.
  bool tls = false;
  std::string tls_ca_pem;
  /// The name the server's certificate must carry, when it is not the target's host (a probe
  /// dialling 127.0.0.1 inside a pod whose certificate names the Service). Empty: the host.
  std::string tls_server_name;
  /// Mutual TLS (nearpointd --tls-client-ca): this client's certificate chain and key, PEM.
  std::string tls_cert_pem;
  std::string tls_key_pem;
  /// Bearer token (nearpointd --token-file), sent as `authorization: Bearer <token>` on every
  /// call. A token turns TLS on: it is never sent in the clear.
  std::string token;

  bool uses_tls() const {
    return tls || !tls_ca_pem.empty() || !tls_cert_pem.empty() || !tls_key_pem.empty() ||
           !token.empty();
  }
};

/// Fills `options`' TLS and token fields from files (an empty path leaves its field alone); the
/// token file's surrounding whitespace is dropped. Not OK (INVALID_ARGUMENT, naming the file)
/// when a file cannot be read, and when only one of the client certificate and key is given.
Status load_credentials(ClientOptions& options, const std::string& tls_ca_file,
                        const std::string& tls_cert_file, const std::string& tls_key_file,
                        const std::string& token_file);

/// What a nearpointd is (nearpoint.v1.ServerInfo): its release, build, transports and limits.
struct ServerInfo {
  std::string version;  ///< "1.0.0", as `nearpointd --version` prints it
  struct Build {
    bool grpc = false, dds = false, metrics = false;  ///< compiled in
  } build;
  struct Transports {
    std::string grpc_listen;  ///< --listen as given
    std::uint32_t grpc_port = 0;
    std::string tls;  ///< "off", "on" or "mutual"
    bool token_required = false;
    bool dds = false;  ///< serving pose streams over DDS
    std::uint32_t dds_domain = 0;
    std::string dds_prefix;
    std::string metrics_listen;  ///< empty: none
    std::uint32_t metrics_port = 0;
  } transports;
  struct Limits {
    std::uint64_t max_geometries = 0, max_pieces_per_geometry = 0, max_vertices_per_geometry = 0,
                  max_scenes = 0, max_objects_per_scene = 0, max_pairs_per_scene = 0,
                  max_piece_pairs_per_scene = 0, max_streams = 0, max_in_flight_per_stream = 0,
                  max_concurrent_queries = 0, max_message_bytes = 0;
    std::uint32_t workers = 0;
  } limits;
};

class Client {
 public:
  /// A client of the server at `target` ("host:port"). The connection is made lazily, on the
  /// first call; an unreachable server shows as UNAVAILABLE there.
  static std::unique_ptr<Client> connect(const std::string& target, ClientOptions options = {});
  virtual ~Client() = default;

  /// Registers an immutable geometry. The client remembers it, so that create_scene can send it
  /// with the scene (to the scene's replica behind a sharding proxy) and sessions can replay it
  /// on a restarted server. The server's id is derived from the content: registering the same
  /// geometry again gives the same id.
  virtual Expected<GeometryInfo> register_geometry(const Geometry& geometry) = 0;
  virtual Status remove_geometry(const std::string& geometry_id) = 0;
  virtual Expected<std::vector<GeometryInfo>> list_geometries() = 0;
  /// The server's version, build options, transports and limits (GetServerInfo).
  virtual Expected<ServerInfo> server_info() = 0;

  /// Creates a scene whose objects name geometries by the ids register_geometry returned (or ids
  /// of geometries registered by others). Remembered for replay, like geometries. The scene's id
  /// is `scene.requested_id`, or, when that is empty, one the client picks ("s-" and 16 random
  /// hex digits), so that this call already carries the routing header (kSceneRoutingHeader)
  /// like every later call about the scene. The geometries this client registered and the scene
  /// uses are sent inline with it (nearpoint.v1.CreateSceneRequest.geometries), so that the scene
  /// is whole on whichever replica holds it.
  virtual Expected<SceneInfo> create_scene(const Scene& scene) = 0;
  virtual Status delete_scene(const std::string& scene_id) = 0;
  /// The server's live scenes, ordered by id (behind a sharding proxy: one replica's).
  virtual Expected<std::vector<SceneSummary>> list_scenes() = 0;

  /// One-shot distances at the given poses (objects not listed are at their initial pose). For a
  /// scene this client created, NOT_FOUND for the scene (a restarted server, or a sharding proxy
  /// that now routes it to another replica) re-creates the scene and asks once more.
  virtual Expected<Report> query(const std::string& scene_id, const std::vector<ObjectPose>& poses,
                                 const QueryOptions& options = {}) = 0;

  /// query() for a robot scene: the robot at `joints` (joints not named at their reference
  /// positions; a base pose if given), other objects at `poses` or their initial poses.
  virtual Expected<Report> query_joints(const std::string& scene_id, const JointPositions& joints,
                                        const QueryOptions& options = {},
                                        const std::vector<ObjectPose>& poses = {}) = 0;

  /// A pose stream on `scene_id` (a scene created by this client, or any scene on the server —
  /// only this client's scenes can be replayed after a restart).
  virtual Expected<std::unique_ptr<Session>> open_session(const std::string& scene_id,
                                                          SessionOptions options = {}) = 0;

  /// Waits until the channel is connected (true) or `deadline` passes (false).
  virtual bool wait_connected(Clock::time_point deadline) = 0;
  /// The gRPC health protocol (grpc.health.v1.Health/Check) for `service` ("" = the server as a
  /// whole; "nearpoint.v1.DistanceService"): "SERVING", "NOT_SERVING", "UNKNOWN" or
  /// "SERVICE_UNKNOWN"; or the call's failure (UNAVAILABLE: no server, NOT_FOUND: no such
  /// service). nearpointd answers it without a token.
  virtual Expected<std::string> health(const std::string& service = {}) = 0;
  virtual const std::string& target() const = 0;
};

}  // namespace nearpoint::client
