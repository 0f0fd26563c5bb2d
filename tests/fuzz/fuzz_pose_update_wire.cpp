// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: nearpointd's reader of pose stream messages (server/src/pose_update_wire.hpp),
// which reads the messages that carry only scene ids, sequence numbers and poses without
// protobuf's parser. The first byte picks a PoseUpdate (even) or a PoseUpdateBatch (odd); the rest
// is the message. Invariants: no read past the bytes (ASan); whatever the reader reads, protobuf's
// parser accepts too and proto::from_proto makes exactly the same updates of it (doubles bit for
// bit). The reader's vector is kept from input to input, as a stream keeps it from message to
// message, so that what one message leaves behind cannot leak into the next.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "fuzz_support.hpp"
#include "pose_update_compare.hpp"
#include "pose_update_wire.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace model = nearpoint::model;
  if (size == 0) return 0;
  const bool batched = (data[0] & 1) != 0;
  const std::span<const std::uint8_t> bytes(data + 1, size - 1);
  static std::vector<model::PoseUpdateInput> plain;
  if (!nearpoint::server::read_plain_pose_updates(bytes, batched, plain)) return 0;
  std::vector<model::PoseUpdateInput> reference;
  NEARPOINT_FUZZ_CHECK(nearpoint::testing::protobuf_pose_updates(bytes, batched, reference),
                       "read a message protobuf refuses");
  NEARPOINT_FUZZ_CHECK(plain.size() == reference.size(), "read " + std::to_string(plain.size()) +
                                                             " updates, protobuf " +
                                                             std::to_string(reference.size()));
  for (std::size_t i = 0; i < plain.size(); ++i) {
    const std::string difference =
        nearpoint::testing::pose_update_difference(plain[i], reference[i]);
    NEARPOINT_FUZZ_CHECK(difference.empty(),
                         "update " + std::to_string(i) + " differs from protobuf's: " + difference);
  }
  return 0;
}
