// SPDX-License-Identifier: Apache-2.0
#include "content_hash.hpp"

#include <openssl/evp.h>

#include <bit>
#include <cstdio>
#include <cstdlib>
#include <type_traits>

namespace nearpoint::server {
namespace {

/// Appends values in a fixed little-endian layout, strings with their length first, so that the
/// byte form is unambiguous (no two inputs share one).
class Canonical {
 public:
  explicit Canonical(Sha256& hash) : hash_(hash) {}
  void u64(std::uint64_t value) {
    std::uint8_t bytes[8];
    for (int i = 0; i < 8; ++i) bytes[i] = std::uint8_t(value >> (8 * i));
    hash_.update(bytes, 8);
  }
  void f64(double value) { u64(std::bit_cast<std::uint64_t>(value)); }
  void vec(const model::Vec3d& v) {
    f64(v.x());
    f64(v.y());
    f64(v.z());
  }
  void str(std::string_view s) {
    u64(s.size());
    hash_.update(s);
  }
  void pose(const model::PoseInput& pose) {
    for (const double q : pose.rotation_wxyz) f64(q);
    vec(pose.translation);
  }

 private:
  Sha256& hash_;
};

}  // namespace

// The calls below fail only when the library cannot allocate or has no SHA-256 at all (a FIPS
// provider misconfigured by the host): nothing a request can cause, and no id may be made without
// the hash, so the server stops with the reason.
namespace {
[[noreturn]] void hash_unavailable(const char* call) {
  std::fprintf(stderr, "nearpointd: OpenSSL %s failed: SHA-256 is unavailable\n", call);
  std::abort();
}
}  // namespace

Sha256::Sha256() : context_(EVP_MD_CTX_new()) {
  if (context_ == nullptr) hash_unavailable("EVP_MD_CTX_new");
  if (EVP_DigestInit_ex(context_, EVP_sha256(), nullptr) != 1)
    hash_unavailable("EVP_DigestInit_ex");
}

Sha256::~Sha256() {
  EVP_MD_CTX_free(context_);
}

void Sha256::update(const void* data, std::size_t size) {
  if (EVP_DigestUpdate(context_, data, size) != 1) hash_unavailable("EVP_DigestUpdate");
}

std::array<std::uint8_t, 32> Sha256::finish() {
  std::array<std::uint8_t, 32> digest;
  unsigned int length = 0;
  if (EVP_DigestFinal_ex(context_, digest.data(), &length) != 1 || length != digest.size())
    hash_unavailable("EVP_DigestFinal_ex");
  return digest;
}

std::string hex_prefix(const std::array<std::uint8_t, 32>& digest, std::size_t bytes) {
  constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  for (std::size_t i = 0; i < bytes && i < digest.size(); ++i) {
    out.push_back(kHex[digest[i] >> 4]);
    out.push_back(kHex[digest[i] & 15]);
  }
  return out;
}

std::string geometry_content_id(const model::GeometryInput& geometry) {
  Sha256 hash;
  Canonical out(hash);
  out.str("nearpoint.geometry.v1");  // the layout's version: a new layout gives new ids
  out.str(geometry.name);
  out.u64(geometry.pieces.size());
  for (const model::PieceInput& piece : geometry.pieces) {
    out.u64(piece.shape.index());
    std::visit(
        [&](const auto& shape) {
          using T = std::decay_t<decltype(shape)>;
          if constexpr (std::is_same_v<T, model::PolytopeInput>) {
            out.u64(shape.vertices.size());
            for (const model::Vec3d& v : shape.vertices) out.vec(v);
          } else if constexpr (std::is_same_v<T, Segment<double>>) {
            out.vec(shape.a);
            out.vec(shape.b);
          } else if constexpr (std::is_same_v<T, Box<double>>) {
            out.vec(shape.half_extents);
          } else if constexpr (std::is_same_v<T, Cylinder<double>> ||
                               std::is_same_v<T, Cone<double>>) {
            out.f64(shape.radius);
            out.f64(shape.half_height);
          } else if constexpr (std::is_same_v<T, Ellipsoid<double>>) {
            out.vec(shape.radii);
          }  // monostate (rejected by validation) and Point: the kind says it all
        },
        piece.shape);
    out.f64(piece.radius);
    out.pose(piece.offset);
  }
  return "geom-" + hex_prefix(hash.finish(), 16);
}

}  // namespace nearpoint::server
