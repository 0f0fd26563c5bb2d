// SPDX-License-Identifier: Apache-2.0
#include "grpc_async.hpp"

#include <algorithm>
#include <array>
#include <utility>

#include "tsan_handoff.hpp"

namespace nearpoint::server {

/// One call on the async generic API: its context and stream, the tags of its operations, and
/// the bookkeeping that turns completions into the reactor's reactions (see AsyncReactor).
///
/// Lifetime: created with a pending RequestCall; deleted by the completion-queue thread that
/// finds the call over: Finish completed, the done notification (AsyncNotifyWhenDone) received,
/// no read or write outstanding and no reaction running. Then OnDone runs, and the call goes.
class AsyncCall {
 public:
  explicit AsyncCall(AsyncGrpcServer& server) : server_(server), stream_(&context_) {
    context_.AsyncNotifyWhenDone(&done_tag_);
    // The completions come back through gRPC's queue, whose synchronisation TSan cannot see
    // (tsan_handoff.hpp): this construction happens before every one of them. Later, the
    // reactor's construction and its reactions are ordered by mutex_ (bound_).
    handoff_release(this);
    server.service_.RequestCall(&context_, &stream_, server.queue_.get(), server.queue_.get(),
                                &accepted_tag_);
  }

  grpc::GenericServerContext* context() { return &context_; }

  void start_read(grpc::ByteBuffer* message) {
    begin_operation();
    stream_.Read(message, &read_tag_);
  }
  void start_write(const grpc::ByteBuffer* message) {
    begin_operation();
    stream_.Write(*message, &write_tag_);
  }
  void finish(const grpc::Status& status) {
    begin_operation();
    stream_.Finish(status, &finish_tag_);
  }
  void finish_with_response(const grpc::ByteBuffer& response) {
    begin_operation();
    stream_.WriteAndFinish(response, grpc::WriteOptions(), grpc::Status::OK, &finish_tag_);
  }

  enum class Event { accepted, read, written, finished, done };
  struct Tag {
    AsyncCall* call;
    Event event;
  };

  /// One completion of this call's, on a completion-queue thread.
  void on_completion(Event event, bool ok) {
    handoff_acquire(this);
    if (event == Event::accepted) return on_accepted(ok);
    {
      std::lock_guard lock(mutex_);
      if (event == Event::done) {
        done_received_ = true;
        ok = context_.IsCancelled();  // the reaction is OnCancel, if cancelled
      } else {
        --operations_;
        if (event == Event::finished) finished_ = true;
      }
      if (!bound_) {
        // The reactor is still being made (its constructor started this operation): its
        // reactions wait until it exists, as the callback API's backlog holds them.
        early_[early_count_++] = {event, ok};
        return;
      }
      ++reactions_;
    }
    react(event, ok);
    reaction_over();
  }

 private:
  void begin_operation() {
    std::lock_guard lock(mutex_);
    ++operations_;
  }

  void on_accepted(bool ok) {
    // Not accepted: the server is shutting down; the done notification never comes for a call
    // that did not start.
    if (!ok) {
      AsyncGrpcServer& server = server_;
      delete this;
      server.call_ended();
      return;
    }
    server_.accept_next();  // the slot for the next call
    AsyncReactor* reactor = server_.route(*this);
    std::array<std::pair<Event, bool>, 4> early;
    std::size_t early_count = 0;
    {
      std::lock_guard lock(mutex_);
      reactor_ = reactor;
      bound_ = true;
      early = early_;
      early_count = early_count_;
      reactions_ += early_count + 1;  // + 1: this thread, until reaction_over() below
    }
    for (std::size_t i = 0; i < early_count; ++i) {
      react(early[i].first, early[i].second);
      reaction_over();
    }
    reaction_over();
  }

  void react(Event event, bool ok) {
    switch (event) {
      case Event::read:
        reactor_->OnReadDone(ok);
        break;
      case Event::written:
        reactor_->OnWriteDone(ok);
        break;
      case Event::done:
        if (ok) reactor_->OnCancel();
        break;
      case Event::finished:
      case Event::accepted:
        break;
    }
  }

  void reaction_over() {
    {
      std::lock_guard lock(mutex_);
      --reactions_;
      if (reactions_ > 0 || operations_ > 0 || !finished_ || !done_received_ || over_) return;
      over_ = true;
    }
    reactor_->OnDone();
    AsyncGrpcServer& server = server_;
    delete this;
    server.call_ended();
  }

  AsyncGrpcServer& server_;
  grpc::GenericServerContext context_;
  grpc::GenericServerAsyncReaderWriter stream_;
  Tag accepted_tag_{this, Event::accepted};
  Tag read_tag_{this, Event::read};
  Tag write_tag_{this, Event::written};
  Tag finish_tag_{this, Event::finished};
  Tag done_tag_{this, Event::done};

  std::mutex mutex_;
  AsyncReactor* reactor_ = nullptr;
  bool bound_ = false;
  /// Completions that arrived while the reactor was being made (a read, a write, the finish and
  /// the done notification at most).
  std::array<std::pair<Event, bool>, 4> early_{};
  std::size_t early_count_ = 0;
  int operations_ = 0;  // started and not yet completed
  int reactions_ = 0;   // running now
  bool finished_ = false;
  bool done_received_ = false;
  bool over_ = false;
};

// ---- AsyncReactor ----

grpc::GenericServerContext* AsyncReactor::context() const {
  return call_.context();
}
void AsyncReactor::StartRead(grpc::ByteBuffer* message) {
  call_.start_read(message);
}
void AsyncReactor::StartWrite(const grpc::ByteBuffer* message) {
  call_.start_write(message);
}
void AsyncReactor::Finish(const grpc::Status& status) {
  call_.finish(status);
}
void AsyncReactor::FinishWithResponse(const grpc::ByteBuffer& response) {
  call_.finish_with_response(response);
}

namespace {

/// A call to a method the server does not have: UNIMPLEMENTED, as gRPC answers it.
class UnknownMethod final : public AsyncReactor {
 public:
  explicit UnknownMethod(AsyncCall& call) : AsyncReactor(call) {
    Finish(grpc::Status(grpc::StatusCode::UNIMPLEMENTED,
                        "unknown method " + call.context()->method()));
  }
  void OnDone() override { delete this; }
};

/// A unary call: reads its one request, then runs the method's handler on a control thread.
class UnaryReactor final : public AsyncReactor {
 public:
  UnaryReactor(AsyncCall& call, AsyncGrpcServer& server, const UnaryHandler& handler,
               UnaryThread thread)
      : AsyncReactor(call), server_(server), handler_(handler), thread_(thread) {
    StartRead(&request_);
  }

  void OnReadDone(bool ok) override {
    if (!ok) {
      // The client half-closed without a message (or the call ended first).
      Finish(grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "the call carried no request"));
      return;
    }
    auto handle = std::make_shared<Handle>(*this);
    if (thread_ == UnaryThread::queue)
      handler_(request_, handle);
    else
      server_.post([this, handle] { handler_(request_, handle); });
  }

  void OnDone() override { delete this; }

 private:
  /// What the handler holds: it may outlive the call (a closure that keeps it after finish),
  /// so it reaches the reactor only until finish.
  class Handle final : public UnaryCallHandle {
   public:
    explicit Handle(UnaryReactor& reactor) : reactor_(reactor), context_(reactor.context()) {}
    grpc::GenericServerContext* context() const override { return context_; }
    void finish(const grpc::Status& status, const grpc::ByteBuffer* response) override {
      if (status.ok() && response != nullptr)
        reactor_.FinishWithResponse(*response);
      else
        reactor_.Finish(status);
    }

   private:
    UnaryReactor& reactor_;
    grpc::GenericServerContext* const context_;
  };

  AsyncGrpcServer& server_;
  const UnaryHandler& handler_;  // the method table's, which outlives every call
  const UnaryThread thread_;
  grpc::ByteBuffer request_;
};

}  // namespace

// ---- AsyncGrpcServer ----

AsyncGrpcServer::AsyncGrpcServer(grpc::ServerBuilder& builder) {
  builder.RegisterAsyncGenericService(&service_);
  queue_ = builder.AddCompletionQueue();
}

AsyncGrpcServer::~AsyncGrpcServer() {
  stop();
}

void AsyncGrpcServer::add_method(std::string path, ReactorFactory make) {
  methods_.insert_or_assign(std::move(path), std::move(make));
}

void AsyncGrpcServer::add_unary_method(std::string path, UnaryHandler handler, UnaryThread thread) {
  auto shared = std::make_shared<UnaryHandler>(std::move(handler));
  add_method(std::move(path), [this, shared, thread](AsyncCall& call) -> AsyncReactor* {
    return new UnaryReactor(call, *this, *shared, thread);
  });
}

void AsyncGrpcServer::start(int queue_threads, int control_threads) {
  queue_threads = std::max(queue_threads, 1);
  control_threads = std::max(control_threads, 1);
  // One pending accept per queue thread, so that a burst of new calls is not taken one by one.
  for (int i = 0; i < queue_threads; ++i) accept_next();
  control_ = std::make_unique<WorkerPool>(std::size_t(control_threads));
  for (int i = 0; i < queue_threads; ++i) queue_threads_.emplace_back([this] { serve_queue(); });
}

void AsyncGrpcServer::stop() {
  if (stopped_) return;
  stopped_ = true;
  {
    // Calls end on their own once the gRPC server has shut down (their operations fail, their
    // reactors finish); those waiting for an evaluation end when it does.
    std::unique_lock lock(calls_mutex_);
    shutting_down_ = true;
    calls_over_.wait(lock, [this] { return live_calls_ == 0; });
  }
  queue_->Shutdown();
  if (queue_threads_.empty()) {
    void* tag = nullptr;
    bool ok = false;
    while (queue_->Next(&tag, &ok)) {
    }
  }
  for (std::thread& thread : queue_threads_) thread.join();
  control_.reset();  // every call is over, so no task is left
}

void AsyncGrpcServer::post(std::function<void()> task) {
  control_->post(std::move(task));
}

void AsyncGrpcServer::accept_next() {
  {
    // Counted from the request on, so that stop() cannot shut the queue down between an
    // accepted call's completion and the next request it makes.
    std::lock_guard lock(calls_mutex_);
    ++live_calls_;
  }
  new AsyncCall(*this);
}

AsyncReactor* AsyncGrpcServer::route(AsyncCall& call) {
  const auto method = methods_.find(call.context()->method());
  if (method == methods_.end()) return new UnknownMethod(call);
  return method->second(call);
}

void AsyncGrpcServer::call_ended() {
  std::lock_guard lock(calls_mutex_);
  if (--live_calls_ == 0 && shutting_down_) calls_over_.notify_all();
}

void AsyncGrpcServer::serve_queue() {
  void* raw = nullptr;
  bool ok = false;
  while (queue_->Next(&raw, &ok)) {
    const auto* tag = static_cast<AsyncCall::Tag*>(raw);
    tag->call->on_completion(tag->event, ok);
  }
}

}  // namespace nearpoint::server
