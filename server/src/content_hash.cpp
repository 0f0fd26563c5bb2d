// SPDX-License-Identifier: Apache-2.0
#include "content_hash.hpp"

#include <algorithm>
#include <bit>
#include <cstring>
#include <type_traits>

namespace nearpoint::server {
namespace {

constexpr std::array<std::uint32_t, 64> kRound = {
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5,
    0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174,
    0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da,
    0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967,
    0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85,
    0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070,
    0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
    0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2};

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

Sha256::Sha256()
    : state_{0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a,
             0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19} {}

void Sha256::block(const std::uint8_t* chunk) {
  std::array<std::uint32_t, 64> w;
  for (int i = 0; i < 16; ++i)
    w[i] = std::uint32_t(chunk[4 * i]) << 24 | std::uint32_t(chunk[4 * i + 1]) << 16 |
           std::uint32_t(chunk[4 * i + 2]) << 8 | std::uint32_t(chunk[4 * i + 3]);
  for (int i = 16; i < 64; ++i) {
    const std::uint32_t s0 = std::rotr(w[i - 15], 7) ^ std::rotr(w[i - 15], 18) ^ (w[i - 15] >> 3);
    const std::uint32_t s1 = std::rotr(w[i - 2], 17) ^ std::rotr(w[i - 2], 19) ^ (w[i - 2] >> 10);
    w[i] = w[i - 16] + s0 + w[i - 7] + s1;
  }
  auto [a, b, c, d, e, f, g, h] = state_;
  for (int i = 0; i < 64; ++i) {
    const std::uint32_t s1 = std::rotr(e, 6) ^ std::rotr(e, 11) ^ std::rotr(e, 25);
    const std::uint32_t choose = (e & f) ^ (~e & g);
    const std::uint32_t t1 = h + s1 + choose + kRound[i] + w[i];
    const std::uint32_t s0 = std::rotr(a, 2) ^ std::rotr(a, 13) ^ std::rotr(a, 22);
    const std::uint32_t majority = (a & b) ^ (a & c) ^ (b & c);
    const std::uint32_t t2 = s0 + majority;
    h = g;
    g = f;
    f = e;
    e = d + t1;
    d = c;
    c = b;
    b = a;
    a = t1 + t2;
  }
  const std::array<std::uint32_t, 8> add = {a, b, c, d, e, f, g, h};
  for (int i = 0; i < 8; ++i) state_[i] += add[i];
}

void Sha256::update(const void* data, std::size_t size) {
  const auto* bytes = static_cast<const std::uint8_t*>(data);
  length_ += size;
  while (size > 0) {
    const std::size_t take = std::min(size, buffer_.size() - buffered_);
    std::memcpy(buffer_.data() + buffered_, bytes, take);
    buffered_ += take;
    bytes += take;
    size -= take;
    if (buffered_ == buffer_.size()) {
      block(buffer_.data());
      buffered_ = 0;
    }
  }
}

std::array<std::uint8_t, 32> Sha256::finish() {
  const std::uint64_t bits = length_ * 8;
  const std::uint8_t one = 0x80;
  update(&one, 1);
  const std::uint8_t zero = 0;
  while (buffered_ != 56) update(&zero, 1);
  std::uint8_t length[8];
  for (int i = 0; i < 8; ++i) length[i] = std::uint8_t(bits >> (56 - 8 * i));
  update(length, 8);
  std::array<std::uint8_t, 32> digest;
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 4; ++j) digest[4 * i + j] = std::uint8_t(state_[i] >> (24 - 8 * j));
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
