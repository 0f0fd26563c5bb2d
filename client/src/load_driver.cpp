// SPDX-License-Identifier: Apache-2.0
#include "load_driver.hpp"

#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <chrono>
#include <deque>
#include <memory>

#include "channel.hpp"  // the client library's channel, credentials and routing rule
#include "convert.hpp"
#include "nearpoint_distance.grpc.pb.h"
#include "scene_lease.hpp"

namespace nearpoint::cli {
namespace {

namespace v1 = ::nearpoint::v1;
using client::Clock;

enum class Op { started, read, written, writes_done, finished };

struct Stream;
struct Tag {
  Stream* stream;
  Op op;
};

// One StreamPoses (or StreamPoseBatches) call. Every field is touched by the driving thread only.
struct Stream {
  grpc::ClientContext context;
  std::unique_ptr<grpc::ClientAsyncReaderWriter<v1::PoseUpdate, v1::DistanceReport>> single;
  std::unique_ptr<grpc::ClientAsyncReaderWriter<v1::PoseUpdateBatch, v1::DistanceReportBatch>>
      batched;
  // Read into again and again: protobuf keeps the pairs' storage from report to report.
  v1::DistanceReport report;
  v1::DistanceReportBatch reports;
  v1::PoseUpdateBatch outgoing;  // batched only
  grpc::Status status;
  Tag tags[5];

  struct InFlight {
    std::uint64_t sequence;
    Clock::time_point sent;
  };
  std::deque<InFlight> in_flight;
  std::size_t step = 0;  // the next pose set of the path
  std::uint64_t next_sequence = 1;
  int pending = 0;           // operations started and not yet completed
  bool writing = false;      // gRPC allows one write at a time
  bool stopping = false;     // no more updates: half-close once the window is empty
  bool half_closed = false;  // WritesDone called
  bool reads_over = false;   // the server ended the stream
  bool finishing = false;    // Finish called

  void* tag(Op op) {
    ++pending;
    tags[int(op)] = {this, op};
    return &tags[int(op)];
  }
};

}  // namespace

LoadResult drive_load(const LoadPlan& plan) {
  const std::vector<std::vector<client::ObjectPose>>& path = *plan.path;
  const std::size_t batch = std::max<std::size_t>(1, plan.batch);
  const std::size_t window = std::max(plan.window, batch);

  // Every update of the path, built once; a write only stamps its sequence number (gRPC
  // serialises the message inside Write, so the next stamp cannot reach the one in flight).
  std::vector<v1::PoseUpdate> updates(path.size());
  for (std::size_t i = 0; i < path.size(); ++i) {
    v1::PoseUpdate& update = updates[i];
    update.set_scene_id(plan.scene_id);
    update.set_flow_control(v1::FLOW_CONTROL_BLOCK);  // every update answered: one latency each
    client::detail::to_proto(client::QueryOptions{}, *update.mutable_options());
    for (const client::ObjectPose& pose : path[i])
      client::detail::to_proto(pose, *update.add_poses());
  }

  const auto channel = client::detail::make_channel(plan.target, plan.client_options);
  const auto stub = v1::DistanceService::NewStub(channel);
  grpc::CompletionQueue queue;
  LoadResult result;
  auto error = [&](std::size_t count, const std::string& why) {
    if (count == 0) return;
    result.errors += count;
    if (result.first_error.empty()) result.first_error = why;
  };

  const Clock::time_point start = Clock::now();
  const Clock::time_point stop_at = start + std::chrono::duration_cast<Clock::duration>(
                                                std::chrono::duration<double>(plan.duration_s));
  // A server that stops answering fails its calls 10 s after the end instead of hanging here.
  const auto call_deadline =
      std::chrono::system_clock::now() +
      std::chrono::duration_cast<std::chrono::system_clock::duration>(
          std::chrono::duration<double>(plan.duration_s) + std::chrono::seconds(10));

  std::vector<std::unique_ptr<Stream>> streams;
  for (int k = 0; k < plan.streams; ++k) {
    auto stream = std::make_unique<Stream>();
    // Streams start at different points of the path, so they do not run in lock step.
    stream->step = std::size_t(k) * path.size() / std::size_t(plan.streams);
    stream->context.set_deadline(call_deadline);
    if (client::detail::routable(plan.scene_id))
      stream->context.AddMetadata(client::kSceneRoutingHeader, plan.scene_id);
    if (batch > 1) {
      stream->batched = stub->PrepareAsyncStreamPoseBatches(&stream->context, &queue);
      stream->batched->StartCall(stream->tag(Op::started));
    } else {
      stream->single = stub->PrepareAsyncStreamPoses(&stream->context, &queue);
      stream->single->StartCall(stream->tag(Op::started));
    }
    streams.push_back(std::move(stream));
  }

  auto read = [](Stream& s) {
    if (s.batched)
      s.batched->Read(&s.reports, s.tag(Op::read));
    else
      s.single->Read(&s.report, s.tag(Op::read));
  };
  // Once the server has ended the stream and no write is outstanding: collect its status.
  auto finish_if_over = [](Stream& s) {
    if (!s.reads_over || s.writing || s.finishing) return;
    s.finishing = true;
    if (s.batched)
      s.batched->Finish(&s.status, s.tag(Op::finished));
    else
      s.single->Finish(&s.status, s.tag(Op::finished));
  };
  // Fills the window: one write at a time, each a whole batch, while `window` updates are not
  // yet in flight; once stopping, half-closes after the last report.
  auto send_more = [&](Stream& s) {
    if (s.writing || s.half_closed || s.reads_over) return;
    if (s.stopping) {
      if (s.in_flight.empty()) {
        s.half_closed = true;
        if (s.batched)
          s.batched->WritesDone(s.tag(Op::writes_done));
        else
          s.single->WritesDone(s.tag(Op::writes_done));
      }
      return;
    }
    if (s.in_flight.size() + batch > window) return;
    s.writing = true;
    const Clock::time_point now = Clock::now();
    if (s.batched) {
      s.outgoing.clear_updates();
      for (std::size_t i = 0; i < batch; ++i) {
        v1::PoseUpdate& update = *s.outgoing.add_updates();
        update = updates[s.step++ % updates.size()];
        update.set_sequence(s.next_sequence);
        s.in_flight.push_back({s.next_sequence++, now});
      }
      s.batched->Write(s.outgoing, s.tag(Op::written));
    } else {
      v1::PoseUpdate& update = updates[s.step++ % updates.size()];
      update.set_sequence(s.next_sequence);
      s.in_flight.push_back({s.next_sequence++, now});
      s.single->Write(update, s.tag(Op::written));
    }
  };
  // One report: every update up to its sequence number is answered (those before it were merged
  // into it by the server, and have no latency of their own).
  auto take = [&](Stream& s, const v1::DistanceReport& report) {
    const Clock::time_point received = Clock::now();
    while (!s.in_flight.empty() && s.in_flight.front().sequence <= report.sequence()) {
      if (s.in_flight.front().sequence == report.sequence() && !report.has_error())
        result.latencies_us.push_back(
            std::chrono::duration<double, std::micro>(received - s.in_flight.front().sent).count());
      s.in_flight.pop_front();
    }
    if (report.has_error()) {
      error(1, client::detail::from_proto(report.error()).describe());
      return;
    }
    result.geometry_us += report.timing().geometry_us();
  };

  bool stopped = false, cancelled = false;
  Clock::time_point next_progress =
      plan.progress_every > 0 ? start + std::chrono::duration_cast<Clock::duration>(
                                            std::chrono::duration<double>(plan.progress_every))
                              : Clock::time_point::max();
  auto pending = [&] {
    int total = 0;
    for (const auto& s : streams) total += s->pending;
    return total;
  };
  while (pending() > 0) {
    const Clock::time_point now = Clock::now();
    if (!stopped && (now >= stop_at || interrupt_signal() != 0)) {
      stopped = true;
      for (auto& s : streams) {
        s->stopping = true;
        send_more(*s);
      }
    }
    if (!cancelled && interrupt_signal() != 0) {
      // Interrupted: the reports still in flight are not waited for.
      cancelled = true;
      for (auto& s : streams) s->context.TryCancel();
    }
    if (now >= next_progress) {
      if (plan.progress)
        plan.progress(std::chrono::duration<double>(now - start).count(),
                      result.latencies_us.size(), result.errors);
      next_progress += std::chrono::duration_cast<Clock::duration>(
          std::chrono::duration<double>(plan.progress_every));
    }
    // Wake for the end, the next progress line, or at least every 100 ms (an interrupt).
    Clock::time_point wake = std::min(now + std::chrono::milliseconds(100), next_progress);
    if (!stopped) wake = std::min(wake, stop_at);
    void* raw = nullptr;
    bool ok = false;
    const auto status =
        queue.AsyncNext(&raw, &ok,
                        std::chrono::system_clock::now() +
                            std::chrono::duration_cast<std::chrono::system_clock::duration>(
                                std::max(wake - now, Clock::duration::zero())));
    if (status != grpc::CompletionQueue::GOT_EVENT) continue;
    const Tag& tag = *static_cast<Tag*>(raw);
    Stream& s = *tag.stream;
    --s.pending;
    switch (tag.op) {
      case Op::started:
        if (!ok) {  // no call: its status says why
          s.reads_over = true;
          finish_if_over(s);
          break;
        }
        read(s);
        send_more(s);
        break;
      case Op::read:
        if (!ok) {
          s.reads_over = true;
          finish_if_over(s);
          break;
        }
        if (s.batched) {
          for (const v1::DistanceReport& report : s.reports.reports()) take(s, report);
        } else {
          take(s, s.report);
        }
        read(s);
        send_more(s);
        break;
      case Op::written:
        s.writing = false;
        // A failed write means the stream is over; the pending read says so and finishes it.
        if (ok) send_more(s);
        finish_if_over(s);
        break;
      case Op::writes_done:
        break;
      case Op::finished:
        // Updates the stream never answered are lost with it; a stream that ended before this
        // side half-closed is an error even with none in flight. After an interrupt (which
        // cancelled the calls) neither is counted.
        if (cancelled) {
          // not an error: the user stopped the load
        } else if (!s.status.ok()) {
          error(std::max<std::size_t>(1, s.in_flight.size()),
                "the stream failed: " +
                    client::Status::error(int(s.status.error_code()), s.status.error_message())
                        .describe());
        } else if (!s.half_closed || !s.in_flight.empty()) {
          error(std::max<std::size_t>(1, s.in_flight.size()),
                "the server ended the stream before answering every update");
        }
        s.in_flight.clear();
        break;
    }
  }
  queue.Shutdown();
  void* ignored_tag = nullptr;
  bool ignored_ok = false;
  while (queue.Next(&ignored_tag, &ignored_ok)) {
  }
  result.elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
  return result;
}

}  // namespace nearpoint::cli
