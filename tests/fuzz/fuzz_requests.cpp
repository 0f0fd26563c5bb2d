// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the protobuf request handlers of nearpointd in process, bytes → parse →
// validate → handle, as the gRPC adapter does it (server/src/grpc_services.cpp), without a
// network. An input is a sequence of up to 12 records, each an operation byte, a 16-bit length and
// that many bytes of a serialized request:
//   0 RegisterGeometryRequest  1 CreateSceneRequest  2 QueryRequest  3 PoseUpdate (one stream per
//   input)  4 RemoveGeometryRequest  5 DeleteSceneRequest
// on one fresh SceneService (small limits, one worker). A seed refers to what it made as
// "geom-1", "geom-2", … (the geometries it registered, in order; the server's ids are content
// hashes, which a seed cannot know, so the harness maps these names to them) and "scene-1", …
// (scene ids, server-assigned in order of creation).
// Bytes that do not parse are what gRPC itself refuses before any handler runs: skipped.
// Invariants: every rejection is a known, non-internal error with a message and a gRPC status a
// client can act on; every accepted query and update yields one well-formed report per request
// (finite numbers, distance ≥ 0, the entries its report mode allows, within the message limit).
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "server_support.hpp"

namespace {

using namespace nearpoint;

constexpr int kMaxRecords = 12;

// "geom-K" → the K-th geometry this input registered (see the header); other ids unchanged.
std::string stored_id(const std::string& id, const std::vector<std::string>& registered) {
  if (id.rfind("geom-", 0) != 0 || id.size() > 8) return id;
  std::size_t k = 0;
  for (std::size_t i = 5; i < id.size(); ++i) {
    if (id[i] < '0' || id[i] > '9') return id;
    k = 10 * k + std::size_t(id[i] - '0');
  }
  return k >= 1 && k <= registered.size() ? registered[k - 1] : id;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::ByteReader in(data, size);
  server::SceneService service(fuzz::small_limits(), 1);
  std::unique_ptr<server::PoseStream> stream;
  std::vector<std::string> registered;
  for (int record = 0; record < kMaxRecords && in.remaining() > 0; ++record) {
    const int op = in.byte() % 6;
    const std::string bytes = in.bytes(in.u16() % 4096);
    switch (op) {
      case 0: {
        v1::RegisterGeometryRequest request;
        if (!request.ParseFromString(bytes)) break;
        server::Expected<model::GeometryInfo> info =
            service.register_geometry(server::to_input(request.geometry()));
        if (!info) {
          fuzz::check_error(info.error(), "RegisterGeometry");
          break;
        }
        registered.push_back(info->geometry_id);
        NEARPOINT_FUZZ_CHECK(info->bounding_center.allFinite() &&
                                 std::isfinite(info->bounding_radius) && info->bounding_radius >= 0,
                             "RegisterGeometry: a non-finite bounding sphere");
        v1::GeometryInfo out;
        server::to_proto(info.value(), out);
        break;
      }
      case 1: {
        v1::CreateSceneRequest request;
        if (!request.ParseFromString(bytes)) break;
        for (v1::SceneObject& object : *request.mutable_objects())
          object.set_geometry_id(stored_id(object.geometry_id(), registered));
        server::Expected<model::SceneInfo> info = service.create_scene(server::to_input(request));
        if (!info) fuzz::check_error(info.error(), "CreateScene");
        break;
      }
      case 2: {
        v1::QueryRequest request;
        if (!request.ParseFromString(bytes)) break;
        const model::QueryInput query = server::to_input(request);
        fuzz::ReportWaiter waiter;
        server::Outcome started = service.query(query, server::Clock::now(), waiter.callback());
        if (!started) {
          fuzz::check_error(started.error(), "Query");
          break;
        }
        fuzz::check_report(waiter.wait(), true, "Query");
        break;
      }
      case 3: {
        v1::PoseUpdate request;
        if (!request.ParseFromString(bytes)) break;
        if (!stream) {
          server::Expected<std::unique_ptr<server::PoseStream>> opened = service.open_stream();
          if (!opened) {
            fuzz::check_error(opened.error(), "StreamPoses");
            break;
          }
          stream = std::move(opened.value());
        }
        const model::PoseUpdateInput update = server::to_input(request);
        server::Expected<server::PreparedUpdate> prepared =
            stream->prepare(update, server::Clock::now());
        if (!prepared) {
          fuzz::check_error(prepared.error(), "StreamPoses update");
          // What the reactor sends back for it must be a well-formed report too.
          v1::DistanceReport report;
          server::to_proto(prepared.error(), update.sequence, report);
          NEARPOINT_FUZZ_CHECK(report.ByteSizeLong() <= fuzz::kMaxMessageBytes,
                               "an error report larger than the message limit");
          break;
        }
        fuzz::ReportWaiter waiter;
        stream->evaluate(std::move(prepared.value()), waiter.callback());
        fuzz::check_report(waiter.wait(), false, "StreamPoses");
        break;
      }
      case 4: {
        v1::RemoveGeometryRequest request;
        if (!request.ParseFromString(bytes)) break;
        if (server::Outcome removed =
                service.remove_geometry(stored_id(request.geometry_id(), registered));
            !removed)
          fuzz::check_error(removed.error(), "RemoveGeometry");
        break;
      }
      default: {
        v1::DeleteSceneRequest request;
        if (!request.ParseFromString(bytes)) break;
        if (server::Outcome deleted = service.delete_scene(request.scene_id()); !deleted)
          fuzz::check_error(deleted.error(), "DeleteScene");
        break;
      }
    }
  }
  return 0;
}
