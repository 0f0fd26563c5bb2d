// SPDX-License-Identifier: Apache-2.0
// A message's bytes between std::string and grpc::ByteBuffer, for the methods that read and
// write their messages without generated gRPC code (health, reflection).
#pragma once

#include <grpcpp/support/byte_buffer.h>
#include <grpcpp/support/slice.h>

#include <string>
#include <vector>

namespace nearpoint::server {

/// The bytes of `buffer`, in one string (false: gRPC could not read them).
inline bool bytes_of(const grpc::ByteBuffer& buffer, std::string& out) {
  std::vector<grpc::Slice> slices;
  if (!buffer.Dump(&slices).ok()) return false;
  out.clear();
  for (const grpc::Slice& slice : slices)
    out.append(reinterpret_cast<const char*>(slice.begin()), slice.size());
  return true;
}

/// A buffer holding a copy of `bytes`.
inline grpc::ByteBuffer byte_buffer_of(const std::string& bytes) {
  grpc::Slice slice(bytes);
  return grpc::ByteBuffer(&slice, 1);
}

}  // namespace nearpoint::server
