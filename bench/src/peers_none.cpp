// SPDX-License-Identifier: Apache-2.0
// The peers when the benchmark is built without NEARPOINT_BENCH_PEERS: every peer declines, and
// the reports say so instead of leaving columns out silently.
#include "runners.hpp"

namespace nearpoint::bench {

bool peers_available() {
  return false;
}

std::unique_ptr<Runner> make_peer_runner(Peer, std::span<const PairInput>, const PeerSettings&,
                                         std::string* why) {
  if (why) *why = "built without NEARPOINT_BENCH_PEERS";
  return nullptr;
}

std::unique_ptr<Runner> make_primitive_peer_runner(PrimitivePeer, std::span<const PrimitiveInput>,
                                                   std::string* why) {
  if (why) *why = "built without NEARPOINT_BENCH_PEERS";
  return nullptr;
}

std::unique_ptr<Runner> make_depth_peer_runner(DepthPeer, std::span<const PairInput>,
                                               const PeerSettings&, std::string* why) {
  if (why) *why = "built without NEARPOINT_BENCH_PEERS";
  return nullptr;
}

std::string check_peer_builds() {
  return "";
}

}  // namespace nearpoint::bench
