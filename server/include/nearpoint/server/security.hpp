// SPDX-License-Identifier: Apache-2.0
// nearpointd's transport security (issue 23, item 3): TLS on the gRPC port, optionally mutual, and
// an optional bearer token. Loaded and checked once at start, before anything binds, so that bad
// configuration stops the server with a message naming the flag.
#pragma once

#include <string>
#include <string_view>

#include "nearpoint/server/errors.hpp"

namespace nearpoint::server {

/// What the gRPC port requires of a client. All empty: plaintext, no token (loopback only, or
/// with an explicit --insecure).
struct ServerSecurity {
  /// PEM: the server's certificate chain and private key. Both set: the port speaks TLS only.
  std::string tls_cert_pem;
  std::string tls_key_pem;
  /// PEM: CAs whose client certificates are accepted. Set: mutual TLS (a client without a
  /// certificate signed by one of them cannot connect).
  std::string tls_client_ca_pem;
  /// The bearer token every call but the health service's must carry as
  /// `authorization: Bearer <token>`. Empty: no token. Needs TLS (clients send no token in the
  /// clear).
  std::string token;

  bool tls() const { return !tls_cert_pem.empty(); }
};

/// The flags as given on the command line (file paths; empty = not given).
struct SecurityFlags {
  std::string tls_cert;       ///< --tls-cert
  std::string tls_key;        ///< --tls-key
  std::string tls_client_ca;  ///< --tls-client-ca
  std::string token_file;     ///< --token-file, else $NEARPOINT_TOKEN_FILE
  bool insecure = false;      ///< --insecure: plaintext on a non-loopback address, acknowledged
};

/// Reads the files the flags name and checks the combination against the listen address. The
/// error's field is the flag to blame ("--tls-key"); its message never contains the token.
Expected<ServerSecurity> load_server_security(const SecurityFlags& flags,
                                              const std::string& listen);

/// True for addresses only this machine can reach: 127.0.0.0/8, ::1, localhost, unix sockets.
/// "0.0.0.0", "[::]", a bare ":port" and every other host are not.
bool is_loopback_listen(const std::string& listen);

/// Compares without an early exit, so the time taken does not tell how much of a guess matched.
bool constant_time_equal(std::string_view a, std::string_view b);

}  // namespace nearpoint::server
