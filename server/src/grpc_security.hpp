// SPDX-License-Identifier: Apache-2.0
// ServerSecurity → gRPC server credentials: TLS (optionally mutual) and the bearer-token check.
#pragma once

#include <grpcpp/security/server_credentials.h>

#include <memory>

#include "nearpoint/server/security.hpp"

namespace nearpoint::server {

/// Plaintext when `security` has no certificate; else TLS, requiring and verifying a client
/// certificate when it has a client CA, and checking `authorization: Bearer <token>` on every
/// call except the health service's when it has a token.
std::shared_ptr<grpc::ServerCredentials> make_server_credentials(const ServerSecurity& security);

}  // namespace nearpoint::server
