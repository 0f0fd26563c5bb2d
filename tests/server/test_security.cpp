// SPDX-License-Identifier: Apache-2.0
// The pure parts of nearpointd's transport security (server/src/security.cpp): which --listen
// addresses count as loopback (everything else needs TLS or --insecure) and the token
// comparison. The flags and files are tested through the real binary (tests/security/).
#include <gtest/gtest.h>

#include "nearpoint/server/security.hpp"

namespace nearpoint::server {
namespace {

using namespace ::nearpoint::model;  // the scene model's types, unqualified in the tests

TEST(Security, LoopbackAddressesNeedNoTls) {
  for (const char* listen : {"127.0.0.1:50051", "127.0.0.1:0", "127.1.2.3:1", "localhost:50051",
                             "[::1]:50051", "unix:/run/nearpoint.sock", "unix-abstract:np"})
    EXPECT_TRUE(is_loopback_listen(listen)) << listen;
}

TEST(Security, EverythingElseIsReachableFromOtherMachines) {
  for (const char* listen :
       {"0.0.0.0:50051", "[::]:50051", ":50051", "10.0.0.7:50051", "example.com:50051",
        "127.example.com:50051", "127.0.0.1.example.com:1", "127.1:50051", "[::1", "",
        "dns:///localhost:50051", "[::ffff:10.0.0.1]:1", "localhost.example.com:1"})
    EXPECT_FALSE(is_loopback_listen(listen)) << listen;
}

TEST(Security, TokenComparison) {
  EXPECT_TRUE(constant_time_equal("Bearer abc", "Bearer abc"));
  EXPECT_TRUE(constant_time_equal("", ""));
  EXPECT_FALSE(constant_time_equal("Bearer abc", "Bearer abd"));
  EXPECT_FALSE(constant_time_equal("Bearer abc", "Bearer ab"));
  EXPECT_FALSE(constant_time_equal("Bearer ab", "Bearer abc"));
  EXPECT_FALSE(constant_time_equal("Bearer abc", ""));
  // A guess that is the token followed by NULs is not the token.
  EXPECT_FALSE(constant_time_equal(std::string_view("abc\0", 4), "abc"));
}

TEST(Security, FlagsAreCheckedBeforeFiles) {
  SecurityFlags flags;
  auto plain = load_server_security(flags, "127.0.0.1:0");
  ASSERT_TRUE(plain.ok());
  EXPECT_FALSE(plain->tls());
  EXPECT_TRUE(plain->token.empty());

  flags.insecure = true;
  EXPECT_TRUE(load_server_security(flags, "0.0.0.0:50051").ok());
  flags.insecure = false;
  auto refused = load_server_security(flags, "0.0.0.0:50051");
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().field, "--listen");

  flags.token_file = "/nonexistent/token";
  auto no_token = load_server_security(flags, "127.0.0.1:0");
  ASSERT_FALSE(no_token.ok());
  EXPECT_EQ(no_token.error().field, "--token-file");
}

}  // namespace
}  // namespace nearpoint::server
