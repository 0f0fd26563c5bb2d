// SPDX-License-Identifier: Apache-2.0
#include "grpc_reflection.hpp"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/descriptor.pb.h>

#include <mutex>
#include <unordered_set>
#include <utility>

#include "grpc_bytes.hpp"
#include "health_v1.pb.h"
#include "reflection_v1.pb.h"
#include "wire_parse.hpp"

namespace nearpoint::server {

namespace {

namespace reflection = ::grpc::reflection::v1alpha;
using google::protobuf::Descriptor;
using google::protobuf::DescriptorPool;
using google::protobuf::FieldDescriptor;
using google::protobuf::FileDescriptor;

void set_error(reflection::ServerReflectionResponse& response, grpc::StatusCode code,
               std::string message) {
  reflection::ErrorResponse& error = *response.mutable_error_response();
  error.set_error_code(int(code));
  error.set_error_message(std::move(message));
}

/// `file`, then the files it imports, transitively, each once (depth first, as gRPC's own
/// reflection answers): a client can then build the file's descriptors with nothing else.
void add_with_dependencies(const FileDescriptor& file, reflection::FileDescriptorResponse& out,
                           std::unordered_set<std::string>& seen) {
  if (!seen.insert(file.name()).second) return;
  google::protobuf::FileDescriptorProto proto;
  file.CopyTo(&proto);
  proto.SerializeToString(out.add_file_descriptor_proto());
  for (int i = 0; i < file.dependency_count(); ++i)
    add_with_dependencies(*file.dependency(i), out, seen);
}

/// `file` with its dependencies; NOT_FOUND saying "`what` not found" when there is no file.
void answer_file(const FileDescriptor* file, const std::string& what,
                 reflection::ServerReflectionResponse& response) {
  if (!file) return set_error(response, grpc::StatusCode::NOT_FOUND, what + " not found");
  std::unordered_set<std::string> seen;
  add_with_dependencies(*file, *response.mutable_file_descriptor_response(), seen);
}

/// The extensions of `type` the generated pool knows. Not inlined, so that TSan's suppression of
/// a false "unlock of an unlocked mutex" can name it (tests/sanitizers/tsan.supp says why).
[[gnu::noinline]] std::vector<const FieldDescriptor*> generated_extensions_of(
    const Descriptor& type) {
  std::vector<const FieldDescriptor*> extensions;
  DescriptorPool::generated_pool()->FindAllExtensions(&type, &extensions);
  return extensions;
}

}  // namespace

/// One ServerReflectionInfo stream: read a request, write its response, read the next, until the
/// client half-closes (OK), cancels, or the server drains it (UNAVAILABLE once the response being
/// written is sent). Answers are computed on the completion-queue thread: a lookup in the
/// generated pool takes microseconds once the pool has built the file (the first time, a
/// millisecond or so), and reflection is a tool's occasional call.
///
/// Locks: the call registry's, then ours (Drain()); we never call into the registry holding
/// ours. Finish is never called while a write is in flight.
class ReflectionReactor final : public AsyncReactor, public DrainableStream {
 public:
  ReflectionReactor(AsyncCall& call, ServerReflection& owner) : AsyncReactor(call), owner_(owner) {
    registered_ = owner_.calls().add(this);  // not under mutex_: Drain() locks the other way
    std::lock_guard lock(mutex_);
    if (!registered_) {
      finish_locked(grpc::StatusCode::UNAVAILABLE, kShuttingDown);
      return;
    }
    if (finished_) return;  // drained already
    StartRead(&request_bytes_);
  }

  void OnReadDone(bool ok) override {
    std::lock_guard lock(mutex_);
    if (finished_) return;
    if (!ok)  // the client's half-close (or the call is over)
      return finish_locked(cancelled_ ? grpc::StatusCode::CANCELLED : grpc::StatusCode::OK, "");
    if (draining_) return finish_locked(grpc::StatusCode::UNAVAILABLE, kDraining);
    reflection::ServerReflectionRequest request;
    if (std::string why_not = parse_message(request_bytes_, request); !why_not.empty())
      return finish_locked(grpc::StatusCode::INVALID_ARGUMENT,
                           "ServerReflectionRequest: " + why_not);
    response_ = byte_buffer_of(owner_.answer(request).SerializeAsString());
    writing_ = true;
    StartWrite(&response_);
  }

  void OnWriteDone(bool ok) override {
    std::lock_guard lock(mutex_);
    writing_ = false;
    if (finished_) return;
    if (!ok) return finish_locked(grpc::StatusCode::CANCELLED, "the client is gone");
    if (cancelled_) return finish_locked(grpc::StatusCode::CANCELLED, "cancelled");
    if (draining_) return finish_locked(grpc::StatusCode::UNAVAILABLE, kDraining);
    StartRead(&request_bytes_);
  }

  void OnCancel() override {
    std::lock_guard lock(mutex_);
    cancelled_ = true;
    if (!finished_ && !writing_) finish_locked(grpc::StatusCode::CANCELLED, "cancelled");
  }

  void Drain() override {
    std::lock_guard lock(mutex_);
    draining_ = true;
    // A read may be outstanding: Finish overtakes it. A write is let through first.
    if (!finished_ && !writing_) finish_locked(grpc::StatusCode::UNAVAILABLE, kDraining);
  }

  void OnDone() override {
    if (registered_) owner_.calls().remove(this);  // no Drain() runs on us after this
    delete this;
  }

 private:
  void finish_locked(grpc::StatusCode code, const std::string& message) {
    finished_ = true;
    Finish(grpc::Status(code, message));
  }

  ServerReflection& owner_;
  bool registered_ = false;
  std::mutex mutex_;
  grpc::ByteBuffer request_bytes_;
  grpc::ByteBuffer response_;
  bool writing_ = false;
  bool cancelled_ = false;
  bool draining_ = false;
  bool finished_ = false;
};

ServerReflection::ServerReflection(std::vector<std::string> services)
    : services_(std::move(services)) {
  for (const char* own : {kServiceNameV1Alpha, kServiceNameV1}) services_.emplace_back(own);
  // The generated pool knows a file only when its generated code is linked in; nothing else
  // refers to these two, so refer to them here: a client can then describe the health service
  // and the v1 reflection service too.
  grpc::health::v1::HealthCheckRequest::descriptor();
  google::protobuf::DescriptorPool::generated_pool()->FindFileByName(
      ::descriptor_table_reflection_5fv1_2eproto.filename);
}

void ServerReflection::register_methods(AsyncGrpcServer& server) {
  for (const char* service : {kServiceNameV1Alpha, kServiceNameV1})
    server.add_method(std::string("/") + service + "/ServerReflectionInfo",
                      [this](AsyncCall& call) { return new ReflectionReactor(call, *this); });
}

reflection::ServerReflectionResponse ServerReflection::answer(
    const reflection::ServerReflectionRequest& request) const {
  reflection::ServerReflectionResponse response;
  response.set_valid_host(request.host());
  *response.mutable_original_request() = request;
  const DescriptorPool& pool = *DescriptorPool::generated_pool();
  switch (request.message_request_case()) {
    case reflection::ServerReflectionRequest::kFileByFilename:
      answer_file(pool.FindFileByName(request.file_by_filename()),
                  "file '" + request.file_by_filename() + "'", response);
      break;
    case reflection::ServerReflectionRequest::kFileContainingSymbol:
      answer_file(pool.FindFileContainingSymbol(request.file_containing_symbol()),
                  "symbol '" + request.file_containing_symbol() + "'", response);
      break;
    case reflection::ServerReflectionRequest::kFileContainingExtension: {
      const reflection::ExtensionRequest& asked = request.file_containing_extension();
      const Descriptor* type = pool.FindMessageTypeByName(asked.containing_type());
      if (!type) {
        set_error(response, grpc::StatusCode::NOT_FOUND,
                  "message type '" + asked.containing_type() + "' not found");
        break;
      }
      const FieldDescriptor* extension = pool.FindExtensionByNumber(type, asked.extension_number());
      answer_file(extension ? extension->file() : nullptr,
                  "extension " + std::to_string(asked.extension_number()) + " of '" +
                      asked.containing_type() + "'",
                  response);
      break;
    }
    case reflection::ServerReflectionRequest::kAllExtensionNumbersOfType: {
      const Descriptor* type = pool.FindMessageTypeByName(request.all_extension_numbers_of_type());
      if (!type) {
        set_error(response, grpc::StatusCode::NOT_FOUND,
                  "message type '" + request.all_extension_numbers_of_type() + "' not found");
        break;
      }
      reflection::ExtensionNumberResponse& numbers =
          *response.mutable_all_extension_numbers_response();
      numbers.set_base_type_name(type->full_name());
      for (const FieldDescriptor* extension : generated_extensions_of(*type))
        numbers.add_extension_number(extension->number());
      break;
    }
    case reflection::ServerReflectionRequest::kListServices: {
      reflection::ListServiceResponse& list = *response.mutable_list_services_response();
      for (const std::string& service : services_) list.add_service()->set_name(service);
      break;
    }
    case reflection::ServerReflectionRequest::MESSAGE_REQUEST_NOT_SET:
      // A kind of request this schema does not know (a newer protocol's), or none: as gRPC's
      // own implementation answers.
      set_error(response, grpc::StatusCode::UNIMPLEMENTED, "the request is not supported");
      break;
  }
  return response;
}

}  // namespace nearpoint::server
