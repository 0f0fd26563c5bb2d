// SPDX-License-Identifier: Apache-2.0
// Builds and links against the installed nearpoint::client and nearpoint::proto; runs without a
// server: a call to a closed loopback port must come back as a value (UNAVAILABLE), not a crash.
#include <chrono>
#include <cstdio>

#include "nearpoint/client/client.hpp"
#include "nearpoint_distance.grpc.pb.h"

int main() {
  nearpoint::v1::RegisterGeometryRequest request;  // the generated types are usable
  request.mutable_geometry()->set_name("consumer");
  nearpoint::client::ClientOptions options;
  options.call_timeout = std::chrono::milliseconds(3000);
  // Port 1 on loopback: nothing listens there.
  const auto client = nearpoint::client::Client::connect("127.0.0.1:1", options);
  const auto listed = client->list_geometries();
  if (listed.ok()) {
    std::printf("unexpected: a server answered on 127.0.0.1:1\n");
    return 1;
  }
  std::printf("client: %s (%s), request name %s\n", listed.status().code_name().c_str(),
              listed.status().message.c_str(), request.geometry().name().c_str());
  return listed.status().code == 14 ? 0 : 1;  // 14 = UNAVAILABLE
}
