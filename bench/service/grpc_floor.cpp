// SPDX-License-Identifier: Apache-2.0
// nearpoint_grpc_floor: what gRPC itself costs a server per streamed message on this machine,
// with nothing of nearpoint in it, for issue 36's question "can any server reach 100,000 updates
// per CPU-second unbatched over gRPC 1.51?". A child process serves one bidi-streaming generic
// method that answers every request (a byte string the size of a pose update) with a reply (the
// size of a report); this process keeps STREAMS streams with WINDOW requests in flight each,
// exactly like `nearpoint load`, and reads the child's CPU time from /proc before and after the
// measured seconds, as bench/service/capacity.sh does for nearpointd. Server kinds:
//   callback — grpc::CallbackGenericService, one ServerBidiReactor per stream: the API
//              nearpointd serves StreamPoses with (gRPC's callback queue and its threads);
//   async    — grpc::AsyncGenericService on a completion queue drained by --server-threads
//              threads of the server's own (default 1), and no callback method at all: the
//              "every RPC on the async API" server that RESULTS.md names as the only lever left;
//   hybrid   — async, plus one callback service that is never called (nearpoint.v1.Diagnostics
//              with its default methods): whether a single callback service anywhere in the
//              process brings back the callback API's cost (it does: nearpointd therefore
//              serves every method, health and reflection included, on the async API).
// The server does no work beyond copying the reply, so a kind's figure is an upper bound for any
// server built on it here: messages per CPU-second of the child, and CPU µs per message.
//
//   nearpoint_grpc_floor [--seconds 4] [--streams 4] [--window 4] [--rounds 2]
//                        [--request-bytes 96] [--reply-bytes 320] [--server-threads 1]
//                        [--minimal-stack 0|1]  (GRPC_ARG_MINIMAL_STACK on both ends)
#include <grpcpp/generic/async_generic_service.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <signal.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bench_support.hpp"
#include "common/child_process.hpp"
#include "nearpoint_diagnostics.grpc.pb.h"

namespace {

using Clock = std::chrono::steady_clock;
using nearpoint::testkit::ChildProcess;

constexpr const char* kMethod = "/nearpoint.floor.Echo/Stream";

grpc::ByteBuffer bytes_of_size(std::size_t size) {
  const std::string payload(size, 'x');
  grpc::Slice slice(payload);
  return grpc::ByteBuffer(&slice, 1);
}

// ---------------------------------------------------------------------------------------------
// Both servers keep one read outstanding at all times and one write; replies that find a write
// in progress wait (as nearpointd's reports do). What a stream's completions decide, the same for
// both APIs; the caller holds the stream's lock.
struct ReplyQueue {
  bool writing = false;
  bool reading_done = false;
  bool finished = false;
  std::size_t queued = 0;

  /// A request arrived: true if its reply is to be written now (else it waits).
  bool on_request() {
    if (writing) {
      ++queued;
      return false;
    }
    writing = true;
    return true;
  }
  /// A write completed: true if the next waiting reply is to be written now.
  bool on_written(bool ok) {
    writing = false;
    if (!ok) queued = 0;
    if (queued == 0) return false;
    --queued;
    writing = true;
    return true;
  }
  /// True once, when the client has half-closed and every reply is written: finish the call.
  bool finish_now() {
    if (!reading_done || writing || finished) return false;
    finished = true;
    return true;
  }
};

// Server, callback API: one reactor per stream.
class CallbackEcho final : public grpc::ServerGenericBidiReactor {
 public:
  explicit CallbackEcho(std::size_t reply_bytes) : reply_(bytes_of_size(reply_bytes)) {
    StartRead(&request_);
  }

  void OnReadDone(bool ok) override {
    std::lock_guard lock(mutex_);
    if (!ok) {
      queue_.reading_done = true;
      if (queue_.finish_now()) Finish(grpc::Status::OK);
      return;
    }
    if (queue_.on_request()) StartWrite(&reply_);
    StartRead(&request_);
  }

  void OnWriteDone(bool ok) override {
    std::lock_guard lock(mutex_);
    if (queue_.on_written(ok))
      StartWrite(&reply_);
    else if (queue_.finish_now())
      Finish(grpc::Status::OK);
  }

  void OnDone() override { delete this; }

 private:
  grpc::ByteBuffer request_;
  grpc::ByteBuffer reply_;
  std::mutex mutex_;
  ReplyQueue queue_;
};

class CallbackService final : public grpc::CallbackGenericService {
 public:
  explicit CallbackService(std::size_t reply_bytes) : reply_bytes_(reply_bytes) {}
  grpc::ServerGenericBidiReactor* CreateReactor(grpc::GenericCallbackServerContext*) override {
    return new CallbackEcho(reply_bytes_);
  }

 private:
  std::size_t reply_bytes_;
};

// ---------------------------------------------------------------------------------------------
// Server, async API: every call is a small state machine driven by completion-queue tags.

class AsyncCall;

struct Tag {
  enum Kind { kAccepted, kRead, kWritten, kFinished } kind;
  AsyncCall* call;
};

class AsyncCall {
 public:
  AsyncCall(grpc::AsyncGenericService& service, grpc::ServerCompletionQueue& cq,
            std::size_t reply_bytes)
      : service_(service),
        cq_(cq),
        reply_bytes_(reply_bytes),
        stream_(&context_),
        reply_(bytes_of_size(reply_bytes)) {
    service_.RequestCall(&context_, &stream_, &cq_, &cq_, &accepted_);
  }

  /// Handles one completion; false when the call is over and may be deleted.
  bool proceed(Tag::Kind kind, bool ok) {
    std::lock_guard lock(mutex_);
    switch (kind) {
      case Tag::kAccepted:
        if (!ok) return false;                       // the server is shutting down
        new AsyncCall(service_, cq_, reply_bytes_);  // the next stream's slot
        start(&AsyncCall::read);
        return true;
      case Tag::kRead:
        --pending_;
        if (!ok) {
          queue_.reading_done = true;
          if (queue_.finish_now()) start(&AsyncCall::finish);
          return pending_ > 0;
        }
        if (queue_.on_request()) start(&AsyncCall::write);
        start(&AsyncCall::read);
        return true;
      case Tag::kWritten:
        --pending_;
        if (queue_.on_written(ok))
          start(&AsyncCall::write);
        else if (queue_.finish_now())
          start(&AsyncCall::finish);
        return pending_ > 0;
      case Tag::kFinished:
        --pending_;
        return pending_ > 0;
    }
    return true;
  }

 private:
  // Every operation started is one completion to come; the call is deleted after the last.
  void start(void (AsyncCall::*operation)()) {
    ++pending_;
    (this->*operation)();
  }
  void read() { stream_.Read(&request_, &read_); }
  void write() { stream_.Write(reply_, &written_); }
  void finish() { stream_.Finish(grpc::Status::OK, &finished_tag_); }

  grpc::AsyncGenericService& service_;
  grpc::ServerCompletionQueue& cq_;
  std::size_t reply_bytes_;
  grpc::GenericServerContext context_;
  grpc::GenericServerAsyncReaderWriter stream_;
  grpc::ByteBuffer request_;
  grpc::ByteBuffer reply_;
  std::mutex mutex_;
  ReplyQueue queue_;
  int pending_ = 0;
  Tag accepted_{Tag::kAccepted, this};
  Tag read_{Tag::kRead, this};
  Tag written_{Tag::kWritten, this};
  Tag finished_tag_{Tag::kFinished, this};
};

/// The child: serves until it is killed (the parent kills it once it has read its CPU time).
int serve(const std::string& kind, std::size_t reply_bytes, int threads, bool minimal_stack) {
  prctl(PR_SET_PDEATHSIG, SIGKILL);  // never outlive the benchmark
  grpc::ServerBuilder builder;
  if (minimal_stack) builder.AddChannelArgument(GRPC_ARG_MINIMAL_STACK, 1);
  int port = 0;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  CallbackService callback_service(reply_bytes);
  grpc::AsyncGenericService async_service;
  nearpoint::v1::Diagnostics::CallbackService idle_callback_service;
  std::unique_ptr<grpc::ServerCompletionQueue> cq;
  if (kind == "callback") {
    builder.RegisterCallbackGenericService(&callback_service);
  } else if (kind == "async" || kind == "hybrid") {
    builder.RegisterAsyncGenericService(&async_service);
    cq = builder.AddCompletionQueue();
    if (kind == "hybrid") builder.RegisterService(&idle_callback_service);
  } else {
    std::fprintf(stderr, "unknown server kind %s\n", kind.c_str());
    return 2;
  }
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  if (!server) return 1;
  std::vector<std::thread> drainers;
  if (cq) {
    new AsyncCall(async_service, *cq, reply_bytes);
    for (int t = 0; t < threads; ++t)
      drainers.emplace_back([&cq] {
        void* raw = nullptr;
        bool ok = false;
        while (cq->Next(&raw, &ok)) {
          auto* tag = static_cast<Tag*>(raw);
          if (!tag->call->proceed(tag->kind, ok)) delete tag->call;
        }
      });
  }
  std::fprintf(stderr, "listening %d %d\n", port, int(getpid()));
  for (;;) pause();
}

// ---------------------------------------------------------------------------------------------
// Client: STREAMS streams on one channel, WINDOW requests in flight each, one completion queue
// drained by one thread, like `nearpoint load`.

struct ClientStream;

struct ClientTag {
  enum Kind { kStarted, kRead, kWritten, kWritesDone, kFinished } kind;
  ClientStream* stream;
};

struct ClientStream {
  ClientStream() {
    for (int k = 0; k < 5; ++k) tags[k] = {ClientTag::Kind(k), this};
  }
  ClientTag* tag(ClientTag::Kind kind) { return &tags[kind]; }

  ClientTag tags[5];
  grpc::ClientContext context;
  std::unique_ptr<grpc::GenericClientAsyncReaderWriter> call;
  grpc::ByteBuffer reply;
  grpc::Status status;
  int in_flight = 0;
  bool writing = false;
  bool stopping = false;
  bool writes_done = false;
};

double process_cpu_seconds(int pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string stat((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::istringstream fields(stat.substr(stat.rfind(')') + 2));
  std::string field;
  unsigned long long utime = 0, stime = 0;
  for (int i = 3; i <= 15 && fields >> field; ++i) {
    if (i == 14) utime = std::stoull(field);
    if (i == 15) stime = std::stoull(field);
  }
  return double(utime + stime) / double(sysconf(_SC_CLK_TCK));
}

struct Measured {
  double messages_per_cpu_second = 0;
  double cpu_us_per_message = 0;
  double messages_per_second = 0;
  std::string error;
};

Measured drive(const std::string& target, int server_pid, int streams, int window,
               std::size_t request_bytes, double seconds, bool minimal_stack) {
  grpc::ChannelArguments arguments;
  if (minimal_stack) arguments.SetInt(GRPC_ARG_MINIMAL_STACK, 1);
  auto channel = grpc::CreateCustomChannel(target, grpc::InsecureChannelCredentials(), arguments);
  grpc::GenericStub stub(channel);
  grpc::CompletionQueue cq;
  const grpc::ByteBuffer request = bytes_of_size(request_bytes);
  std::vector<std::unique_ptr<ClientStream>> all;
  for (int s = 0; s < streams; ++s) {
    auto stream = std::make_unique<ClientStream>();
    stream->call = stub.PrepareCall(&stream->context, kMethod, &cq);
    stream->call->StartCall(stream->tag(ClientTag::kStarted));
    all.push_back(std::move(stream));
  }
  // One write at a time per stream (gRPC's rule), up to `window` requests unanswered; once
  // stopping, the last replies are drained and the stream half-closed.
  auto send_more = [&](ClientStream& stream) {
    if (stream.writing || stream.writes_done) return;
    if (stream.stopping) {
      if (stream.in_flight == 0) {
        stream.writes_done = true;
        stream.call->WritesDone(stream.tag(ClientTag::kWritesDone));
      }
      return;
    }
    if (stream.in_flight >= window) return;
    ++stream.in_flight;
    stream.writing = true;
    stream.call->Write(request, stream.tag(ClientTag::kWritten));
  };

  const auto warm_until = Clock::now() + std::chrono::milliseconds(500);
  const auto stop_at = warm_until + std::chrono::duration_cast<Clock::duration>(
                                        std::chrono::duration<double>(seconds));
  bool measuring = false;
  double cpu_at_start = 0;
  Clock::time_point started;
  std::uint64_t replies = 0, replies_at_start = 0;
  double cpu_seconds = 0, wall_seconds = 0;
  // An error ends the run; every call is cancelled and the queue drained first, since gRPC
  // requires a completion queue to be empty when it is destroyed.
  auto fail = [&](std::string why) {
    for (auto& each : all) each->context.TryCancel();
    cq.Shutdown();
    void* ignored_tag = nullptr;
    bool ignored_ok = false;
    while (cq.Next(&ignored_tag, &ignored_ok)) {
    }
    return Measured{0, 0, 0, std::move(why)};
  };
  int finished = 0;
  while (finished < streams) {
    void* raw = nullptr;
    bool ok = false;
    if (cq.AsyncNext(&raw, &ok, std::chrono::system_clock::now() + std::chrono::seconds(10)) !=
        grpc::CompletionQueue::GOT_EVENT) {
      return fail("no completion for 10 s");
    }
    auto* tag = static_cast<ClientTag*>(raw);
    ClientStream& stream = *tag->stream;
    const auto now = Clock::now();
    if (!measuring && now >= warm_until) {
      measuring = true;
      cpu_at_start = process_cpu_seconds(server_pid);
      started = now;
      replies_at_start = replies;
    }
    if (measuring && now >= stop_at && wall_seconds == 0) {
      cpu_seconds = process_cpu_seconds(server_pid) - cpu_at_start;
      wall_seconds = std::chrono::duration<double>(now - started).count();
      replies -= replies_at_start;
      for (auto& each : all) each->stopping = true;
    }
    switch (tag->kind) {
      case ClientTag::kStarted:
        if (!ok) return fail("stream did not start");
        stream.call->Read(&stream.reply, stream.tag(ClientTag::kRead));
        send_more(stream);
        break;
      case ClientTag::kRead:
        if (!ok) {  // the server has finished: collect its status
          if (!stream.writes_done) return fail("the server ended a stream");
          stream.call->Finish(&stream.status, stream.tag(ClientTag::kFinished));
          break;
        }
        --stream.in_flight;
        if (wall_seconds == 0) ++replies;
        stream.call->Read(&stream.reply, stream.tag(ClientTag::kRead));
        send_more(stream);
        break;
      case ClientTag::kWritten:
        stream.writing = false;
        if (!ok) return fail("write failed");
        send_more(stream);
        break;
      case ClientTag::kWritesDone:
        break;
      case ClientTag::kFinished:
        if (!stream.status.ok()) return fail(stream.status.error_message());
        ++finished;
        break;
    }
  }
  if (cpu_seconds <= 0) return {0, 0, 0, "the server used no measurable CPU"};
  return {double(replies) / cpu_seconds, cpu_seconds * 1e6 / double(replies),
          double(replies) / wall_seconds, ""};
}

int run(int argc, char** argv) {
  double seconds = 4;
  int streams = 4, window = 4, rounds = 2, server_threads = 1, minimal_stack = 0;
  std::size_t request_bytes = 96, reply_bytes = 320;
  if (argc % 2 == 0) {
    std::fprintf(stderr, "every flag takes a value: %s\n", argv[argc - 1]);
    return 2;
  }
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    const char* value = argv[i + 1];
    if (flag == "--seconds")
      seconds = std::atof(value);
    else if (flag == "--streams")
      streams = std::atoi(value);
    else if (flag == "--window")
      window = std::atoi(value);
    else if (flag == "--rounds")
      rounds = std::atoi(value);
    else if (flag == "--request-bytes")
      request_bytes = std::size_t(std::atol(value));
    else if (flag == "--reply-bytes")
      reply_bytes = std::size_t(std::atol(value));
    else if (flag == "--server-threads")
      server_threads = std::atoi(value);
    else if (flag == "--minimal-stack")
      minimal_stack = std::atoi(value);
    else {
      std::fprintf(stderr, "unknown flag %s\n", flag.c_str());
      return 2;
    }
  }
  if (seconds <= 0 || seconds > 60 || streams < 1 || streams > 64 || window < 1 || window > 256 ||
      rounds < 1 || rounds > 10 || server_threads < 1 || server_threads > 16) {
    std::fprintf(stderr,
                 "out of range: --seconds (0,60] --streams 1-64 --window 1-256 "
                 "--rounds 1-10 --server-threads 1-16\n");
    return 2;
  }
  std::printf("# nearpoint_grpc_floor, %s, %s, gRPC %s\n", bench_support::utc_date().c_str(),
              bench_support::cpu_model().c_str(), grpc::Version().c_str());
  std::printf(
      "# %d streams x %d in flight, %.1f s per row, request %zu B, reply %zu B, "
      "async server threads %d, minimal stack %s\n",
      streams, window, seconds, request_bytes, reply_bytes, server_threads,
      minimal_stack ? "on" : "off");
  std::printf(
      "| round | server | messages per CPU-second | CPU µs per message | messages per s |\n"
      "|---:|---|---:|---:|---:|\n");
  const std::string self = std::filesystem::read_symlink("/proc/self/exe").string();
  int failures = 0;
  for (int round = 1; round <= rounds; ++round) {
    for (const char* kind : {"callback", "async", "hybrid"}) {
      ChildProcess child({self, "--serve", kind, "--reply-bytes", std::to_string(reply_bytes),
                          "--server-threads", std::to_string(server_threads), "--minimal-stack",
                          std::to_string(minimal_stack)});
      const std::string line = child.wait_for_stderr("listening", std::chrono::seconds(10));
      Measured measured;
      int port = 0, pid = 0;
      if (std::sscanf(line.c_str(), "listening %d %d", &port, &pid) != 2) {
        measured.error = "server did not start: " + child.stderr_text();
      } else {
        measured = drive("127.0.0.1:" + std::to_string(port), pid, streams, window, request_bytes,
                         seconds, minimal_stack != 0);
      }
      child.signal(SIGKILL);
      child.wait_exit(std::chrono::seconds(10));
      if (!measured.error.empty()) {
        ++failures;
        std::printf("| %d | %s | error: %s | | |\n", round, kind, measured.error.c_str());
      } else {
        std::printf("| %d | %s | %.0f | %.2f | %.0f |\n", round, kind,
                    measured.messages_per_cpu_second, measured.cpu_us_per_message,
                    measured.messages_per_second);
      }
      std::fflush(stdout);
    }
  }
  return failures == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 3 && std::strcmp(argv[1], "--serve") == 0) {
    std::size_t reply_bytes = 320;
    int threads = 1, minimal_stack = 0;
    for (int i = 3; i + 1 < argc; i += 2) {
      if (std::strcmp(argv[i], "--minimal-stack") == 0) minimal_stack = std::atoi(argv[i + 1]);
      if (std::strcmp(argv[i], "--reply-bytes") == 0)
        reply_bytes = std::size_t(std::atol(argv[i + 1]));
      if (std::strcmp(argv[i], "--server-threads") == 0) threads = std::atoi(argv[i + 1]);
    }
    return serve(argv[2], reply_bytes, threads, minimal_stack != 0);
  }
  return run(argc, argv);
}
