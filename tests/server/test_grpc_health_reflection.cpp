// SPDX-License-Identifier: Apache-2.0
// grpc.health.v1.Health and server reflection as nearpointd serves them on the async generic
// API (grpc_health.hpp, grpc_reflection.hpp): a real gRPC server on 127.0.0.1:0 with only these
// methods, and a client that writes and reads the protocols' bytes, so that what is checked is
// the wire, not our own types.
#include <google/protobuf/descriptor.h>
#include <google/protobuf/descriptor.pb.h>
#include <google/protobuf/descriptor_database.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "grpc_async.hpp"
#include "grpc_health.hpp"
#include "grpc_reflection.hpp"
#include "reflection_v1alpha.pb.h"
#include "server/server_test_support.hpp"

namespace nearpoint::server::testing {
namespace {

namespace reflection = ::grpc::reflection::v1alpha;

constexpr const char* kDistanceService = "nearpoint.v1.DistanceService";

/// HealthCheckRequest { service } written by hand (names shorter than 128 bytes).
std::string health_request(const std::string& service) {
  if (service.empty()) return {};
  return std::string("\x0a", 1) + char(service.size()) + service;
}

/// HealthCheckResponse { status } as the protocol writes it.
std::string health_response(int status) {
  return std::string("\x08", 1) + char(status);
}

class HealthReflectionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    grpc::ServerBuilder builder;
    builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    async_ = std::make_unique<AsyncGrpcServer>(builder);
    health_.register_methods(*async_);
    reflection_.register_methods(*async_);
    server_ = builder.BuildAndStart();
    ASSERT_TRUE(server_);
    ASSERT_NE(port_, 0);
    async_->start(1, 1);
    channel_ = grpc::CreateChannel("127.0.0.1:" + std::to_string(port_),
                                   grpc::InsecureChannelCredentials());
  }

  void TearDown() override { stop_server(); }

  /// What GrpcServer::shutdown does with these two: health first, then drain, then the server.
  void stop_server() {
    if (!server_) return;
    health_.shutdown();
    health_.calls().drain_all();
    reflection_.calls().drain_all();
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    EXPECT_TRUE(health_.calls().wait_idle(deadline));
    EXPECT_TRUE(reflection_.calls().wait_idle(deadline));
    server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(1));
    async_->stop();
    server_.reset();
    async_.reset();
  }

  /// One unary call with raw bytes.
  grpc::Status unary(const std::string& method, const std::string& request, std::string& response) {
    grpc::GenericStub generic(channel_);
    grpc::CompletionQueue queue;
    auto context = make_context();
    grpc::Slice slice(request);
    grpc::ByteBuffer request_buffer(&slice, 1), response_buffer;
    auto call = generic.PrepareUnaryCall(context.get(), method, request_buffer, &queue);
    call->StartCall();
    grpc::Status status;
    call->Finish(&response_buffer, &status, reinterpret_cast<void*>(1));
    void* tag = nullptr;
    bool ok = false;
    EXPECT_EQ(queue.AsyncNext(&tag, &ok, std::chrono::system_clock::now() + kCallDeadline),
              grpc::CompletionQueue::GOT_EVENT);
    queue.Shutdown();
    while (queue.Next(&tag, &ok)) {
    }
    response = bytes_of(response_buffer);
    return status;
  }

  grpc::Status check(const std::string& service, std::string& response) {
    return unary(HealthStatus::kCheckMethod, health_request(service), response);
  }

  /// Sends `request` on an open reflection stream and parses the answer.
  static reflection::ServerReflectionResponse ask(
      RawStream& stream, const reflection::ServerReflectionRequest& request) {
    reflection::ServerReflectionResponse response;
    EXPECT_TRUE(stream.write(request.SerializeAsString()));
    std::string bytes;
    EXPECT_TRUE(stream.read(bytes));
    EXPECT_TRUE(response.ParseFromString(bytes));
    return response;
  }

  HealthStatus health_;
  ServerReflection reflection_{{kDistanceService, HealthStatus::kServiceName}};
  int port_ = 0;
  std::unique_ptr<AsyncGrpcServer> async_;
  std::unique_ptr<grpc::Server> server_;
  std::shared_ptr<grpc::Channel> channel_;
};

// ---- Check ----

TEST_F(HealthReflectionTest, CheckAnswersTheServerAndEachService) {
  health_.set_serving("", true);
  health_.set_serving(kDistanceService, true);
  std::string response;
  ASSERT_TRUE(check("", response).ok());
  EXPECT_EQ(response, health_response(1)) << "SERVING";
  ASSERT_TRUE(check(kDistanceService, response).ok());
  EXPECT_EQ(response, health_response(1)) << "SERVING";
  health_.set_serving(kDistanceService, false);
  ASSERT_TRUE(check(kDistanceService, response).ok());
  EXPECT_EQ(response, health_response(2)) << "NOT_SERVING";
  ASSERT_TRUE(check("", response).ok());
  EXPECT_EQ(response, health_response(1)) << "the server as a whole is a service of its own";
}

TEST_F(HealthReflectionTest, CheckOfAnUnknownServiceIsNotFound) {
  health_.set_serving("", true);
  std::string response;
  const grpc::Status status = check("nearpoint.v1.NoSuchService", response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::NOT_FOUND) << status.error_message();
  EXPECT_NE(status.error_message().find("nearpoint.v1.NoSuchService"), std::string::npos);
}

TEST_F(HealthReflectionTest, CheckAfterShutdownIsNotServingAndSetServingIsIgnored) {
  health_.set_serving("", true);
  health_.shutdown();
  health_.set_serving("", true);
  std::string response;
  ASSERT_TRUE(check("", response).ok());
  EXPECT_EQ(response, health_response(2)) << "NOT_SERVING";
}

// The request is parsed by hand: unknown fields are skipped as protobuf skips them, and bytes
// that are not wire format get INVALID_ARGUMENT with a reason.
TEST_F(HealthReflectionTest, CheckSkipsUnknownFieldsAndRejectsBadBytes) {
  health_.set_serving(kDistanceService, true);
  std::string response;
  // field 2 (varint 7), field 3 (fixed32), then service.
  const std::string with_unknown =
      std::string("\x10\x07\x1d\x01\x02\x03\x04", 7) + health_request(kDistanceService);
  grpc::Status status = unary(HealthStatus::kCheckMethod, with_unknown, response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(response, health_response(1));

  status = unary(HealthStatus::kCheckMethod, std::string("\x0a\x10short", 7), response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("service"), std::string::npos) << status.error_message();

  status = unary(HealthStatus::kCheckMethod, std::string("\x0a\x02\xc3\x28", 4), response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("UTF-8"), std::string::npos) << status.error_message();

  status = unary(HealthStatus::kCheckMethod, std::string("\xff\xff", 2), response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
}

// ---- Watch ----

TEST_F(HealthReflectionTest, WatchSendsEachChangeThenNotServingAtShutdownAndEnds) {
  health_.set_serving("", true);
  RawStream watch(channel_, HealthStatus::kWatchMethod);
  ASSERT_TRUE(watch.started());
  ASSERT_TRUE(watch.write(health_request("")));
  ASSERT_TRUE(watch.writes_done());
  std::string message;
  ASSERT_TRUE(watch.read(message));
  EXPECT_EQ(message, health_response(1)) << "the status at once: SERVING";
  health_.set_serving("", false);
  ASSERT_TRUE(watch.read(message));
  EXPECT_EQ(message, health_response(2)) << "NOT_SERVING";
  health_.set_serving("", true);
  ASSERT_TRUE(watch.read(message));
  EXPECT_EQ(message, health_response(1)) << "SERVING again";

  health_.shutdown();
  ASSERT_TRUE(watch.read(message));
  EXPECT_EQ(message, health_response(2)) << "NOT_SERVING at shutdown";
  health_.calls().drain_all();
  EXPECT_FALSE(watch.read(message)) << "the stream ends after NOT_SERVING, nothing more";
  const grpc::Status status = watch.finish();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << status.error_message();
}

// A drained watcher that has not been told NOT_SERVING is told before the stream ends; a new
// Watch during the drain is refused.
TEST_F(HealthReflectionTest, DrainTellsNotServingFirstAndRefusesNewWatchers) {
  health_.set_serving(kDistanceService, true);
  RawStream watch(channel_, HealthStatus::kWatchMethod);
  ASSERT_TRUE(watch.write(health_request(kDistanceService)));
  std::string message;
  ASSERT_TRUE(watch.read(message));
  EXPECT_EQ(message, health_response(1));
  health_.calls().drain_all();  // without shutdown(): the status is still SERVING
  ASSERT_TRUE(watch.read(message));
  EXPECT_EQ(message, health_response(2)) << "NOT_SERVING before the end";
  EXPECT_FALSE(watch.read(message));
  EXPECT_EQ(watch.finish().error_code(), grpc::StatusCode::UNAVAILABLE);

  RawStream late(channel_, HealthStatus::kWatchMethod);
  late.write(health_request(kDistanceService));
  EXPECT_FALSE(late.read(message));
  EXPECT_EQ(late.finish().error_code(), grpc::StatusCode::UNAVAILABLE);
}

TEST_F(HealthReflectionTest, WatchOfAnUnknownServiceSaysSoThenFollowsIt) {
  RawStream watch(channel_, HealthStatus::kWatchMethod);
  ASSERT_TRUE(watch.write(health_request("nearpoint.v1.Later")));
  std::string message;
  ASSERT_TRUE(watch.read(message));
  EXPECT_EQ(message, health_response(3)) << "SERVICE_UNKNOWN, not an error";
  health_.set_serving("nearpoint.v1.Other", true);  // another service: nothing to tell
  health_.set_serving("nearpoint.v1.Later", true);
  ASSERT_TRUE(watch.read(message));
  EXPECT_EQ(message, health_response(1));
}

// The watcher's reactor is gone once the client cancels: nothing is left for the drain to wait
// for (a watcher that outlived its client would hold shutdown until the drain timeout).
TEST_F(HealthReflectionTest, WatchEndsWhenTheClientCancels) {
  health_.set_serving("", true);
  {
    RawStream watch(channel_, HealthStatus::kWatchMethod);
    ASSERT_TRUE(watch.write(health_request("")));
    std::string message;
    ASSERT_TRUE(watch.read(message));
  }  // cancels
  EXPECT_TRUE(
      health_.calls().wait_idle(std::chrono::steady_clock::now() + std::chrono::seconds(10)));
}

TEST_F(HealthReflectionTest, WatchWithABadRequestIsInvalidArgument) {
  RawStream watch(channel_, HealthStatus::kWatchMethod);
  ASSERT_TRUE(watch.write(std::string("\x0a\x05x", 3)));
  std::string message;
  EXPECT_FALSE(watch.read(message));
  const grpc::Status status = watch.finish();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
}

// ---- Reflection ----

TEST_F(HealthReflectionTest, ReflectionListsTheGivenServicesAndItself) {
  for (const char* service :
       {ServerReflection::kServiceNameV1Alpha, ServerReflection::kServiceNameV1}) {
    RawStream stream(channel_, std::string("/") + service + "/ServerReflectionInfo");
    reflection::ServerReflectionRequest request;
    request.set_host("example.test");
    request.set_list_services("");
    const reflection::ServerReflectionResponse response = ask(stream, request);
    EXPECT_EQ(response.valid_host(), "example.test");
    EXPECT_EQ(response.original_request().SerializeAsString(), request.SerializeAsString());
    ASSERT_TRUE(response.has_list_services_response()) << service;
    std::set<std::string> names;
    for (const reflection::ServiceResponse& listed : response.list_services_response().service())
      names.insert(listed.name());
    EXPECT_EQ(names, (std::set<std::string>{kDistanceService, "grpc.health.v1.Health",
                                            "grpc.reflection.v1alpha.ServerReflection",
                                            "grpc.reflection.v1.ServerReflection"}));
    ASSERT_TRUE(stream.writes_done());
    EXPECT_TRUE(stream.finish().ok()) << "the client's half-close ends the stream OK";
  }
}

// The file is answered with every file it imports, so that a client can build its descriptors
// with nothing else (here: a fresh pool that knows only the response).
TEST_F(HealthReflectionTest, FileContainingSymbolGivesAFileThatBuildsWithItsDependencies) {
  RawStream stream(channel_, "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo");
  for (const std::string& symbol :
       {std::string(kDistanceService), std::string(kDistanceService) + ".StreamPoses",
        std::string("nearpoint.v1.PoseUpdate")}) {
    reflection::ServerReflectionRequest request;
    request.set_file_containing_symbol(symbol);
    const reflection::ServerReflectionResponse response = ask(stream, request);
    ASSERT_TRUE(response.has_file_descriptor_response()) << symbol;
    google::protobuf::SimpleDescriptorDatabase database;
    std::string first;
    std::set<std::string> files;
    for (const std::string& bytes : response.file_descriptor_response().file_descriptor_proto()) {
      google::protobuf::FileDescriptorProto file;
      ASSERT_TRUE(file.ParseFromString(bytes));
      if (first.empty()) first = file.name();
      EXPECT_TRUE(files.insert(file.name()).second) << file.name() << " sent twice";
      ASSERT_TRUE(database.Add(file));
    }
    google::protobuf::DescriptorPool pool(&database);
    const google::protobuf::FileDescriptor* file = pool.FindFileByName(first);
    ASSERT_NE(file, nullptr) << symbol << ": the response's first file does not build from it";
    const google::protobuf::ServiceDescriptor* service = pool.FindServiceByName(kDistanceService);
    ASSERT_NE(service, nullptr) << symbol;
    const google::protobuf::MethodDescriptor* method = service->FindMethodByName("StreamPoses");
    ASSERT_NE(method, nullptr);
    EXPECT_EQ(method->input_type()->full_name(), "nearpoint.v1.PoseUpdate");
    EXPECT_TRUE(method->client_streaming() && method->server_streaming());
  }
}

TEST_F(HealthReflectionTest, UnknownNamesAreNotFoundAndTheStreamGoesOn) {
  RawStream stream(channel_, "/grpc.reflection.v1.ServerReflection/ServerReflectionInfo");
  reflection::ServerReflectionRequest request;
  request.set_file_by_filename("no/such/file.proto");
  reflection::ServerReflectionResponse response = ask(stream, request);
  ASSERT_TRUE(response.has_error_response());
  EXPECT_EQ(response.error_response().error_code(), 5) << "NOT_FOUND";
  EXPECT_NE(response.error_response().error_message().find("no/such/file.proto"),
            std::string::npos);
  EXPECT_EQ(response.original_request().file_by_filename(), "no/such/file.proto");

  request.set_file_containing_symbol("nearpoint.v1.NoSuchThing");
  response = ask(stream, request);
  ASSERT_TRUE(response.has_error_response());
  EXPECT_EQ(response.error_response().error_code(), 5);

  request.mutable_file_containing_extension()->set_containing_type("nearpoint.v1.PoseUpdate");
  request.mutable_file_containing_extension()->set_extension_number(1000);
  response = ask(stream, request);
  ASSERT_TRUE(response.has_error_response());
  EXPECT_EQ(response.error_response().error_code(), 5);

  request.set_all_extension_numbers_of_type("nearpoint.v1.NoSuchMessage");
  response = ask(stream, request);
  ASSERT_TRUE(response.has_error_response());
  EXPECT_EQ(response.error_response().error_code(), 5);

  // The stream still answers after errors.
  request.set_file_by_filename("nearpoint_distance.proto");
  response = ask(stream, request);
  ASSERT_TRUE(response.has_file_descriptor_response());
  google::protobuf::FileDescriptorProto file;
  ASSERT_TRUE(file.ParseFromString(response.file_descriptor_response().file_descriptor_proto(0)));
  EXPECT_EQ(file.name(), "nearpoint_distance.proto");
}

TEST_F(HealthReflectionTest, ExtensionNumbersOfAKnownTypeNameTheType) {
  RawStream stream(channel_, "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo");
  reflection::ServerReflectionRequest request;
  request.set_all_extension_numbers_of_type("nearpoint.v1.PoseUpdate");
  const reflection::ServerReflectionResponse response = ask(stream, request);
  ASSERT_TRUE(response.has_all_extension_numbers_response());
  EXPECT_EQ(response.all_extension_numbers_response().base_type_name(), "nearpoint.v1.PoseUpdate");
  EXPECT_EQ(response.all_extension_numbers_response().extension_number_size(), 0);
}

// Clients such as grpcurl need the health service's schema to call it.
TEST_F(HealthReflectionTest, TheHealthAndReflectionServicesCanBeDescribed) {
  RawStream stream(channel_, "/grpc.reflection.v1.ServerReflection/ServerReflectionInfo");
  for (const char* symbol : {"grpc.health.v1.Health", "grpc.reflection.v1.ServerReflection",
                             "grpc.reflection.v1alpha.ServerReflection"}) {
    reflection::ServerReflectionRequest request;
    request.set_file_containing_symbol(symbol);
    const reflection::ServerReflectionResponse response = ask(stream, request);
    EXPECT_TRUE(response.has_file_descriptor_response()) << symbol;
  }
}

TEST_F(HealthReflectionTest, ReflectionRejectsBytesThatDoNotParse) {
  RawStream stream(channel_, "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo");
  ASSERT_TRUE(stream.write(std::string("\x3a\x09short", 7)));
  std::string bytes;
  EXPECT_FALSE(stream.read(bytes));
  const grpc::Status status = stream.finish();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
}

TEST_F(HealthReflectionTest, ReflectionStreamsEndAtTheDrain) {
  RawStream stream(channel_, "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo");
  reflection::ServerReflectionRequest request;
  request.set_list_services("");
  ask(stream, request);
  reflection_.calls().drain_all();
  std::string bytes;
  EXPECT_FALSE(stream.read(bytes));
  EXPECT_EQ(stream.finish().error_code(), grpc::StatusCode::UNAVAILABLE);
  RawStream late(channel_, "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo");
  late.write(request.SerializeAsString());
  EXPECT_FALSE(late.read(bytes));
  EXPECT_EQ(late.finish().error_code(), grpc::StatusCode::UNAVAILABLE);
}

}  // namespace
}  // namespace nearpoint::server::testing
