// SPDX-License-Identifier: Apache-2.0
// The report topics' serialiser: DistanceReport_ and DistanceReportBatch_ samples turned into
// XCDR1 bytes by code written for these two types, instead of by Cyclone DDS's interpreter of
// the idlc descriptor.
//
// Why: a batched cell45 report sample is 8 reports × 45 pairs × 56 values. Cyclone's generic
// writer walks its op codes for every field and aligns each one with a division; in a profile of
// nearpointd under `nearpoint dds load` that serialisation was about a fifth of the server's CPU,
// more than the bridge's own work. The bytes are the same (tests/dds/test_dds_report_sertype.cpp
// compares them with Cyclone's own), so readers, ROS 2 nodes and the wire contract see no change.
//
// How: a Cyclone sertype of our own (the ddsi_sertype interface that rmw_cyclonedds also
// implements) for the two topics the bridge only writes. Its serdata is the finished bytes. The
// type name, the XTypes type information and the type map come from the idlc descriptor, so
// discovery and type matching are exactly those of a topic made with dds_create_topic.
#pragma once

#include <dds/dds.h>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "nearpoint_ros.h"

namespace nearpoint::server {

/// The two sample types this serialiser writes (the idlc C structs: dds_write takes these).
enum class ReportTopicType { report, report_batch };

/// dds_create_topic for `type` on `participant`, with samples serialised by this file's code.
/// Returns the topic's handle or Cyclone's negative return code, as dds_create_topic does.
dds_entity_t create_report_topic(dds_entity_t participant, ReportTopicType type, const char* name,
                                 const dds_qos_t* qos);

/// The serialised form of one sample as the topic's writer sends it: the 4-byte encapsulation
/// header (CDR little endian, the options naming the padding), the XCDR1 payload, and zero
/// padding to a multiple of 4. For tests and benchmarks; the writer does not go through it.
std::vector<unsigned char> serialise_report(const nearpoint_msgs_msg_dds__DistanceReport_& sample);
std::vector<unsigned char> serialise_report_batch(
    const nearpoint_msgs_msg_dds__DistanceReportBatch_& sample);

}  // namespace nearpoint::server
