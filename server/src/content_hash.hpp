// SPDX-License-Identifier: Apache-2.0
// Content ids: SHA-256 (FIPS 180-4, OpenSSL's implementation) over a canonical byte form, so that
// the same geometry gets the same id on every replica and on every registration (registering twice
// is idempotent, and a client that re-creates its scene on another replica after a failover names
// the same ids). Not a security boundary: ids are public; SHA-256 only makes accidental collisions
// impossible in practice (128 bits are kept).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>

#include "nearpoint/server/report.hpp"

struct evp_md_ctx_st;  // OpenSSL's EVP_MD_CTX, kept out of the including files

namespace nearpoint::server {

/// Incremental SHA-256, OpenSSL's EVP (libcrypto, linked for gRPC's TLS anyway).
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;
  void update(const void* data, std::size_t size);
  void update(std::string_view bytes) { update(bytes.data(), bytes.size()); }
  /// The digest; the object is spent afterwards.
  std::array<std::uint8_t, 32> finish();

 private:
  evp_md_ctx_st* context_;
};

/// Lower-case hex of the first `bytes` bytes of `digest`.
std::string hex_prefix(const std::array<std::uint8_t, 32>& digest, std::size_t bytes);

/// "geom-" and 32 hex digits: 128 bits of the SHA-256 of the geometry as received (name, pieces
/// in order, each shape's kind and numbers bit for bit, radius, offset). Equal inputs give equal
/// ids; any difference, however small, gives another.
std::string geometry_content_id(const model::GeometryInput& geometry);

}  // namespace nearpoint::server
