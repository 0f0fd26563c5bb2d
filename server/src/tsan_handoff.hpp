// SPDX-License-Identifier: Apache-2.0
// Happens-before edges that gRPC guarantees but ThreadSanitizer cannot see.
//
// gRPC orders a callback reactor's construction before its reactions (OnReadDone, OnWriteDone,
// OnCancel, OnDone) through its completion queue, and that queue synchronises inside Debian's
// libgrpc/libgpr/libabsl, which are not built with -fsanitize=thread: absl::Mutex waits on futexes
// that TSan does not intercept. Without help TSan then reports the reactor's own members (its
// std::mutex first of all) as raced between the constructing thread and the reacting thread.
//
// `handoff_release(key)` where gRPC's guarantee starts and `handoff_acquire(key)` where it ends
// state exactly that guarantee (ReactorHandoff below, for reactors), no more. Outside TSan
// builds both are empty inline functions.
#pragma once

#if defined(__SANITIZE_THREAD__)
extern "C" void __tsan_acquire(void* address);
extern "C" void __tsan_release(void* address);
#endif

namespace nearpoint::server {

inline void handoff_release([[maybe_unused]] const void* object) {
#if defined(__SANITIZE_THREAD__)
  __tsan_release(const_cast<void*>(object));
#endif
}

inline void handoff_acquire([[maybe_unused]] const void* object) {
#if defined(__SANITIZE_THREAD__)
  __tsan_acquire(const_cast<void*>(object));
#endif
}

/// gRPC's ordering of one callback reactor's code, told to TSan: the constructor happens before
/// every reaction, and every reaction happens before OnDone. Reactions are not ordered among
/// themselves (gRPC may run OnReadDone and OnWriteDone at once), so TSan still checks them.
/// A member of the reactor; each method returns a guard for the scope of the code it names.
class ReactorHandoff {
 public:
  /// Release at scope exit, so that a constructor with early returns publishes every path.
  class Release {
   public:
    explicit Release(const void* key) : key_(key) {}
    ~Release() { handoff_release(key_); }
    Release(const Release&) = delete;
    Release& operator=(const Release&) = delete;

   private:
    const void* key_;
  };

  /// For the whole constructor body.
  [[nodiscard]] Release construction() const { return Release(&constructed_); }
  /// For the whole body of a reaction other than OnDone.
  [[nodiscard]] Release reaction() const {
    handoff_acquire(&constructed_);
    return Release(&reacted_);
  }
  /// At the start of OnDone.
  void done() const {
    handoff_acquire(&constructed_);
    handoff_acquire(&reacted_);
  }

 private:
  // Two distinct addresses, the keys TSan synchronises on; never read or written.
  char constructed_ = 0;
  char reacted_ = 0;
};

}  // namespace nearpoint::server
