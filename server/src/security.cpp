// SPDX-License-Identifier: Apache-2.0
#include "nearpoint/server/security.hpp"

#include <cctype>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace nearpoint::server {
namespace {

/// The whole file, or an error naming `flag` (never the content: it may be a secret).
Expected<std::string> read_file(const std::string& flag, const std::string& path) {
  // A directory opens as a stream and reads as empty: say what it is instead.
  std::error_code error;
  if (std::filesystem::is_directory(path, error))
    return invalid_argument(flag, text("cannot read '", path, "': it is a directory"));
  std::ifstream in(path, std::ios::binary);
  if (!in) return invalid_argument(flag, text("cannot read '", path, "'"));
  std::ostringstream content;
  content << in.rdbuf();
  if (in.bad()) return invalid_argument(flag, text("cannot read '", path, "'"));
  return content.str();
}

/// A PEM file: readable and holding at least one PEM block. gRPC checks the rest (that the key
/// matches the certificate) when the port is bound, and the start fails there.
Expected<std::string> read_pem(const std::string& flag, const std::string& path) {
  auto content = read_file(flag, path);
  if (!content) return content;
  if (content->find("-----BEGIN ") == std::string::npos)
    return invalid_argument(flag, text("'", path, "' is not a PEM file (no -----BEGIN line)"));
  return content;
}

/// The token: the file's content without surrounding whitespace (a trailing newline is usual).
/// Visible ASCII only, as HTTP/2 header values and RFC 6750 tokens allow.
Expected<std::string> read_token(const std::string& flag, const std::string& path) {
  auto content = read_file(flag, path);
  if (!content) return content;
  std::string& token = *content;
  const auto first = token.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return invalid_argument(flag, text("'", path, "' is empty"));
  token = token.substr(first, token.find_last_not_of(" \t\r\n") - first + 1);
  for (const char c : token) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte < 0x21 || byte > 0x7e)
      return invalid_argument(
          flag, text("'", path, "' holds a character other than visible ASCII (one line only)"));
  }
  return content;
}

}  // namespace

bool is_loopback_listen(const std::string& listen) {
  if (listen.rfind("unix:", 0) == 0 || listen.rfind("unix-abstract:", 0) == 0) return true;
  std::string host;
  if (!listen.empty() && listen.front() == '[') {
    const auto close = listen.find(']');
    if (close == std::string::npos) return false;
    host = listen.substr(1, close - 1);
  } else {
    const auto colon = listen.rfind(':');
    host = colon == std::string::npos ? listen : listen.substr(0, colon);
  }
  if (host == "localhost" || host == "::1") return true;
  // 127.0.0.0/8, in dotted-decimal form only ("127.1" and friends are not accepted).
  if (host.rfind("127.", 0) != 0) return false;
  int dots = 0;
  for (const char c : host) {
    if (c == '.')
      ++dots;
    else if (!std::isdigit(static_cast<unsigned char>(c)))
      return false;
  }
  return dots == 3;
}

bool constant_time_equal(std::string_view a, std::string_view b) {
  // Every byte of the longer string is visited; only the sizes' difference is observable, and
  // the token's size is no secret worth a timing channel.
  const std::size_t n = a.size() > b.size() ? a.size() : b.size();
  unsigned char difference = a.size() == b.size() ? 0 : 1;
  for (std::size_t i = 0; i < n; ++i) {
    const auto x = i < a.size() ? static_cast<unsigned char>(a[i]) : 0;
    const auto y = i < b.size() ? static_cast<unsigned char>(b[i]) : 0;
    difference = static_cast<unsigned char>(difference | (x ^ y));
  }
  // volatile: the compiler may not turn the loop into an early-exit comparison.
  volatile unsigned char result = difference;
  return result == 0;
}

Expected<ServerSecurity> load_server_security(const SecurityFlags& flags,
                                              const std::string& listen) {
  ServerSecurity security;
  if (flags.tls_cert.empty() != flags.tls_key.empty()) {
    if (flags.tls_cert.empty())
      return invalid_argument("--tls-cert", "--tls-key was given without --tls-cert");
    return invalid_argument("--tls-key", "--tls-cert was given without --tls-key");
  }
  if (!flags.tls_client_ca.empty() && flags.tls_cert.empty())
    return invalid_argument("--tls-client-ca",
                            "mutual TLS needs the server's own --tls-cert and --tls-key");
  if (!flags.tls_cert.empty()) {
    auto cert = read_pem("--tls-cert", flags.tls_cert);
    if (!cert) return cert.error();
    auto key = read_pem("--tls-key", flags.tls_key);
    if (!key) return key.error();
    security.tls_cert_pem = std::move(*cert);
    security.tls_key_pem = std::move(*key);
  }
  if (!flags.tls_client_ca.empty()) {
    auto ca = read_pem("--tls-client-ca", flags.tls_client_ca);
    if (!ca) return ca.error();
    security.tls_client_ca_pem = std::move(*ca);
  }
  if (!flags.token_file.empty()) {
    auto token = read_token("--token-file", flags.token_file);
    if (!token) return token.error();
    // gRPC clients refuse to send call credentials over a plaintext channel, and a token sent
    // in the clear is a token given away.
    if (!security.tls())
      return invalid_argument("--token-file",
                              "a bearer token needs TLS: give --tls-cert and --tls-key too");
    security.token = std::move(*token);
  }
  if (!security.tls() && !flags.insecure && !is_loopback_listen(listen))
    return invalid_argument(
        "--listen", text("'", listen,
                         "' is reachable from other machines: give --tls-cert and --tls-key, "
                         "or --insecure to serve plaintext there"));
  return security;
}

}  // namespace nearpoint::server
