// SPDX-License-Identifier: Apache-2.0
// The server's limits, each with its default and why. One home: flags and tests override these.
#pragma once

#include <cstddef>

#include "nearpoint/model/scene_types.hpp"

namespace nearpoint::server {

// Fixed rules for the strings of a request (not configurable: clients rely on them). Every id and
// name is echoed somewhere — in reports, error messages, logs, DDS instance keys — so each has a
// bound, and ids a character set that needs no escaping anywhere.

/// Ids (scene, object, geometry): 1–128 bytes of printable ASCII without spaces (0x21–0x7E).
inline constexpr std::size_t kMaxIdBytes = 128;
/// Names (a geometry's or a scene's label, a DDS client_id): at most 256 bytes of UTF-8 text
/// without control characters.
inline constexpr std::size_t kMaxNameBytes = 256;
/// Error messages and logs quote at most this many bytes of an id or name the client sent, then
/// its length: "no scene 'abc…' (8192 bytes)".
inline constexpr std::size_t kQuotedBytes = 64;

/// The default message size limit (--max-message-bytes), shared with the clients.
using model::kDefaultMaxMessageBytes;

struct ServiceLimits {
  /// Stored geometries. Each costs its vertices (24 B each) plus a few hundred bytes.
  std::size_t max_geometries = 10'000;
  /// Convex pieces of one geometry. A piece pair costs a 36-byte warm-start cache per stream.
  std::size_t max_pieces_per_geometry = 256;
  /// Polytope vertices of one geometry, over its pieces. A support call scans a piece's vertices,
  /// so this also bounds the cost of one GJK iteration (100k vertices ≈ 50 µs).
  std::size_t max_vertices_per_geometry = 100'000;
  /// Live scenes.
  std::size_t max_scenes = 1'000;
  /// Objects of one scene.
  std::size_t max_objects_per_scene = 1'000;
  /// Selected object pairs of one scene: one PairDistance each per report (≈100 B on the wire,
  /// plus the two object ids; near points and gradients add up to 215 B).
  std::size_t max_pairs_per_scene = 100'000;
  /// The largest report a scene may produce, bytes of its nearpoint.v1.DistanceReport encoding
  /// (an upper bound computed from the pair count, the object ids and the options asked for).
  /// A scene whose reports could exceed it is refused at creation, and a query or update whose
  /// options would make its report exceed it is refused: a report too large to send could never
  /// be answered. nearpointd sets it to --max-message-bytes, the most gRPC sends in one message.
  std::size_t max_report_bytes = kDefaultMaxMessageBytes;
  /// Piece pairs over a scene's selected pairs: each stream holds one 36-byte cache per piece
  /// pair, so this bounds a stream's memory (262 144 → 9.4 MB).
  std::size_t max_piece_pairs_per_scene = 262'144;
  /// Concurrent pose streams, all clients together.
  std::size_t max_streams = 256;
  /// Updates a stream may have read but not yet answered (queued, being evaluated, or reports
  /// waiting to be written). The bound on what one slow client can make the server hold.
  std::size_t max_in_flight_per_stream = 8;
  /// Unary queries evaluated or queued at once, all clients together.
  std::size_t max_concurrent_queries = 256;
  /// A gRPC stream's update whose evaluation is one task's worth of pairs
  /// (SceneDefinition::tasks_per_evaluation) is evaluated on the thread that read it rather than
  /// handed to a worker: the hand-off cost more than such an update's geometry
  /// (bench/service/RESULTS.md, "Where an update's CPU goes"). false: every evaluation on the
  /// workers, so that --workers bounds the threads doing geometry (nearpointd
  /// --no-inline-evaluation).
  bool inline_evaluation = true;
};

}  // namespace nearpoint::server
