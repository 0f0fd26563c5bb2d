// libFuzzer target: the protobuf request handlers of nearpointd in process, bytes → parse →
// validate → handle, as the gRPC adapter does it (server/src/grpc_services.cpp), without a
// network. An input is a sequence of up to 12 records, each an operation byte, a 16-bit length and
// that many bytes of a serialized request:
//   0 RegisterGeometryRequest  1 CreateSceneRequest  2 QueryRequest  3 PoseUpdate (one stream per
//   input)  4 RemoveGeometryRequest  5 DeleteSceneRequest
// on one fresh SceneService (small limits, one worker). Geometry ids are "geom-1", "geom-2", …
// and scene ids "scene-1", … in order of creation, so a seed can refer to what it made.
// Bytes that do not parse are what gRPC itself refuses before any handler runs: skipped.
// Invariants: every rejection is a known, non-internal error with a message and a gRPC status a
// client can act on; every accepted query and update yields one well-formed report per request
// (finite numbers, distance ≥ 0, one entry per pair, within the message limit).
#include <cstdint>
#include <memory>
#include <string>

#include "server_support.hpp"

namespace {

using namespace nearpoint;

constexpr int kMaxRecords = 12;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::ByteReader in(data, size);
  server::SceneService service(fuzz::small_limits(), 1);
  std::unique_ptr<server::PoseStream> stream;
  for (int record = 0; record < kMaxRecords && in.remaining() > 0; ++record) {
    const int op = in.byte() % 6;
    const std::string bytes = in.bytes(in.u16() % 4096);
    switch (op) {
      case 0: {
        v1::RegisterGeometryRequest request;
        if (!request.ParseFromString(bytes)) break;
        server::Expected<server::GeometryInfo> info =
            service.register_geometry(server::to_input(request.geometry()));
        if (!info) {
          fuzz::check_error(info.error(), "RegisterGeometry");
          break;
        }
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
        server::Expected<server::SceneInfo> info = service.create_scene(server::to_input(request));
        if (!info) fuzz::check_error(info.error(), "CreateScene");
        break;
      }
      case 2: {
        v1::QueryRequest request;
        if (!request.ParseFromString(bytes)) break;
        const server::QueryInput query = server::to_input(request);
        fuzz::ReportWaiter waiter;
        server::Outcome started = service.query(query, server::Clock::now(), waiter.callback());
        if (!started) {
          fuzz::check_error(started.error(), "Query");
          break;
        }
        fuzz::check_report(waiter.wait(), "Query");
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
        const server::PoseUpdateInput update = server::to_input(request);
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
        fuzz::check_report(waiter.wait(), "StreamPoses");
        break;
      }
      case 4: {
        v1::RemoveGeometryRequest request;
        if (!request.ParseFromString(bytes)) break;
        if (server::Outcome removed = service.remove_geometry(request.geometry_id()); !removed)
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
