// SPDX-License-Identifier: Apache-2.0
// Content ids: SHA-256 (FIPS 180-4) over a canonical byte form, so that the same geometry gets the
// same id on every replica and on every registration (registering twice is idempotent, and a
// client that re-creates its scene on another replica after a failover names the same ids).
// Not a security boundary: ids are public; SHA-256 only makes accidental collisions impossible in
// practice (128 bits are kept).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>

#include "nearpoint/server/report.hpp"

namespace nearpoint::server {

/// Incremental SHA-256.
class Sha256 {
 public:
  Sha256();
  void update(const void* data, std::size_t size);
  void update(std::string_view bytes) { update(bytes.data(), bytes.size()); }
  /// The digest; the object is spent afterwards.
  std::array<std::uint8_t, 32> finish();

 private:
  void block(const std::uint8_t* chunk);
  std::array<std::uint32_t, 8> state_;
  std::array<std::uint8_t, 64> buffer_{};
  std::size_t buffered_ = 0;
  std::uint64_t length_ = 0;
};

/// Lower-case hex of the first `bytes` bytes of `digest`.
std::string hex_prefix(const std::array<std::uint8_t, 32>& digest, std::size_t bytes);

/// "geom-" and 32 hex digits: 128 bits of the SHA-256 of the geometry as received (name, pieces
/// in order, each shape's kind and numbers bit for bit, radius, offset). Equal inputs give equal
/// ids; any difference, however small, gives another.
std::string geometry_content_id(const model::GeometryInput& geometry);

}  // namespace nearpoint::server
