#include "grpc_services.hpp"

#include <deque>
#include <memory>
#include <optional>
#include <variant>
#include <vector>

#include "nearpoint/server/log.hpp"
#include "proto_convert.hpp"
#include "tsan_handoff.hpp"

namespace nearpoint::server {
namespace {

constexpr const char* kShuttingDown = "server is shutting down";

/// Finishes a unary call begun with `calls.begin_unary()`.
void finish(grpc::ServerUnaryReactor* reactor, CallRegistry& calls, const grpc::Status& status) {
  reactor->Finish(status);
  calls.end_unary();
}

/// Finishes a unary call with `error` and logs it (one line per rejected request).
void reject(grpc::ServerUnaryReactor* reactor, CallRegistry& calls,
            grpc::CallbackServerContext* context, const char* rpc, const Error& error) {
  log_warn("request_rejected")
      .kv("rpc", rpc)
      .kv("peer", context->peer())
      .kv("code", to_string(error.code))
      .kv("field", error.field)
      .kv("message", error.message);
  finish(reactor, calls, to_grpc_status(error));
}

/// A report larger than the server sends cannot go out (gRPC would fail the call with "Sent
/// message larger than max", and a stream's update would get no answer at all). Scenes and
/// requests whose reports could be that large are refused up front (SceneService), so this is
/// the backstop: the error that replaces such a report, or nullopt when it fits.
std::optional<Error> check_report_fits(const v1::DistanceReport& report, std::size_t limit) {
  const std::size_t size = report.ByteSizeLong();
  if (size <= limit) return std::nullopt;
  return resource_exhausted(
      "",
      text("the report of sequence ", report.sequence(), " takes ", size, " bytes, more than the ",
           limit, " bytes the server sends in one message (--max-message-bytes)"));
}

/// The reactor of a unary call refused because the server is draining.
grpc::ServerUnaryReactor* refuse(grpc::ServerUnaryReactor* reactor) {
  reactor->Finish(grpc::Status(grpc::StatusCode::UNAVAILABLE, kShuttingDown));
  return reactor;
}

// ---- StreamPoses ----

/// One pose stream. Every accepted update yields exactly one report, in order: updates are
/// evaluated one at a time (the stream's caches are its single mutable state) and reports are
/// written in the order their updates were read, the error reports of rejected updates included.
///
/// Flow control (bounded, see nearpoint.v1.FlowControl), with N = max_in_flight_per_stream:
///  - BLOCK: the next read starts only while fewer than N updates are in flight (read and not
///    yet answered: queued, evaluating, or reports queued or being written). A client that
///    outpaces the server, or does not read its reports, then waits in HTTP/2 flow control.
///  - COALESCE: reads continue; an update read while another is still queued replaces it (its
///    poses already include the older one's) and its report counts the merged updates. A new
///    evaluation starts only when no report is waiting behind the one being written, so reports
///    stay fresh. Reads stop only if N reports (error reports of rejected updates) are waiting.
///    An error report queued behind an update keeps its place: a newer update does not merge
///    across it.
///
/// Locking: `mutex_` guards every member below it. gRPC never runs a reaction inline inside
/// StartRead/StartWrite/Finish (their tags are not inlineable), so calling them under the lock
/// is safe; OnDone takes the lock once before deleting, so whoever called Finish has let go.
class PoseStreamReactor final : public grpc::ServerBidiReactor<v1::PoseUpdate, v1::DistanceReport>,
                                public DrainableStream {
 public:
  PoseStreamReactor(DistanceServiceImpl& service, grpc::CallbackServerContext* context,
                    std::uint64_t number)
      : service_(service), number_(number), peer_(context->peer()) {
    const auto constructed = handoff_.construction();  // see tsan_handoff.hpp
    max_in_flight_ = std::max<std::size_t>(1, service.scenes().limits().max_in_flight_per_stream);
    Expected<std::unique_ptr<PoseStream>> stream = service.scenes().open_stream();
    if (!stream) {
      log_warn("stream_refused")
          .kv("stream", number_)
          .kv("peer", peer_)
          .kv("message", stream.error().message);
      finished_ = true;
      Finish(to_grpc_status(stream.error()));
      return;
    }
    stream_ = std::move(stream.value());
    // gRPC holds back OnDone until this constructor has returned, so a Drain() arriving from
    // the registry before the lock below is harmless.
    registered_ = service.calls().add(this);
    if (!registered_) {
      finished_ = true;
      Finish(grpc::Status(grpc::StatusCode::UNAVAILABLE, kShuttingDown));
      return;
    }
    log_info("stream_open").kv("stream", number_).kv("peer", peer_);
    std::lock_guard lock(mutex_);
    Pump();
  }

  void OnReadDone(bool ok) override {
    const auto reaction = handoff_.reaction();
    std::lock_guard lock(mutex_);
    reading_ = false;
    // A read that completes after the call was finished (drained while it was outstanding) is
    // not accepted: it could no longer be answered.
    if (finished_) return;
    if (!ok) {
      reads_done_ = true;  // the client half-closed (or the call ended)
      Pump();
      return;
    }
    ++updates_read_;
    const PoseUpdateInput update = to_input(incoming_);
    Expected<PreparedUpdate> prepared = stream_->prepare(update, Clock::now());
    if (!prepared) {
      ++updates_rejected_;
      const Error& error = prepared.error();
      log_warn("update_rejected")
          .kv("stream", number_)
          .kv("sequence", update.sequence)
          .kv("code", to_string(error.code))
          .kv("field", error.field)
          .kv("message", error.message);
      // Queued behind the updates read before it, so that its report does not overtake
      // theirs: reports leave in the order their updates were read.
      v1::DistanceReport report;
      to_proto(error, update.sequence, report);
      pending_.emplace_back(std::move(report));
    } else if (stream_->flow_control() == FlowControl::coalesce && !pending_.empty() &&
               std::holds_alternative<PreparedUpdate>(pending_.back())) {
      PreparedUpdate& older = std::get<PreparedUpdate>(pending_.back());
      PoseStream::coalesce(prepared.value(), older);
      older = std::move(prepared.value());
      ++updates_coalesced_;
    } else {
      pending_.push_back(std::move(prepared.value()));
    }
    Pump();
  }

  void OnWriteDone(bool ok) override {
    const auto reaction = handoff_.reaction();
    std::lock_guard lock(mutex_);
    writing_ = false;
    if (ok) {
      ++reports_written_;
    } else {
      broken_ = true;  // the call is over (client gone, deadline, cancel): stop writing
    }
    Pump();
  }

  void OnCancel() override {
    const auto reaction = handoff_.reaction();
    std::lock_guard lock(mutex_);
    broken_ = true;
    Pump();
  }

  void OnDone() override {
    handoff_.done();
    { std::lock_guard lock(mutex_); }  // whoever called Finish has released the lock
    if (registered_) {
      service_.calls().remove(this);
      log_info("stream_closed")
          .kv("stream", number_)
          .kv("updates", updates_read_)
          .kv("rejected", updates_rejected_)
          .kv("coalesced", updates_coalesced_)
          .kv("reports", reports_written_)
          .kv("status", finish_reason_);
    }
    delete this;
  }

  void Drain() override {
    std::lock_guard lock(mutex_);
    draining_ = true;
    Pump();
  }

 private:
  std::size_t in_flight() const {
    return pending_.size() + (evaluating_ ? 1 : 0) + outgoing_.size() + (writing_ ? 1 : 0);
  }

  /// Starts whatever can start now: an evaluation, a write, a read, or the end of the call.
  /// Requires `mutex_`.
  void Pump() {
    if (finished_) return;
    const bool coalescing = stream_->flow_control() == FlowControl::coalesce;

    // Error reports at the head of the queue go out once everything read before them has been
    // answered (no evaluation in progress).
    while (!broken_ && !evaluating_ && !pending_.empty() &&
           std::holds_alternative<v1::DistanceReport>(pending_.front())) {
      outgoing_.push_back(std::move(std::get<v1::DistanceReport>(pending_.front())));
      pending_.pop_front();
    }
    if (!broken_ && !evaluating_ && !pending_.empty() && (!coalescing || outgoing_.empty())) {
      PreparedUpdate next = std::move(std::get<PreparedUpdate>(pending_.front()));
      pending_.pop_front();
      evaluating_ = true;
      stream_->evaluate(std::move(next), [this](Report report) { OnReport(std::move(report)); });
    }
    if (!broken_ && !writing_ && !outgoing_.empty()) {
      current_write_ = std::move(outgoing_.front());
      outgoing_.pop_front();
      writing_ = true;
      StartWrite(&current_write_);
    }

    if (broken_) {
      // Nothing more can be written. Wait for the evaluation and the write in progress (they
      // reference this reactor), then end.
      pending_.clear();
      outgoing_.clear();
      if (!evaluating_ && !writing_)
        End(grpc::Status(grpc::StatusCode::CANCELLED, "cancelled"), "cancelled");
      return;
    }
    const bool idle = pending_.empty() && !evaluating_ && outgoing_.empty() && !writing_;
    if (idle && draining_) {
      // "draining" tells a client this is a drain, not a crash: nothing it sent was lost
      // unanswered, and the count says exactly which updates were read (the first N it sent).
      End(grpc::Status(grpc::StatusCode::UNAVAILABLE,
                       text("server is draining (shutting down): all ", updates_read_,
                            " updates read on this stream were answered; later ones were not "
                            "read")),
          "drained");
      return;
    }
    if (idle && reads_done_) {
      End(grpc::Status::OK, "ok");
      return;
    }
    // Coalescing keeps at most one update queued (newer ones merge into it), so what can pile up
    // is reports: written ones and error reports waiting their turn.
    const bool room = coalescing ? outgoing_.size() + pending_.size() < max_in_flight_ + 1
                                 : in_flight() < max_in_flight_;
    if (!reading_ && !reads_done_ && !draining_ && room) {
      reading_ = true;
      StartRead(&incoming_);
    }
  }

  void End(const grpc::Status& status, const char* reason) {
    finished_ = true;
    finish_reason_ = reason;
    Finish(status);
  }

  /// The evaluation's report, on a pool thread.
  void OnReport(Report report) {
    v1::DistanceReport message;
    to_proto(report, message);  // outside the lock: it may be large
    if (auto error = check_report_fits(message, service_.max_message_bytes())) {
      log_error("report_too_large").kv("stream", number_).kv("message", error->message);
      to_proto(*error, report.sequence, message);  // the update is answered all the same
    }
    std::lock_guard lock(mutex_);
    evaluating_ = false;
    if (!broken_) outgoing_.push_back(std::move(message));
    Pump();
  }

  ReactorHandoff handoff_;
  DistanceServiceImpl& service_;
  const std::uint64_t number_;
  const std::string peer_;
  std::size_t max_in_flight_ = 1;
  std::unique_ptr<PoseStream> stream_;
  bool registered_ = false;

  std::mutex mutex_;
  v1::PoseUpdate incoming_;
  v1::DistanceReport current_write_;
  /// Read and not yet answered, in read order: updates to evaluate, and the error reports of
  /// rejected updates waiting for their turn.
  std::deque<std::variant<PreparedUpdate, v1::DistanceReport>> pending_;
  std::deque<v1::DistanceReport> outgoing_;
  bool reading_ = false;
  bool writing_ = false;
  bool evaluating_ = false;
  bool reads_done_ = false;
  bool broken_ = false;
  bool draining_ = false;
  bool finished_ = false;
  const char* finish_reason_ = "";
  std::uint64_t updates_read_ = 0;
  std::uint64_t updates_rejected_ = 0;
  std::uint64_t updates_coalesced_ = 0;
  std::uint64_t reports_written_ = 0;
};

// ---- Echo ----

/// Writes back every message it reads, one at a time (the transport floor for benchmarks).
class EchoReactor final : public grpc::ServerBidiReactor<v1::EchoMessage, v1::EchoMessage>,
                          public DrainableStream {
 public:
  explicit EchoReactor(CallRegistry& registry) : registry_(registry) {
    const auto constructed = handoff_.construction();  // see tsan_handoff.hpp
    registered_ = registry_.add(this);  // not under mutex_: drain_all locks them the other way
    std::lock_guard lock(mutex_);
    if (!registered_) End(grpc::Status(grpc::StatusCode::UNAVAILABLE, "server is shutting down"));
    if (finished_) return;  // refused, or drained already
    reading_ = true;
    StartRead(&message_);
  }

  void OnReadDone(bool ok) override {
    const auto reaction = handoff_.reaction();
    std::lock_guard lock(mutex_);
    reading_ = false;
    if (!ok) return End(grpc::Status::OK);
    if (draining_) return End(grpc::Status(grpc::StatusCode::UNAVAILABLE, "shutting down"));
    writing_ = true;
    StartWrite(&message_);
  }

  void OnWriteDone(bool ok) override {
    const auto reaction = handoff_.reaction();
    std::lock_guard lock(mutex_);
    writing_ = false;
    if (!ok) return End(grpc::Status(grpc::StatusCode::CANCELLED, "cancelled"));
    if (draining_) return End(grpc::Status(grpc::StatusCode::UNAVAILABLE, "shutting down"));
    reading_ = true;
    StartRead(&message_);
  }

  void Drain() override {
    std::lock_guard lock(mutex_);
    draining_ = true;
    if (!writing_) End(grpc::Status(grpc::StatusCode::UNAVAILABLE, "shutting down"));
  }

  void OnDone() override {
    handoff_.done();
    { std::lock_guard lock(mutex_); }
    if (registered_) registry_.remove(this);
    delete this;
  }

 private:
  void End(const grpc::Status& status) {
    if (finished_) return;
    finished_ = true;
    Finish(status);
  }

  ReactorHandoff handoff_;
  CallRegistry& registry_;
  bool registered_ = false;
  std::mutex mutex_;
  v1::EchoMessage message_;
  bool reading_ = false;
  bool writing_ = false;
  bool draining_ = false;
  bool finished_ = false;
};

}  // namespace

// ---- CallRegistry ----

bool CallRegistry::add(DrainableStream* stream) {
  std::lock_guard lock(mutex_);
  if (draining_) return false;
  streams_.insert(stream);
  return true;
}

void CallRegistry::remove(DrainableStream* stream) {
  std::lock_guard lock(mutex_);
  streams_.erase(stream);
  if (streams_.empty() && unary_calls_ == 0) idle_.notify_all();
}

bool CallRegistry::begin_unary() {
  std::lock_guard lock(mutex_);
  if (draining_) return false;
  ++unary_calls_;
  return true;
}

void CallRegistry::end_unary() {
  std::lock_guard lock(mutex_);
  --unary_calls_;
  if (streams_.empty() && unary_calls_ == 0) idle_.notify_all();
}

void CallRegistry::drain_all() {
  // Under the registry lock: a stream removes itself (in OnDone, before deleting itself) under
  // the same lock, so every pointer here is alive while we call it.
  std::lock_guard lock(mutex_);
  draining_ = true;
  for (DrainableStream* stream : streams_) stream->Drain();
}

bool CallRegistry::wait_idle(std::chrono::steady_clock::time_point deadline) {
  std::unique_lock lock(mutex_);
  return idle_.wait_until(lock, deadline, [this] { return streams_.empty() && unary_calls_ == 0; });
}

// ---- DistanceService ----

grpc::ServerUnaryReactor* DistanceServiceImpl::RegisterGeometry(
    grpc::CallbackServerContext* context, const v1::RegisterGeometryRequest* request,
    v1::RegisterGeometryResponse* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (!calls_.begin_unary()) return refuse(reactor);
  Expected<GeometryInfo> info = scenes_.register_geometry(to_input(request->geometry()));
  if (!info) {
    reject(reactor, calls_, context, "RegisterGeometry", info.error());
    return reactor;
  }
  to_proto(info.value(), *response->mutable_geometry());
  log_info("geometry_registered")
      .kv("geometry", info->geometry_id)
      .kv("name", info->name)
      .kv("pieces", info->piece_count)
      .kv("vertices", info->vertex_count)
      .kv("bounding_radius", info->bounding_radius);
  finish(reactor, calls_, grpc::Status::OK);
  return reactor;
}

grpc::ServerUnaryReactor* DistanceServiceImpl::RemoveGeometry(
    grpc::CallbackServerContext* context, const v1::RemoveGeometryRequest* request,
    v1::RemoveGeometryResponse*) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (!calls_.begin_unary()) return refuse(reactor);
  if (Outcome removed = scenes_.remove_geometry(request->geometry_id()); !removed) {
    reject(reactor, calls_, context, "RemoveGeometry", removed.error());
    return reactor;
  }
  log_info("geometry_removed").kv("geometry", request->geometry_id());
  finish(reactor, calls_, grpc::Status::OK);
  return reactor;
}

grpc::ServerUnaryReactor* DistanceServiceImpl::ListGeometries(
    grpc::CallbackServerContext* context, const v1::ListGeometriesRequest*,
    v1::ListGeometriesResponse* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (!calls_.begin_unary()) return refuse(reactor);
  for (const GeometryInfo& info : scenes_.list_geometries())
    to_proto(info, *response->add_geometries());
  finish(reactor, calls_, grpc::Status::OK);
  return reactor;
}

grpc::ServerUnaryReactor* DistanceServiceImpl::CreateScene(grpc::CallbackServerContext* context,
                                                           const v1::CreateSceneRequest* request,
                                                           v1::CreateSceneResponse* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (!calls_.begin_unary()) return refuse(reactor);
  Expected<SceneInfo> info = scenes_.create_scene(to_input(*request));
  if (!info) {
    reject(reactor, calls_, context, "CreateScene", info.error());
    return reactor;
  }
  response->set_scene_id(info->scene_id);
  response->set_pair_count(std::uint32_t(info->pair_count));
  log_info("scene_created")
      .kv("scene", info->scene_id)
      .kv("name", request->name())
      .kv("objects", request->objects_size())
      .kv("pairs", info->pair_count);
  finish(reactor, calls_, grpc::Status::OK);
  return reactor;
}

grpc::ServerUnaryReactor* DistanceServiceImpl::DeleteScene(grpc::CallbackServerContext* context,
                                                           const v1::DeleteSceneRequest* request,
                                                           v1::DeleteSceneResponse*) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (!calls_.begin_unary()) return refuse(reactor);
  if (Outcome deleted = scenes_.delete_scene(request->scene_id()); !deleted) {
    reject(reactor, calls_, context, "DeleteScene", deleted.error());
    return reactor;
  }
  log_info("scene_deleted").kv("scene", request->scene_id());
  finish(reactor, calls_, grpc::Status::OK);
  return reactor;
}

grpc::ServerUnaryReactor* DistanceServiceImpl::Query(grpc::CallbackServerContext* context,
                                                     const v1::QueryRequest* request,
                                                     v1::DistanceReport* response) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  if (!calls_.begin_unary()) return refuse(reactor);
  // The geometry runs on the pool; the reactor is finished from there.
  Outcome started =
      scenes_.query(to_input(*request), Clock::now(), [this, reactor, response](Report report) {
        to_proto(report, *response);
        if (auto error = check_report_fits(*response, max_message_bytes_)) {
          log_error("report_too_large").kv("rpc", "Query").kv("message", error->message);
          response->Clear();
          finish(reactor, calls_, to_grpc_status(*error));
          return;
        }
        finish(reactor, calls_, grpc::Status::OK);
      });
  if (!started) reject(reactor, calls_, context, "Query", started.error());
  return reactor;
}

grpc::ServerBidiReactor<v1::PoseUpdate, v1::DistanceReport>* DistanceServiceImpl::StreamPoses(
    grpc::CallbackServerContext* context) {
  return new PoseStreamReactor(*this, context, next_stream_number_.fetch_add(1));
}

grpc::ServerBidiReactor<v1::EchoMessage, v1::EchoMessage>* DiagnosticsServiceImpl::Echo(
    grpc::CallbackServerContext*) {
  return new EchoReactor(calls_);
}

}  // namespace nearpoint::server
