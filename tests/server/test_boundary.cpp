// The service's boundary against requests within every limit that could still not be answered:
// reports larger than the server can send, and ids too long to echo. A real in-process server
// on 127.0.0.1:0 and the generated gRPC client (issue 21, items 3 and 4).
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <sstream>
#include <string>
#include <tuple>

#include "nearpoint/server/log.hpp"
#include "scene_fixture.hpp"

namespace nearpoint::server::testing {
namespace {

std::string register_sphere(v1::DistanceService::Stub& stub) {
  v1::RegisterGeometryRequest request;
  v1::Piece& piece = *request.mutable_geometry()->add_pieces();
  piece.mutable_point();
  piece.set_radius(1.0);
  v1::RegisterGeometryResponse response;
  const grpc::Status status = stub.RegisterGeometry(make_context().get(), request, &response);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return response.geometry().geometry_id();
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// ---- item 4: ids echoed without bound ----

// Guards the id rule (check_id at validation) and the short quoting of ids in messages
// (`quoted`) and logs: an 8 kB and a 10 MB unknown scene id used to be copied whole into the
// status message — the first made the client fail with "received initial metadata size exceeds
// limit" instead of an answer, the second wrote a 10 MB log line. Now both get INVALID_ARGUMENT
// with a message of a few hundred bytes quoting a 64-byte prefix and the length, every log line
// stays short, and the next call on the same channel works. A well-formed unknown id still
// gets NOT_FOUND, quoted whole.
TEST(IdLimits, LongUnknownIdsGetAShortErrorAndTheChannelKeepsWorking) {
  RunningServer running = start_server();
  ASSERT_TRUE(running.server);
  v1::DistanceService::Stub& stub = *running.stub;
  const std::string sphere = register_sphere(stub);
  v1::CreateSceneRequest create;
  for (const char* id : {"a", "b"}) {
    v1::SceneObject& object = *create.add_objects();
    object.set_id(id);
    object.set_geometry_id(sphere);
    object.mutable_pose()->mutable_translation()->set_x(id[0] == 'a' ? 0 : 5);
  }
  v1::CreateSceneResponse created;
  ASSERT_TRUE(stub.CreateScene(make_context().get(), create, &created).ok());

  ::testing::internal::CaptureStderr();  // the server's log lines (fd 2)
  for (const std::size_t length : {std::size_t(8192), std::size_t(10u << 20)}) {
    SCOPED_TRACE(length);
    const std::string id(length, 's');
    v1::QueryRequest query;
    query.set_scene_id(id);
    v1::DistanceReport report;
    const grpc::Status status = stub.Query(make_context().get(), query, &report);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_LT(status.error_message().size(), 300u) << status.error_message().substr(0, 300);
    EXPECT_TRUE(contains(status.error_message(), "(" + std::to_string(length) + " bytes)"))
        << status.error_message().substr(0, 300);

    v1::DeleteSceneRequest remove;
    remove.set_scene_id(id);
    v1::DeleteSceneResponse removed;
    const grpc::Status deleted = stub.DeleteScene(make_context().get(), remove, &removed);
    EXPECT_EQ(deleted.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_LT(deleted.error_message().size(), 300u);

    StreamClient stream(stub);
    v1::PoseUpdate update;
    update.set_scene_id(id);
    update.set_sequence(1);
    ASSERT_TRUE(stream.write(update));
    ASSERT_TRUE(stream.read(report));
    EXPECT_EQ(report.sequence(), 1u);
    EXPECT_EQ(report.error().code(), v1::ERROR_CODE_INVALID_ARGUMENT);
    EXPECT_LT(report.error().message().size(), 300u);
    EXPECT_TRUE(stream.finish().ok());

    // An object id of the same length in a pose: the same rule.
    query.set_scene_id(created.scene_id());
    query.add_poses()->set_object_id(id);
    const grpc::Status object = stub.Query(make_context().get(), query, &report);
    EXPECT_EQ(object.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_EQ(object.error_message().rfind("poses[0].object_id: ", 0), 0u);
    EXPECT_LT(object.error_message().size(), 300u);

    // The next call on the same channel works.
    v1::QueryRequest valid;
    valid.set_scene_id(created.scene_id());
    const grpc::Status answered = stub.Query(make_context().get(), valid, &report);
    ASSERT_TRUE(answered.ok()) << answered.error_message();
    EXPECT_EQ(report.pairs_size(), 1);
  }
  const std::string log = ::testing::internal::GetCapturedStderr();
  EXPECT_TRUE(contains(log, "event=request_rejected")) << log.substr(0, 2000);
  std::istringstream lines(log);
  std::size_t longest = 0;
  for (std::string line; std::getline(lines, line);) longest = std::max(longest, line.size());
  EXPECT_LT(longest, 1000u);
  EXPECT_LT(log.size(), 20'000u);

  v1::QueryRequest unknown;
  unknown.set_scene_id("no-such-scene");
  v1::DistanceReport report;
  const grpc::Status status = stub.Query(make_context().get(), unknown, &report);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(status.error_message(), "scene_id: no scene 'no-such-scene'");
}

// Guards the character sets (check_id, check_name): ids are printable ASCII without spaces and
// names UTF-8 text without control characters, on every kind of id and name, so that nothing a
// client names can break a log line, a message or a report; the error names the field.
TEST(IdLimits, IdsAndNamesOutsideTheirCharacterSetsAreRejectedNamingTheField) {
  RunningServer running = start_server();
  ASSERT_TRUE(running.server);
  v1::DistanceService::Stub& stub = *running.stub;
  const std::string sphere = register_sphere(stub);

  v1::RegisterGeometryRequest geometry;
  geometry.mutable_geometry()->add_pieces()->mutable_point();
  geometry.mutable_geometry()->set_name("arm\n level=error event=forged");
  v1::RegisterGeometryResponse registered;
  grpc::Status status = stub.RegisterGeometry(make_context().get(), geometry, &registered);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message().rfind("geometry.name: ", 0), 0u) << status.error_message();
  geometry.mutable_geometry()->set_name("Greifer \xC3\x84 links");  // UTF-8 text is a fine name
  EXPECT_TRUE(stub.RegisterGeometry(make_context().get(), geometry, &registered).ok());

  v1::RemoveGeometryRequest remove;
  remove.set_geometry_id(std::string(200, 'g'));
  v1::RemoveGeometryResponse removed;
  status = stub.RemoveGeometry(make_context().get(), remove, &removed);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(status.error_message().rfind("geometry_id: ", 0), 0u) << status.error_message();

  struct Case {
    const char* what;
    std::function<void(v1::CreateSceneRequest&)> mutate;
    const char* field;
  };
  const std::vector<Case> cases = {
      {"object id with a space", [](auto& r) { r.mutable_objects(0)->set_id("left arm"); },
       "objects[0].id: "},
      {"object id with a newline", [](auto& r) { r.mutable_objects(1)->set_id("b\nc"); },
       "objects[1].id: "},
      {"object id of 129 bytes",
       [](auto& r) { r.mutable_objects(1)->set_id(std::string(129, 'o')); }, "objects[1].id: "},
      {"geometry id of 10 kB",
       [](auto& r) { r.mutable_objects(0)->set_geometry_id(std::string(10000, 'g')); },
       "objects[0].geometry_id: "},
      {"scene id with a tab", [](auto& r) { r.set_scene_id("cell\t1"); }, "scene_id: "},
      {"scene name with an escape", [](auto& r) { r.set_name("cell \x1b[2J"); }, "name: "},
      {"scene name of 257 bytes", [](auto& r) { r.set_name(std::string(257, 'n')); }, "name: "},
      {"listed pair naming a 1 MB id",
       [](auto& r) {
         v1::ObjectPair& pair = *r.mutable_pair_selection()->mutable_listed_pairs()->add_pairs();
         pair.set_object_a("a");
         pair.set_object_b(std::string(1u << 20, 'b'));
       },
       "pair_selection.listed_pairs.pairs[0].object_b: "},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    v1::CreateSceneRequest create;
    for (const char* id : {"a", "b"}) {
      v1::SceneObject& object = *create.add_objects();
      object.set_id(id);
      object.set_geometry_id(sphere);
    }
    c.mutate(create);
    v1::CreateSceneResponse created;
    status = stub.CreateScene(make_context().get(), create, &created);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_EQ(status.error_message().rfind(c.field, 0), 0u) << status.error_message();
    EXPECT_LT(status.error_message().size(), 400u);
    EXPECT_EQ(status.error_message().find('\n'), std::string::npos);
  }
}

}  // namespace
}  // namespace nearpoint::server::testing
