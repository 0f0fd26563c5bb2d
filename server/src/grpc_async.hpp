// SPDX-License-Identifier: Apache-2.0
// nearpointd's gRPC server core: every method on gRPC's async generic API, driven by completion-
// queue threads of our own, with the callback API's reactor interface on top.
//
// Why not the callback API: on gRPC 1.51 (Debian 12) the callback queue's threads take part in
// polling and hand every message from thread to thread. An empty streaming server costs about
// 20 µs of CPU per message on the callback API and 10.5 µs on one completion-queue thread, and a
// single callback (or sync) service anywhere in the process brings the 20 µs back
// (bench/service/grpc_floor.cpp, "hybrid"). So the server has no callback or sync service at all:
// DistanceService, Diagnostics, health and reflection are all served here, routed by method path.
#pragma once

#include <grpcpp/generic/async_generic_service.h>
#include <grpcpp/grpcpp.h>

#include <condition_variable>
#include <cstddef>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "nearpoint/server/worker_pool.hpp"

namespace nearpoint::server {

class AsyncCall;

/// One call's logic, as a reactor of gRPC's callback API: at most one read and one write
/// outstanding, each answered by OnReadDone / OnWriteDone on a completion-queue thread (never
/// inline inside StartRead/StartWrite/Finish), OnCancel when the call is cancelled, and OnDone
/// exactly once, last, after Finish has completed and no other reaction is running. The
/// reactor owns itself: it is created by its method's factory and usually deletes itself in
/// OnDone. StartRead, StartWrite and Finish may be called from any thread.
class AsyncReactor {
 public:
  AsyncReactor(const AsyncReactor&) = delete;
  AsyncReactor& operator=(const AsyncReactor&) = delete;

  virtual void OnReadDone(bool /*ok*/) {}
  virtual void OnWriteDone(bool /*ok*/) {}
  virtual void OnCancel() {}
  virtual void OnDone() = 0;

 protected:
  explicit AsyncReactor(AsyncCall& call) : call_(call) {}
  virtual ~AsyncReactor() = default;

  /// The call's context (peer, metadata, cancellation); valid until OnDone returns.
  grpc::GenericServerContext* context() const;
  void StartRead(grpc::ByteBuffer* message);
  /// `message` may be reused once this returns (gRPC holds its own reference to the bytes).
  void StartWrite(const grpc::ByteBuffer* message);
  void Finish(const grpc::Status& status);
  /// A unary call's answer: `response` and OK in one operation.
  void FinishWithResponse(const grpc::ByteBuffer& response);

 private:
  AsyncCall& call_;
};

/// Makes the reactor of a call routed to a method (see AsyncGrpcServer::add_method). Runs on a
/// completion-queue thread, so it must not block.
using ReactorFactory = std::function<AsyncReactor*(AsyncCall& call)>;

/// A unary method's body: the request's bytes (valid until the call is ended), and the means to
/// end the call exactly once (possibly later, from another thread). Runs where its method says
/// (UnaryThread).
class UnaryCallHandle {
 public:
  virtual ~UnaryCallHandle() = default;
  virtual grpc::GenericServerContext* context() const = 0;
  /// Ends the call: `status`, with `response` when OK (ignored otherwise).
  virtual void finish(const grpc::Status& status, const grpc::ByteBuffer* response) = 0;
};
using UnaryHandler = std::function<void(const grpc::ByteBuffer& request,
                                        const std::shared_ptr<UnaryCallHandle>& call)>;

/// Where a unary method's handler runs.
enum class UnaryThread {
  /// On one of the server's control threads, never on a completion-queue thread, so that a long
  /// request (a large geometry's hull) holds up no stream.
  control,
  /// On the completion-queue thread that read the request: for handlers that answer in
  /// microseconds and must not wait behind long requests (health checks: a probe that times out
  /// takes a replica out of service).
  queue,
};

/// The generic service, its completion queue and threads, the method table, and the control
/// threads unary methods run on.
class AsyncGrpcServer {
 public:
  /// Registers the generic service and adds the completion queue; before builder.BuildAndStart().
  explicit AsyncGrpcServer(grpc::ServerBuilder& builder);
  ~AsyncGrpcServer();

  /// Routes `path` ("/package.Service/Method") to reactors made by `make`. Before start().
  void add_method(std::string path, ReactorFactory make);
  /// A unary method: one request message in, one response out (see UnaryHandler).
  void add_unary_method(std::string path, UnaryHandler handler,
                        UnaryThread thread = UnaryThread::control);

  /// Starts serving: `queue_threads` completion-queue threads and `control_threads` threads for
  /// unary handlers. After BuildAndStart().
  void start(int queue_threads, int control_threads);
  /// After grpc::Server::Shutdown() has returned (or BuildAndStart() failed): waits until every
  /// call is over, then shuts the queue down and joins every thread. Idempotent; not thread-safe
  /// (GrpcServer calls it under its shutdown lock). Before the server's shutdown it would wait
  /// for ever: the pending accept only completes then.
  void stop();

  /// Runs `task` on a control thread.
  void post(std::function<void()> task);

 private:
  friend class AsyncCall;
  void accept_next();
  /// Called by an accepted call: makes its reactor (UNIMPLEMENTED's for a path no method has).
  AsyncReactor* route(AsyncCall& call);
  void call_ended();
  void serve_queue();

  grpc::AsyncGenericService service_;
  std::unique_ptr<grpc::ServerCompletionQueue> queue_;
  std::unordered_map<std::string, ReactorFactory> methods_;
  std::vector<std::thread> queue_threads_;

  std::mutex calls_mutex_;
  std::condition_variable calls_over_;
  std::size_t live_calls_ = 0;  // calls requested or accepted, and not yet over
  bool shutting_down_ = false;

  std::unique_ptr<WorkerPool> control_;  // made by start()
  bool stopped_ = false;
};

}  // namespace nearpoint::server
