// SPDX-License-Identifier: Apache-2.0
// The gRPC channel a Client talks over: its credentials (plaintext, TLS, a bearer token) and its
// arguments (message size, reconnect backoff, keepalive). Private to the client library and the
// `nearpoint` tool, whose load driver streams on a channel of its own made the same way.
#pragma once

#include <grpcpp/grpcpp.h>

#include <memory>
#include <string>

#include "nearpoint/client/client.hpp"

namespace nearpoint::client::detail {

std::shared_ptr<grpc::Channel> make_channel(const std::string& target,
                                            const ClientOptions& options);

/// Whether `id` may travel as a metadata value (kSceneRoutingHeader): a call about a scene whose
/// id may not goes without the header, and the server refuses the id by name.
bool routable(const std::string& id);

}  // namespace nearpoint::client::detail
