// SPDX-License-Identifier: Apache-2.0
#include "grpc_security.hpp"

#include <grpcpp/security/auth_metadata_processor.h>
#include <grpcpp/security/server_credentials.h>

#include <string>
#include <string_view>

#include "nearpoint/server/log.hpp"

namespace nearpoint::server {
namespace {

/// Checks the bearer token before a call reaches any service. The token is consumed (removed
/// from the metadata the handlers see), so no handler can log it by accident.
///
/// grpc.health.v1.Health is exempt: Kubernetes' gRPC probes and load balancers' health checks
/// cannot send a token, and the health service tells nothing but SERVING / NOT_SERVING. TLS
/// (and with a client CA, the client certificate) still applies to it.
class TokenProcessor final : public grpc::AuthMetadataProcessor {
 public:
  explicit TokenProcessor(std::string token) : expected_("Bearer " + std::move(token)) {}

  // Cheap and non-blocking: run inline on gRPC's own thread.
  bool IsBlocking() const override { return false; }

  grpc::Status Process(const InputMetadata& metadata, grpc::AuthContext* /*context*/,
                       OutputMetadata* consumed, OutputMetadata* /*response*/) override {
    const auto path = metadata.find(":path");
    if (path != metadata.end() && starts_with(path->second, "/grpc.health.v1.Health/"))
      return grpc::Status::OK;
    const auto range = metadata.equal_range("authorization");
    bool accepted = false;
    int count = 0;
    for (auto it = range.first; it != range.second; ++it) {
      ++count;
      const std::string_view value(it->second.data(), it->second.size());
      accepted = constant_time_equal(value, expected_) || accepted;
    }
    if (count > 0)
      consumed->insert(
          {"authorization", std::string(range.first->second.data(), range.first->second.size())});
    if (count == 1 && accepted) return grpc::Status::OK;
    // The log says which call was refused and why, never what was sent.
    log_warn("unauthenticated")
        .kv("method", path != metadata.end() ? std::string(path->second.data(), path->second.size())
                                             : std::string("?"))
        .kv("reason", count == 0  ? "no token"
                      : count > 1 ? "several tokens"
                                  : "wrong token");
    return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                        count == 0 ? "this server needs a bearer token (authorization: Bearer …)"
                                   : "the bearer token is not valid");
  }

 private:
  static bool starts_with(grpc::string_ref value, std::string_view prefix) {
    return value.size() >= prefix.size() && std::string_view(value.data(), prefix.size()) == prefix;
  }
  std::string expected_;
};

}  // namespace

std::shared_ptr<grpc::ServerCredentials> make_server_credentials(const ServerSecurity& security) {
  if (!security.tls()) return grpc::InsecureServerCredentials();
  grpc::SslServerCredentialsOptions options(
      security.tls_client_ca_pem.empty()
          ? GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE
          : GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY);
  options.pem_root_certs = security.tls_client_ca_pem;
  options.pem_key_cert_pairs.push_back({security.tls_key_pem, security.tls_cert_pem});
  auto credentials = grpc::SslServerCredentials(options);
  if (!security.token.empty())
    credentials->SetAuthMetadataProcessor(std::make_shared<TokenProcessor>(security.token));
  return credentials;
}

}  // namespace nearpoint::server
