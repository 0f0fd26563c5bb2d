// SPDX-License-Identifier: Apache-2.0
#include "grpc_services.hpp"

#include <deque>
#include <memory>
#include <optional>
#include <variant>
#include <vector>

#include <google/protobuf/arena.h>
#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/wire_format_lite.h>

#include "metrics.hpp"
#include "nearpoint/server/log.hpp"
#include "pose_update_wire.hpp"
#include "proto_convert.hpp"
#include "report_wire.hpp"
#include "tsan_handoff.hpp"
#include "wire_parse.hpp"

namespace nearpoint::server {
namespace {

/// The routing header a sharding proxy hashes (nearpoint.v1.DistanceService, "Routing key"),
/// first 128 bytes (an id is at most that); "" when the call carries none. Logged, so that an
/// operator can see which scenes a replica was sent.
std::string routing_key(const grpc::ServerContextBase* context) {
  const auto& metadata = context->client_metadata();
  const auto found = metadata.find("x-nearpoint-scene");
  if (found == metadata.end()) return {};
  return std::string(found->second.data(), std::min<std::size_t>(found->second.size(), 128));
}

/// One unary call whose request we parsed (see DistanceServiceImpl). Its typed handler fills
/// `response` and ends the call exactly once, with finish() or reject(), possibly later and on
/// another thread (Query ends from the pool); the call object lives until then.
template <class Request, class Response>
class UnaryCall {
 public:
  UnaryCall(std::shared_ptr<UnaryCallHandle> handle, CallRegistry& calls, const char* rpc)
      : context(handle->context()), rpc(rpc), handle_(std::move(handle)), calls_(calls) {}

  /// Ends the call: `status`, with the serialised response when OK.
  void finish(grpc::Status status) {
    grpc::ByteBuffer response_bytes;
    if (status.ok()) {
      bool own_buffer = false;
      status =
          grpc::SerializationTraits<Response>::Serialize(response, &response_bytes, &own_buffer);
    }
    metrics::record_grpc_status(rpc, status.error_code());
    handle_->finish(status, &response_bytes);
    calls_.end_unary();
  }
  /// Ends the call with `error` and logs it (one line per rejected request).
  void reject(const Error& error) {
    log_warn("request_rejected")
        .kv("rpc", rpc)
        .kv("peer", context->peer())
        .kv("code", to_string(error.code))
        .kv("field", error.field)
        .kv("message", error.message);
    finish(to_grpc_status(error));
  }

  grpc::GenericServerContext* const context;
  const char* const rpc;
  Request request;
  Response response;

 private:
  const std::shared_ptr<UnaryCallHandle> handle_;
  CallRegistry& calls_;
};

/// A report larger than the server sends cannot go out (gRPC would fail the call with "Sent
/// message larger than max", and a stream's update would get no answer at all). Scenes and
/// requests whose reports could be that large are refused up front (SceneService), so this is
/// the backstop: the error that replaces such a report, or nullopt when it fits.
std::optional<Error> check_report_size(std::uint64_t sequence, std::size_t size,
                                       std::size_t limit) {
  if (size <= limit) return std::nullopt;
  return resource_exhausted(
      "", text("the report of sequence ", sequence, " takes ", size, " bytes, more than the ",
               limit, " bytes the server sends in one message (--max-message-bytes)"));
}
std::optional<Error> check_report_fits(const v1::DistanceReport& report, std::size_t limit) {
  return check_report_size(report.sequence(), report.ByteSizeLong(), limit);
}

/// A unary method: refuse while draining, parse the request (INVALID_ARGUMENT with the reason
/// when it does not parse), then hand the call to `handler`, which ends it.
template <class Request, class Response, class Handler>
UnaryHandler unary_method(CallRegistry& calls, const char* rpc, Handler handler) {
  return [&calls, rpc, handler](const grpc::ByteBuffer& request_bytes,
                                const std::shared_ptr<UnaryCallHandle>& handle) {
    if (!calls.begin_unary()) {
      handle->finish(grpc::Status(grpc::StatusCode::UNAVAILABLE, kShuttingDown), nullptr);
      return;
    }
    auto call = std::make_shared<UnaryCall<Request, Response>>(handle, calls, rpc);
    if (std::string why = parse_message(request_bytes, call->request); !why.empty()) {
      call->reject(invalid_argument("", text("request ", why)));
      return;
    }
    handler(call);
  };
}

// ---- StreamPoses and StreamPoseBatches ----

/// Which of the two pose-stream RPCs a reactor serves. They differ only in framing: a batched
/// stream reads a PoseUpdateBatch per message and writes a DistanceReportBatch per message; every
/// update in it goes through exactly what a lone update on StreamPoses goes through.
enum class StreamFraming { one_per_message, batched };

/// The most a report's key and length add to it inside a DistanceReportBatch: one byte of key
/// (field 1, length-delimited) and a varint of at most 5 bytes (the length is below 2^32).
constexpr std::size_t kBatchEntryOverhead = 6;

/// How long a batched stream's oldest waiting report may wait for the stream's evaluations in
/// progress before the reports are written: the DDS bridge's kReportHold, so that a stream kept
/// busy by a steady flow of updates still sees its reports every few milliseconds.
constexpr auto kReportHold = std::chrono::milliseconds(2);

/// A stream's parse arena: its first block (kParseBlockBytes at `first_block`) is the stream's.
constexpr std::size_t kParseBlockBytes = 16384;
google::protobuf::ArenaOptions parse_arena_options(char* first_block) {
  google::protobuf::ArenaOptions options;
  options.initial_block = first_block;
  options.initial_block_size = kParseBlockBytes;
  return options;
}

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
/// Batched streams (StreamPoseBatches) count updates, not messages: a batch is read whole and
/// each of its updates is accepted as if it had arrived alone (BLOCK may then hold up to N − 1
/// plus one batch's updates). Its reports are kept already framed as DistanceReportBatch
/// entries, so that a write is the reports waiting at that moment, concatenated up to the
/// message size limit. They are written together once the stream has nothing more to evaluate,
/// when the oldest has waited kReportHold, or when they fill a message (HoldReports), as the DDS
/// bridge writes a batched stream's reports. Every write costs gRPC's framing and a sendmsg
/// whatever it carries: writing a batch's first report alone, the moment it is ready, would make
/// two writes of every batch.
/// Nothing waits for a batch to fill: a stream with nothing left to evaluate writes at once.
///
/// Locking: `mutex_` guards every member below it. A reaction never runs inline inside
/// StartRead/StartWrite/Finish (it comes from the completion queue), so calling them under the
/// lock is safe; OnDone takes the lock once before deleting, so whoever called Finish has let go.
class PoseStreamReactor final : public AsyncReactor, public DrainableStream {
 public:
  PoseStreamReactor(AsyncCall& call, DistanceServiceImpl& service, std::uint64_t number,
                    StreamFraming framing)
      : AsyncReactor(call),
        service_(service),
        context_(context()),
        number_(number),
        peer_(context_->peer()),
        batched_(framing == StreamFraming::batched),
        rpc_(batched_ ? "StreamPoseBatches" : "StreamPoses"),
        report_limit_(batched_ ? service.max_message_bytes() - kBatchEntryOverhead
                               : service.max_message_bytes()) {
    const auto constructed = handoff_.construction();  // see tsan_handoff.hpp
    max_in_flight_ = std::max<std::size_t>(1, service.scenes().limits().max_in_flight_per_stream);
    Expected<std::unique_ptr<PoseStream>> stream = service.scenes().open_stream();
    if (!stream) {
      log_warn("stream_refused")
          .kv("stream", number_)
          .kv("peer", peer_)
          .kv("message", stream.error().message);
      finished_ = true;
      const grpc::Status refused = to_grpc_status(stream.error());
      metrics::record_grpc_status(rpc_, refused.error_code());
      Finish(refused);
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
    log_info("stream_open")
        .kv("stream", number_)
        .kv("rpc", rpc_)
        .kv("peer", peer_)
        .kv("routing_key", routing_key(context_));
    std::unique_lock lock(mutex_);
    Pump(lock);
  }

  void OnReadDone(bool ok) override {
    const auto reaction = handoff_.reaction();
    std::unique_lock lock(mutex_);
    reading_ = false;
    // A read that completes after the call was finished (drained while it was outstanding) is
    // not accepted: it could no longer be answered.
    if (finished_) return;
    if (!ok) {
      reads_done_ = true;  // the client half-closed (or the call ended)
      Pump(lock);
      return;
    }
    // The message's bytes in one piece (a zero-length payload may have no buffer: then empty).
    grpc::Slice bytes;
    const bool whole = !incoming_.Valid() || incoming_.DumpToSingleSlice(&bytes).ok();
    // Most messages carry only a stream's updates (scene id, sequence, poses, options, flow
    // control): read straight into the model's inputs (pose_update_wire.hpp). Anything else is
    // parsed by protobuf below.
    if (whole && read_plain_pose_updates({bytes.begin(), bytes.size()}, batched_, plain_updates_)) {
      ++messages_read_;
      for (const model::PoseUpdateInput& each : plain_updates_) {
        Accept(each);
        if (batched_) StartEvaluation();  // as below
      }
      Pump(lock);
      return;
    }
    // The previous message is done with (Accept converted it): its arena space is reused.
    parse_arena_.Reset();
    v1::PoseUpdate* update = nullptr;
    v1::PoseUpdateBatch* batch = nullptr;
    if (batched_)
      batch = google::protobuf::Arena::CreateMessage<v1::PoseUpdateBatch>(&parse_arena_);
    else
      update = google::protobuf::Arena::CreateMessage<v1::PoseUpdate>(&parse_arena_);
    google::protobuf::Message& parsed =
        batched_ ? static_cast<google::protobuf::Message&>(*batch) : *update;
    std::string why =
        whole ? parse_message(bytes, parsed) : "the message's bytes could not be read";
    if (!why.empty()) {
      // Not an update we can answer or refuse by sequence number: stop reading, answer what was
      // read before it, then end the stream INVALID_ARGUMENT (never OK after input we could not
      // read).
      unparsable_ = text("message ", messages_read_ + 1, " of the stream (after sequence ",
                         last_sequence_, ") ", why, "; the ", updates_read_,
                         " updates before it were answered and nothing after it was read");
      log_warn("stream_message_unparsable")
          .kv("stream", number_)
          .kv("peer", peer_)
          .kv("message", unparsable_);
      reads_done_ = true;
      Pump(lock);
      return;
    }
    ++messages_read_;
    if (batched_) {
      // One by one, as if each had arrived alone: the first may start evaluating before the
      // next is accepted, so that COALESCE merges only what arrives while the stream is busy.
      // (Not Pump(): no read may start before the whole batch counts as in flight.)
      for (const v1::PoseUpdate& each : batch->updates()) {
        Accept(to_input(each));
        StartEvaluation();
      }
    } else {
      Accept(to_input(*update));
    }
    Pump(lock);
  }

  void OnWriteDone(bool ok) override {
    const auto reaction = handoff_.reaction();
    std::unique_lock lock(mutex_);
    writing_ = false;
    if (ok) {
      reports_written_ += reports_in_write_;
      ++messages_written_;
    } else {
      broken_ = true;  // the call is over (client gone, deadline, cancel): stop writing
    }
    reports_in_write_ = 0;
    Pump(lock);
  }

  void OnCancel() override {
    const auto reaction = handoff_.reaction();
    std::unique_lock lock(mutex_);
    broken_ = true;
    Pump(lock);
  }

  void OnDone() override {
    handoff_.done();
    { std::lock_guard lock(mutex_); }  // whoever called Finish has released the lock
    if (registered_) {
      service_.calls().remove(this);
      // A client that vanishes (SIGKILL, lost network) ends the reads just like a half-close
      // (OnReadDone(false)), so an idle stream went on to Finish(OK) and was logged "ok". Only
      // now is it known whether the status reached the client: gRPC marks the call cancelled
      // when it did not.
      if (context_->IsCancelled()) finish_reason_ = "cancelled";
      log_info("stream_closed")
          .kv("stream", number_)
          .kv("updates", updates_read_)
          .kv("messages", messages_read_)
          .kv("rejected", updates_rejected_)
          .kv("coalesced", updates_coalesced_)
          .kv("reports", reports_written_)
          .kv("messages_written", messages_written_)
          .kv("status", finish_reason_);
    }
    delete this;
  }

  void Drain() override {
    std::unique_lock lock(mutex_);
    draining_ = true;
    Pump(lock);
  }

 private:
  /// One update read off the stream: validated (PoseStream::prepare) and queued behind what was
  /// read before it, its error report if rejected, or merged into the queued update under
  /// COALESCE. Requires `mutex_`.
  void Accept(const model::PoseUpdateInput& update) {
    ++updates_read_;
    last_sequence_ = update.sequence;
    Expected<PreparedUpdate> prepared = stream_->prepare(update, Clock::now());
    metrics::record_update(prepared ? nullptr : &prepared.error());
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
      pending_.emplace_back(Serialise(report));
    } else if (stream_->flow_control() == model::FlowControl::coalesce && !pending_.empty() &&
               std::holds_alternative<PreparedUpdate>(pending_.back())) {
      PreparedUpdate& older = std::get<PreparedUpdate>(pending_.back());
      PoseStream::coalesce(prepared.value(), older);
      older = std::move(prepared.value());
      ++updates_coalesced_;
    } else {
      pending_.push_back(std::move(prepared.value()));
    }
  }

  std::size_t in_flight() const {
    return pending_.size() + (evaluating_ ? 1 : 0) + outgoing_.size() + reports_in_write_;
  }

  /// Pump(), then the evaluations it handed to this thread (PoseStream::evaluates_inline):
  /// each runs with `lock` released, its report queued under it, and Pump() again, until no
  /// inline evaluation is due.
  void Pump(std::unique_lock<std::mutex>& lock) {
    Pump();
    while (inline_evaluation_) {
      std::shared_ptr<EvaluationJob> job = std::move(inline_evaluation_);
      lock.unlock();
      grpc::Slice message = ToSlice(stream_->run_evaluation(*job));
      job.reset();
      lock.lock();
      Answered(std::move(message));
      Pump();
    }
  }

  /// Starts whatever can start now: an evaluation, a write, a read, or the end of the call.
  /// Requires `mutex_`. An evaluation small enough to run on this thread is left in
  /// `inline_evaluation_` for Pump(lock) to run once the lock is released.
  void Pump() {
    if (finished_) return;
    const bool coalescing = stream_->flow_control() == model::FlowControl::coalesce;
    StartEvaluation();
    if (!broken_ && !writing_ && !outgoing_.empty() && !HoldReports()) StartNextWrite();

    if (broken_) {
      // Nothing more can be written. Wait for the evaluation and the write in progress (they
      // reference this reactor), then end.
      pending_.clear();
      outgoing_.clear();
      outgoing_bytes_ = 0;
      if (!evaluating_ && !writing_)
        End(grpc::Status(grpc::StatusCode::CANCELLED, "cancelled"), "cancelled");
      return;
    }
    const bool idle = pending_.empty() && !evaluating_ && outgoing_.empty() && !writing_;
    if (idle && draining_) {
      // "draining" tells a client this is a drain, not a crash: nothing it sent was lost
      // unanswered, and the count says exactly which updates were read (the first N it sent).
      End(grpc::Status(grpc::StatusCode::UNAVAILABLE,
                       text(kDraining, ": all ", updates_read_,
                            " updates read on this stream were answered; later ones were not "
                            "read")),
          "drained");
      return;
    }
    if (idle && !unparsable_.empty()) {
      End(grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, unparsable_), "invalid_argument");
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

  /// The part of Pump() that moves the queue along: error reports at the head of the queue go out
  /// once everything read before them has been answered (no evaluation in progress), and the
  /// next update starts evaluating when none is (under COALESCE only when no report is waiting).
  /// Requires `mutex_`.
  void StartEvaluation() {
    while (!broken_ && !evaluating_ && !pending_.empty() &&
           std::holds_alternative<grpc::Slice>(pending_.front())) {
      Queue(std::move(std::get<grpc::Slice>(pending_.front())));
      pending_.pop_front();
    }
    const bool coalescing = stream_->flow_control() == model::FlowControl::coalesce;
    if (!broken_ && !evaluating_ && !pending_.empty() && (!coalescing || outgoing_.empty())) {
      PreparedUpdate next = std::move(std::get<PreparedUpdate>(pending_.front()));
      pending_.pop_front();
      evaluating_ = true;
      if (stream_->evaluates_inline())
        inline_evaluation_ = stream_->take_evaluation(std::move(next));
      else
        stream_->evaluate(std::move(next), [this](Report report) { OnReport(std::move(report)); });
    }
  }

  void End(const grpc::Status& status, const char* reason) {
    finished_ = true;
    finish_reason_ = reason;
    metrics::record_grpc_status(rpc_, status.error_code());
    Finish(status);
  }

  /// Writes the oldest report, or on a batched stream every report ready now that fits in one
  /// message (at least one: each fits alone, see report_limit_). Requires `mutex_`.
  void StartNextWrite() {
    write_slices_.clear();
    std::size_t bytes = 0;
    while (!outgoing_.empty() &&
           (write_slices_.empty() ||
            (batched_ && bytes + outgoing_.front().size() <= service_.max_message_bytes()))) {
      bytes += outgoing_.front().size();
      write_slices_.push_back(std::move(outgoing_.front()));
      outgoing_.pop_front();
    }
    outgoing_bytes_ -= bytes;
    reports_in_write_ = write_slices_.size();
    grpc::ByteBuffer message(write_slices_.data(), write_slices_.size());  // refs the slices
    current_write_.Swap(&message);
    write_slices_.clear();
    writing_ = true;
    StartWrite(&current_write_);
  }

  /// The report on the wire, encoded outside the lock (it may be large) straight from `report`
  /// by the stream's encoder (report_wire.hpp: protobuf's bytes without building the message;
  /// after the first report it allocates nothing but the slice). Evaluations of one stream never
  /// overlap, so neither do calls of this.
  grpc::Slice ToSlice(const Report& report) {
    const std::size_t size = encoder_.measure(report);
    if (auto error = check_report_size(report.sequence, size, report_limit_)) {
      log_error("report_too_large").kv("stream", number_).kv("message", error->message);
      v1::DistanceReport answer;  // the update is answered all the same
      to_proto(*error, report.sequence, answer);
      return Serialise(answer);
    }
    return Framed(size, [&](std::uint8_t* out) { encoder_.write(report, out); });
  }

  /// A message built as protobuf (error reports), on the wire as Framed() puts it.
  grpc::Slice Serialise(const v1::DistanceReport& message) const {
    const std::size_t size = message.ByteSizeLong();
    return Framed(size, [&](std::uint8_t* out) { message.SerializeWithCachedSizesToArray(out); });
  }

  /// A message of `size` bytes, written by `write`, on the wire. Below --max-message-bytes, so
  /// well below 2 GB. On a batched stream preceded by its key and length as an entry of
  /// DistanceReportBatch.reports, so that a write is the entries' concatenation (a valid
  /// DistanceReportBatch) without a copy.
  template <class Write>
  grpc::Slice Framed(std::size_t size, Write&& write) const {
    using google::protobuf::internal::WireFormatLite;
    using google::protobuf::io::CodedOutputStream;
    constexpr std::uint32_t kEntryKey = WireFormatLite::MakeTag(
        v1::DistanceReportBatch::kReportsFieldNumber, WireFormatLite::WIRETYPE_LENGTH_DELIMITED);
    const std::size_t prefix = batched_ ? CodedOutputStream::VarintSize32(kEntryKey) +
                                              CodedOutputStream::VarintSize64(size)
                                        : 0;
    grpc::Slice slice(prefix + size);
    std::uint8_t* out = const_cast<std::uint8_t*>(slice.begin());
    if (batched_) {
      out = CodedOutputStream::WriteVarint32ToArray(kEntryKey, out);
      out = CodedOutputStream::WriteVarint64ToArray(size, out);
    }
    write(out);
    return slice;
  }

  /// The evaluation under way is over; its report goes out unless nothing can be written any
  /// more. Requires `mutex_`.
  void Answered(grpc::Slice message) {
    evaluating_ = false;
    if (!broken_) Queue(std::move(message));
  }

  /// Puts a report in line for writing. Requires `mutex_`.
  void Queue(grpc::Slice message) {
    if (outgoing_.empty()) oldest_outgoing_ = Clock::now();
    outgoing_bytes_ += message.size();
    outgoing_.push_back(std::move(message));
  }

  /// Whether a batched stream's waiting reports wait for the evaluation in progress: while one
  /// runs (evaluations start as soon as an update is queued, so none running means none due),
  /// the reports do not fill a message yet, and the oldest has waited less than kReportHold.
  /// COALESCE starts no evaluation while a report waits, so it never holds. Requires `mutex_`.
  bool HoldReports() const {
    return batched_ && evaluating_ && outgoing_bytes_ < service_.max_message_bytes() &&
           Clock::now() - oldest_outgoing_ < kReportHold;
  }

  /// The evaluation's report, on a pool thread.
  void OnReport(Report report) {
    grpc::Slice message = ToSlice(report);
    std::unique_lock lock(mutex_);
    Answered(std::move(message));
    Pump(lock);
  }

  ReactorHandoff handoff_;
  DistanceServiceImpl& service_;
  grpc::GenericServerContext* const context_;  // valid until OnDone returns
  const std::uint64_t number_;
  const std::string peer_;
  const bool batched_;
  const char* const rpc_;  // for metrics and logs
  /// The largest report sent: --max-message-bytes, less a batch entry's framing when batched.
  const std::size_t report_limit_;
  std::size_t max_in_flight_ = 1;
  std::unique_ptr<PoseStream> stream_;
  bool registered_ = false;

  std::mutex mutex_;
  grpc::ByteBuffer incoming_;
  /// Each message is parsed on this arena, reset before the next: parsed into a reused message
  /// instead, every pose's Pose, Vector3 and Quaternion were allocated and freed again per update
  /// (proto3's Clear deletes sub-messages), 30 of each for a cell45 update. The first block is
  /// the reactor's own, so that a message that fits in it allocates nothing.
  std::unique_ptr<char[]> parse_block_ = std::make_unique_for_overwrite<char[]>(kParseBlockBytes);
  google::protobuf::Arena parse_arena_{parse_arena_options(parse_block_.get())};
  /// The updates of the last message read_plain_pose_updates read, reused from message to message.
  std::vector<model::PoseUpdateInput> plain_updates_;
  grpc::ByteBuffer current_write_;
  /// The reports in current_write_ (0 while none is under way); the slices it is built from.
  std::size_t reports_in_write_ = 0;
  std::vector<grpc::Slice> write_slices_;
  /// Read and not yet answered, in read order: updates to evaluate, and the error reports of
  /// rejected updates (serialised, see Serialise) waiting for their turn.
  std::deque<std::variant<PreparedUpdate, grpc::Slice>> pending_;
  /// Serialised reports waiting for the write in progress, oldest first.
  std::deque<grpc::Slice> outgoing_;
  /// The bytes in outgoing_, and when its oldest was queued (see HoldReports).
  std::size_t outgoing_bytes_ = 0;
  Clock::time_point oldest_outgoing_;
  /// Reused by ToSlice (see there).
  ReportEncoder encoder_;
  bool reading_ = false;
  bool writing_ = false;
  bool evaluating_ = false;
  /// Taken by Pump() for Pump(lock) to run on this thread (see PoseStream::evaluates_inline).
  std::shared_ptr<EvaluationJob> inline_evaluation_;
  bool reads_done_ = false;
  bool broken_ = false;
  bool draining_ = false;
  bool finished_ = false;
  const char* finish_reason_ = "";
  /// Why a message did not parse (the stream then ends INVALID_ARGUMENT); empty while all did.
  std::string unparsable_;
  std::uint64_t last_sequence_ = 0;
  std::uint64_t messages_read_ = 0;
  std::uint64_t updates_read_ = 0;
  std::uint64_t updates_rejected_ = 0;
  std::uint64_t updates_coalesced_ = 0;
  std::uint64_t reports_written_ = 0;
  std::uint64_t messages_written_ = 0;
};

// ---- Echo ----

/// Writes back every message it reads, one at a time (the transport floor for benchmarks), as
/// the bytes it read: an EchoMessage comes back as sent, without a parse and a serialisation.
class EchoReactor final : public AsyncReactor, public DrainableStream {
 public:
  EchoReactor(AsyncCall& call, CallRegistry& registry) : AsyncReactor(call), registry_(registry) {
    const auto constructed = handoff_.construction();  // see tsan_handoff.hpp
    registered_ = registry_.add(this);  // not under mutex_: drain_all locks them the other way
    std::lock_guard lock(mutex_);
    if (!registered_) End(grpc::Status(grpc::StatusCode::UNAVAILABLE, kShuttingDown));
    if (finished_) return;  // refused, or drained already
    reading_ = true;
    StartRead(&message_);
  }

  void OnReadDone(bool ok) override {
    const auto reaction = handoff_.reaction();
    std::lock_guard lock(mutex_);
    reading_ = false;
    if (!ok) return End(grpc::Status::OK);
    if (draining_) return End(grpc::Status(grpc::StatusCode::UNAVAILABLE, kDraining));
    writing_ = true;
    StartWrite(&message_);
  }

  void OnWriteDone(bool ok) override {
    const auto reaction = handoff_.reaction();
    std::lock_guard lock(mutex_);
    writing_ = false;
    if (!ok) return End(grpc::Status(grpc::StatusCode::CANCELLED, "cancelled"));
    if (draining_) return End(grpc::Status(grpc::StatusCode::UNAVAILABLE, kDraining));
    reading_ = true;
    StartRead(&message_);
  }

  void Drain() override {
    std::lock_guard lock(mutex_);
    draining_ = true;
    if (!writing_) End(grpc::Status(grpc::StatusCode::UNAVAILABLE, kDraining));
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
  grpc::ByteBuffer message_;
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

namespace {

// The typed handlers: each ends its call once (see UnaryCall).

using RegisterGeometryCall = UnaryCall<v1::RegisterGeometryRequest, v1::RegisterGeometryResponse>;
void register_geometry(SceneService& scenes, RegisterGeometryCall& call) {
  Expected<model::GeometryInfo> info = scenes.register_geometry(to_input(call.request.geometry()));
  if (!info) return call.reject(info.error());
  to_proto(info.value(), *call.response.mutable_geometry());
  log_info("geometry_registered")
      .kv("geometry", info->geometry_id)
      .kv("name", info->name)
      .kv("pieces", info->piece_count)
      .kv("vertices", info->vertex_count)
      .kv("bounding_radius", info->bounding_radius);
  call.finish(grpc::Status::OK);
}

using RemoveGeometryCall = UnaryCall<v1::RemoveGeometryRequest, v1::RemoveGeometryResponse>;
void remove_geometry(SceneService& scenes, RemoveGeometryCall& call) {
  if (Outcome removed = scenes.remove_geometry(call.request.geometry_id()); !removed)
    return call.reject(removed.error());
  log_info("geometry_removed").kv("geometry", call.request.geometry_id());
  call.finish(grpc::Status::OK);
}

using ListGeometriesCall = UnaryCall<v1::ListGeometriesRequest, v1::ListGeometriesResponse>;
void list_geometries(SceneService& scenes, ListGeometriesCall& call) {
  for (const model::GeometryInfo& info : scenes.list_geometries())
    to_proto(info, *call.response.add_geometries());
  call.finish(grpc::Status::OK);
}

using CreateSceneCall = UnaryCall<v1::CreateSceneRequest, v1::CreateSceneResponse>;
void create_scene(SceneService& scenes, CreateSceneCall& call) {
  const v1::CreateSceneRequest& request = call.request;
  // A routing key that names another scene would place this one where no later call for it
  // is routed: refuse it rather than create a scene nobody can reach through the proxy.
  if (const std::string key = routing_key(call.context);
      !key.empty() && !request.scene_id().empty() && key != request.scene_id())
    return call.reject(invalid_argument(
        "scene_id", text("differs from the routing header x-nearpoint-scene ", quoted(key),
                         ": a sharding proxy would route later calls for ",
                         quoted(request.scene_id()), " elsewhere")));
  Expected<model::SceneInfo> info = scenes.create_scene(to_input(request));
  if (!info) return call.reject(info.error());
  call.response.set_scene_id(info->scene_id);
  call.response.set_pair_count(std::uint32_t(info->pair_count));
  for (const auto& [key, id] : info->geometry_ids)
    (*call.response.mutable_geometry_ids())[key] = id;
  log_info("scene_created")
      .kv("scene", info->scene_id)
      .kv("routing_key", routing_key(call.context))
      .kv("name", request.name())
      .kv("objects", request.objects_size())
      .kv("pairs", info->pair_count);
  call.finish(grpc::Status::OK);
}

using DeleteSceneCall = UnaryCall<v1::DeleteSceneRequest, v1::DeleteSceneResponse>;
void delete_scene(SceneService& scenes, DeleteSceneCall& call) {
  if (Outcome deleted = scenes.delete_scene(call.request.scene_id()); !deleted)
    return call.reject(deleted.error());
  log_info("scene_deleted").kv("scene", call.request.scene_id());
  call.finish(grpc::Status::OK);
}

using ListScenesCall = UnaryCall<v1::ListScenesRequest, v1::ListScenesResponse>;
void list_scenes(SceneService& scenes, ListScenesCall& call) {
  for (const auto& scene : scenes.list_scenes()) {
    v1::SceneSummary& summary = *call.response.add_scenes();
    summary.set_scene_id(scene->id);
    summary.set_name(scene->name);
    summary.set_pair_count(std::uint32_t(scene->pairs.size()));
    for (const SceneObject& object : scene->objects) {
      v1::SceneObject& out = *summary.add_objects();
      out.set_id(object.id);
      out.set_geometry_id(object.geometry->info.geometry_id);
      const Eigen::Quaterniond q(object.initial_pose.rotation);
      v1::Quaternion& rotation = *out.mutable_pose()->mutable_rotation();
      rotation.set_w(q.w());
      rotation.set_x(q.x());
      rotation.set_y(q.y());
      rotation.set_z(q.z());
      v1::Vector3& translation = *out.mutable_pose()->mutable_translation();
      translation.set_x(object.initial_pose.translation.x());
      translation.set_y(object.initial_pose.translation.y());
      translation.set_z(object.initial_pose.translation.z());
      out.set_group(object.group);
      out.set_mask(object.mask);
      out.set_padding(object.padding);
      out.set_self_padding(object.self_padding);
    }
  }
  call.finish(grpc::Status::OK);
}

using QueryCall = UnaryCall<v1::QueryRequest, v1::DistanceReport>;
void query(SceneService& scenes, std::size_t max_message_bytes,
           const std::shared_ptr<QueryCall>& call) {
  // The geometry runs on the pool; the call is ended from there (and kept alive until then).
  Outcome started =
      scenes.query(to_input(call->request), Clock::now(), [call, max_message_bytes](Report report) {
        to_proto(report, call->response);
        auto error = check_report_fits(call->response, max_message_bytes);
        metrics::record_query(error ? &*error : nullptr);
        if (error) {
          log_error("report_too_large").kv("rpc", "Query").kv("message", error->message);
          call->response.Clear();
          call->finish(to_grpc_status(*error));
          return;
        }
        call->finish(grpc::Status::OK);
      });
  if (!started) {
    metrics::record_query(&started.error());
    call->reject(started.error());
  }
}

}  // namespace

void DistanceServiceImpl::register_methods(AsyncGrpcServer& server) {
  const std::string prefix = text("/", v1::DistanceService::service_full_name(), "/");
  server.add_unary_method(prefix + "RegisterGeometry",
                          unary_method<v1::RegisterGeometryRequest, v1::RegisterGeometryResponse>(
                              calls_, "RegisterGeometry",
                              [this](const auto& call) { register_geometry(scenes_, *call); }));
  server.add_unary_method(
      prefix + "RemoveGeometry",
      unary_method<v1::RemoveGeometryRequest, v1::RemoveGeometryResponse>(
          calls_, "RemoveGeometry", [this](const auto& call) { remove_geometry(scenes_, *call); }));
  server.add_unary_method(
      prefix + "ListGeometries",
      unary_method<v1::ListGeometriesRequest, v1::ListGeometriesResponse>(
          calls_, "ListGeometries", [this](const auto& call) { list_geometries(scenes_, *call); }));
  server.add_unary_method(
      prefix + "CreateScene",
      unary_method<v1::CreateSceneRequest, v1::CreateSceneResponse>(
          calls_, "CreateScene", [this](const auto& call) { create_scene(scenes_, *call); }));
  server.add_unary_method(
      prefix + "DeleteScene",
      unary_method<v1::DeleteSceneRequest, v1::DeleteSceneResponse>(
          calls_, "DeleteScene", [this](const auto& call) { delete_scene(scenes_, *call); }));
  server.add_unary_method(
      prefix + "ListScenes",
      unary_method<v1::ListScenesRequest, v1::ListScenesResponse>(
          calls_, "ListScenes", [this](const auto& call) { list_scenes(scenes_, *call); }));
  server.add_unary_method(prefix + "Query", unary_method<v1::QueryRequest, v1::DistanceReport>(
                                                calls_, "Query", [this](const auto& call) {
                                                  query(scenes_, max_message_bytes_, call);
                                                }));
  server.add_unary_method(
      prefix + "GetServerInfo",
      unary_method<v1::GetServerInfoRequest, v1::ServerInfo>(
          calls_, "GetServerInfo", [this](const auto& call) {
            call->response = server_info_;
            call->response.mutable_transports()->set_grpc_port(std::uint32_t(port_.load()));
            call->finish(grpc::Status::OK);
          }));
  server.add_method(prefix + "StreamPoses", [this](AsyncCall& call) -> AsyncReactor* {
    return new PoseStreamReactor(call, *this, next_stream_number_.fetch_add(1),
                                 StreamFraming::one_per_message);
  });
  server.add_method(prefix + "StreamPoseBatches", [this](AsyncCall& call) -> AsyncReactor* {
    return new PoseStreamReactor(call, *this, next_stream_number_.fetch_add(1),
                                 StreamFraming::batched);
  });
}

void DiagnosticsServiceImpl::register_methods(AsyncGrpcServer& server) {
  server.add_method(
      text("/", v1::Diagnostics::service_full_name(), "/Echo"),
      [this](AsyncCall& call) -> AsyncReactor* { return new EchoReactor(call, calls_); });
}

}  // namespace nearpoint::server
