// SPDX-License-Identifier: Apache-2.0
#include "grpc_health.hpp"

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/stubs/common.h>
#include <google/protobuf/wire_format_lite.h>

#include <memory>
#include <utility>

#include "grpc_bytes.hpp"

namespace nearpoint::server {

namespace {

using google::protobuf::internal::WireFormatLite;

}  // namespace

std::optional<HealthCheckRequest> parse_health_check_request(std::string_view bytes,
                                                             std::string& why_not) {
  constexpr std::uint32_t kServiceTag =
      WireFormatLite::MakeTag(1, WireFormatLite::WIRETYPE_LENGTH_DELIMITED);
  google::protobuf::io::CodedInputStream input(reinterpret_cast<const std::uint8_t*>(bytes.data()),
                                               static_cast<int>(bytes.size()));
  HealthCheckRequest request;
  while (input.CurrentPosition() < static_cast<int>(bytes.size())) {
    const std::uint32_t tag = input.ReadTag();
    if (tag == 0) {  // a truncated varint, or field number 0
      why_not = "HealthCheckRequest: the bytes are not protobuf wire format (bad tag)";
      return std::nullopt;
    }
    if (tag == kServiceTag) {
      // Repeated occurrences: the last one wins, as for any singular protobuf field.
      std::uint32_t length = 0;
      if (!input.ReadVarint32(&length) || !input.ReadString(&request.service, int(length))) {
        why_not = "HealthCheckRequest: field service is truncated";
        return std::nullopt;
      }
      if (!google::protobuf::internal::IsStructurallyValidUTF8(request.service.data(),
                                                               int(request.service.size()))) {
        why_not = "HealthCheckRequest: field service is not valid UTF-8";
        return std::nullopt;
      }
      continue;
    }
    // Unknown fields, and field 1 with another wire type (protobuf's parser skips those too).
    if (!WireFormatLite::SkipField(&input, tag)) {
      why_not = "HealthCheckRequest: the bytes are not protobuf wire format (field " +
                std::to_string(WireFormatLite::GetTagFieldNumber(tag)) + " is malformed)";
      return std::nullopt;
    }
  }
  return request;
}

std::string serialize_health_check_response(ServingStatus status) {
  // proto3 leaves a zero enum out; every status we send is non-zero.
  if (status == ServingStatus::unknown) return {};
  return {char(WireFormatLite::MakeTag(1, WireFormatLite::WIRETYPE_VARINT)), char(status)};
}

/// One Watch call: reads the request, sends the status at once, then each change (only the
/// latest when several come during one write, as the protocol allows), until the client
/// cancels or the server drains it (NOT_SERVING unless sent already, then UNAVAILABLE).
///
/// Locks: HealthStatus's mutex, then ours (notify() is called under it); the call registry's,
/// then ours (Drain()). We never call into either while holding ours. Finish is never called
/// while a write is in flight (one send operation at a time on an async call).
class HealthWatchReactor final : public AsyncReactor, public DrainableStream {
 public:
  HealthWatchReactor(AsyncCall& call, HealthStatus& health) : AsyncReactor(call), health_(health) {
    registered_ = health_.calls().add(this);  // not under mutex_: Drain() locks the other way
    std::lock_guard lock(mutex_);
    if (!registered_) {
      finish_locked(grpc::StatusCode::UNAVAILABLE, kShuttingDown);
      return;
    }
    if (finished_) return;  // drained already
    reading_ = true;
    StartRead(&request_bytes_);
  }

  const std::string& service() const { return service_; }

  /// The status of our service now (from HealthStatus, under its mutex).
  void notify(ServingStatus status) {
    std::lock_guard lock(mutex_);
    // Once drained, the last word is NOT_SERVING whatever comes.
    latest_ = draining_ ? ServingStatus::not_serving : status;
    pump_locked();
  }

  void OnReadDone(bool ok) override {
    {
      std::lock_guard lock(mutex_);
      reading_ = false;
      if (finished_) return;
      if (!ok) {
        if (cancelled_) return finish_locked(grpc::StatusCode::CANCELLED, "cancelled");
        return finish_locked(grpc::StatusCode::INVALID_ARGUMENT,
                             "Watch: the client sent no HealthCheckRequest");
      }
      if (draining_) return finish_locked(grpc::StatusCode::UNAVAILABLE, kDraining);
      std::string bytes, why_not;
      if (!bytes_of(request_bytes_, bytes))
        return finish_locked(grpc::StatusCode::INTERNAL, "Watch: cannot read the request");
      std::optional<HealthCheckRequest> request = parse_health_check_request(bytes, why_not);
      if (!request) return finish_locked(grpc::StatusCode::INVALID_ARGUMENT, why_not);
      service_ = std::move(request->service);
      request_read_ = true;
    }
    // Outside our mutex (HealthStatus locks its own, then ours). OnDone cannot run before this
    // reaction returns, so `this` is alive; a drain in between is handled by notify().
    health_.subscribe(this);
  }

  void OnWriteDone(bool ok) override {
    std::lock_guard lock(mutex_);
    writing_ = false;
    if (!ok) return finish_locked(grpc::StatusCode::CANCELLED, "Watch: the client is gone");
    pump_locked();
  }

  void OnCancel() override {
    std::lock_guard lock(mutex_);
    cancelled_ = true;
    pump_locked();
  }

  void Drain() override {
    std::lock_guard lock(mutex_);
    draining_ = true;
    if (finished_) return;
    // No request yet: nothing to tell (a read may be outstanding; Finish may overtake it).
    if (!request_read_) return finish_locked(grpc::StatusCode::UNAVAILABLE, kDraining);
    latest_ = ServingStatus::not_serving;
    pump_locked();
  }

  void OnDone() override {
    health_.unsubscribe(this);                      // no notify() runs on us after this
    if (registered_) health_.calls().remove(this);  // nor Drain()
    delete this;
  }

 private:
  /// Writes the latest status if it is not the one sent last; ends the call when there is
  /// nothing more to say (cancelled, or drained and NOT_SERVING sent).
  void pump_locked() {
    if (finished_ || writing_) return;
    if (cancelled_) return finish_locked(grpc::StatusCode::CANCELLED, "cancelled");
    if (latest_ && latest_ != sent_) {
      sent_ = latest_;
      response_ = byte_buffer_of(serialize_health_check_response(*latest_));
      writing_ = true;
      StartWrite(&response_);
      return;
    }
    if (draining_) finish_locked(grpc::StatusCode::UNAVAILABLE, kDraining);
  }

  void finish_locked(grpc::StatusCode code, const std::string& message) {
    finished_ = true;
    Finish(grpc::Status(code, message));
  }

  HealthStatus& health_;
  bool registered_ = false;
  std::mutex mutex_;
  grpc::ByteBuffer request_bytes_;
  grpc::ByteBuffer response_;
  std::string service_;  // set before subscribe(), constant after
  bool reading_ = false;
  bool request_read_ = false;
  bool writing_ = false;
  bool cancelled_ = false;
  bool draining_ = false;
  bool finished_ = false;
  std::optional<ServingStatus> latest_;  // the status to tell the client
  std::optional<ServingStatus> sent_;    // the status written last
};

void HealthStatus::register_methods(AsyncGrpcServer& server) {
  server.add_unary_method(
      kCheckMethod,
      [this](const grpc::ByteBuffer& request_bytes, const std::shared_ptr<UnaryCallHandle>& call) {
        std::string bytes, why_not;
        if (!bytes_of(request_bytes, bytes))
          return call->finish(grpc::Status(grpc::StatusCode::INTERNAL, "cannot read the request"),
                              nullptr);
        const std::optional<HealthCheckRequest> request =
            parse_health_check_request(bytes, why_not);
        if (!request)
          return call->finish(grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, why_not), nullptr);
        const ServingStatus now = status(request->service);
        if (now == ServingStatus::service_unknown)
          return call->finish(grpc::Status(grpc::StatusCode::NOT_FOUND,
                                           "unknown service '" + request->service + "'"),
                              nullptr);
        const grpc::ByteBuffer response = byte_buffer_of(serialize_health_check_response(now));
        call->finish(grpc::Status::OK, &response);
      },
      UnaryThread::queue);  // a probe never waits behind a long request
  server.add_method(kWatchMethod,
                    [this](AsyncCall& call) { return new HealthWatchReactor(call, *this); });
}

void HealthStatus::set_serving(const std::string& service, bool serving) {
  std::lock_guard lock(mutex_);
  if (shut_down_) return;
  serving_[service] = serving;
  publish_locked(service, serving ? ServingStatus::serving : ServingStatus::not_serving);
}

void HealthStatus::shutdown() {
  std::lock_guard lock(mutex_);
  if (shut_down_) return;
  shut_down_ = true;
  for (auto& [service, serving] : serving_) {
    serving = false;
    publish_locked(service, ServingStatus::not_serving);
  }
}

ServingStatus HealthStatus::status(const std::string& service) const {
  std::lock_guard lock(mutex_);
  return status_locked(service);
}

ServingStatus HealthStatus::status_locked(const std::string& service) const {
  const auto found = serving_.find(service);
  if (found == serving_.end()) return ServingStatus::service_unknown;
  return found->second ? ServingStatus::serving : ServingStatus::not_serving;
}

void HealthStatus::publish_locked(const std::string& service, ServingStatus status) {
  for (HealthWatchReactor* watcher : watchers_)
    if (watcher->service() == service) watcher->notify(status);
}

void HealthStatus::subscribe(HealthWatchReactor* watcher) {
  std::lock_guard lock(mutex_);
  watchers_.insert(watcher);
  watcher->notify(status_locked(watcher->service()));
}

void HealthStatus::unsubscribe(HealthWatchReactor* watcher) {
  std::lock_guard lock(mutex_);
  watchers_.erase(watcher);
}

}  // namespace nearpoint::server
