// SPDX-License-Identifier: Apache-2.0
// Parsing requests ourselves, so that bytes that do not parse get a reason. gRPC's generated
// handlers parse before our code runs: a unary request that fails is answered UNIMPLEMENTED with
// no message, and a stream message that fails looks like the client's half-close (OnReadDone
// false). The service therefore takes every method raw (grpc::ByteBuffer) and parses here.
#pragma once

#include <grpcpp/support/byte_buffer.h>

#include <string>

#include <google/protobuf/message.h>

namespace nearpoint::server {

/// Parses `bytes` into `message` (cleared first). "" on success; otherwise why not, e.g.
/// "field scene_id is not valid UTF-8" or "the bytes are not protobuf wire format …".
std::string parse_message(const grpc::ByteBuffer& bytes, google::protobuf::Message& message);
/// The same for a message's bytes already in one piece.
std::string parse_message(const grpc::Slice& bytes, google::protobuf::Message& message);

/// Why `size` bytes at `data` do not parse as `type` (the parse has failed already): names the
/// first field to blame when it can. Never recurses deeper than protobuf's own nesting limit.
std::string why_unparsable(const void* data, int size, const google::protobuf::Descriptor& type);

}  // namespace nearpoint::server
