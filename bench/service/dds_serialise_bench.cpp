// SPDX-License-Identifier: Apache-2.0
// nearpoint_dds_serialise_bench: what one dds_write of a report costs on the topic Cyclone DDS
// serialises (dds_create_topic, the idlc descriptor's interpreter) and on the topic nearpointd
// uses (create_report_topic, server/src/dds_report_sertype.hpp), side by side in one process:
// rounds alternate between the two writers, each writing the same samples. The writers have no
// readers, so what is timed is Cyclone's write path with each serialiser (serialise, history,
// no network). The samples are cell45's shape: 45 pairs a report, one report or a batch of 8.
//
//   export CYCLONEDDS_URI=file://$PWD/deploy/cyclonedds-loopback.xml
//   nearpoint_dds_serialise_bench [--rounds 5] [--writes 2000] [--domain 151]
#include <dds/dds.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "dds_report_sertype.hpp"
#include "nearpoint_dds.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using nearpoint::server::create_report_topic;
using nearpoint::server::ReportTopicType;

struct Options {
  int rounds = 5;
  int writes = 2000;
  dds_domainid_t domain = 151;
};

Options parse(int argc, char** argv) {
  Options options;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    const int value = std::atoi(argv[i + 1]);
    if (flag == "--rounds")
      options.rounds = std::max(1, value);
    else if (flag == "--writes")
      options.writes = std::max(1, value);
    else if (flag == "--domain")
      options.domain = value;
    else {
      std::fprintf(stderr, "usage: %s [--rounds N] [--writes N] [--domain D]\n", argv[0]);
      std::exit(2);
    }
  }
  return options;
}

/// Ten objects, 45 pairs, every pair with near points: a cell45 report's fields.
struct Cell45Reports {
  std::vector<std::string> ids;
  std::vector<nearpoint_msgs_msg_dds__PairDistance_> pairs;
  std::vector<nearpoint_msgs_msg_dds__DistanceReport_> reports;
  nearpoint_msgs_msg_dds__DistanceReportBatch_ batch{};

  explicit Cell45Reports(std::size_t per_batch) {
    for (int i = 0; i < 10; ++i) ids.push_back("part_" + std::to_string(i));
    for (std::size_t a = 0; a < ids.size(); ++a)
      for (std::size_t b = a + 1; b < ids.size(); ++b) {
        nearpoint_msgs_msg_dds__PairDistance_ p{};
        p.object_a = ids[a].data();
        p.object_b = ids[b].data();
        p.distance = 0.01 * double(pairs.size() + 1);
        p.distance_lower_bound = p.distance * (1 - 1e-12);
        p.error_bound = 1e-12;
        p.iterations = 4;
        p.piece_pairs_evaluated = 1;
        p.warm_started = true;
        p.has_near_points = true;
        p.point_a = {0.1, 0.2, 0.3};
        p.point_b = {0.1, 0.2, 0.3 + p.distance};
        p.normal = {0, 0, 1};
        p.message = const_cast<char*>("");
        pairs.push_back(p);
      }
    reports.resize(per_batch);
    std::uint64_t sequence = 0;
    for (auto& r : reports) {
      r = {};
      r.header.frame_id = const_cast<char*>("");
      r.scene_id = const_cast<char*>("cell45");
      r.client_id = const_cast<char*>("bench");
      r.sequence_number = ++sequence;
      r.error_field = const_cast<char*>("");
      r.message = const_cast<char*>("");
      r.pairs._buffer = pairs.data();
      r.pairs._length = r.pairs._maximum = std::uint32_t(pairs.size());
      r.timing = {100, 5, 80, 15};
      r.counts = {45, 0, 0};
      r.report_mode = 1;
    }
    batch.reports._buffer = reports.data();
    batch.reports._length = batch.reports._maximum = std::uint32_t(reports.size());
  }
};

/// Microseconds per dds_write of `sample` on `writer`, over `writes` writes.
double time_writes(dds_entity_t writer, const void* sample, int writes) {
  const auto start = Clock::now();
  for (int i = 0; i < writes; ++i)
    if (const dds_return_t rc = dds_write(writer, sample); rc < 0) {
      std::fprintf(stderr, "dds_write: %s\n", dds_strretcode(rc));
      std::exit(1);
    }
  return std::chrono::duration<double, std::micro>(Clock::now() - start).count() / writes;
}

dds_entity_t writer_on(dds_entity_t participant, dds_entity_t topic, const dds_qos_t* qos) {
  const dds_entity_t writer = dds_create_writer(participant, topic, qos, nullptr);
  if (topic < 0 || writer < 0) {
    std::fprintf(stderr, "creating a topic or writer failed: %s\n",
                 dds_strretcode(topic < 0 ? topic : writer));
    std::exit(1);
  }
  return writer;
}

}  // namespace

int main(int argc, char** argv) {
  const Options options = parse(argc, argv);
  if (!std::getenv("CYCLONEDDS_URI")) {
    std::fprintf(stderr, "set CYCLONEDDS_URI (deploy/cyclonedds-loopback.xml) first\n");
    return 2;
  }
  const dds_entity_t participant = dds_create_participant(options.domain, nullptr, nullptr);
  if (participant < 0) {
    std::fprintf(stderr, "dds_create_participant: %s\n", dds_strretcode(participant));
    return 1;
  }
  const nearpoint::dds::QosPtr qos = nearpoint::dds::stream_qos();
  const std::string prefix = "rt/nearpoint_serialise_bench_" + std::to_string(getpid()) + "/";

  struct Case {
    const char* name;
    std::size_t updates;
    const void* sample;
    dds_entity_t cyclone, ours;
    std::vector<double> cyclone_us, ours_us;
  };
  Cell45Reports one(1), eight(8);
  auto make = [&](const char* name, ReportTopicType type, const dds_topic_descriptor_t* descriptor,
                  const void* sample, std::size_t updates) {
    const std::string topic = prefix + name;
    return Case{
        name,
        updates,
        sample,
        writer_on(participant,
                  dds_create_topic(participant, descriptor, (topic + "_cyclone").c_str(), qos.get(),
                                   nullptr),
                  qos.get()),
        writer_on(participant,
                  create_report_topic(participant, type, (topic + "_ours").c_str(), qos.get()),
                  qos.get()),
        {},
        {}};
  };
  std::vector<Case> cases;
  cases.push_back(make("report", ReportTopicType::report,
                       &nearpoint_msgs_msg_dds__DistanceReport__desc, &one.reports[0], 1));
  cases.push_back(make("batch_of_8", ReportTopicType::report_batch,
                       &nearpoint_msgs_msg_dds__DistanceReportBatch__desc, &eight.batch, 8));

  for (Case& c : cases) {  // warm up both writers
    time_writes(c.cyclone, c.sample, 100);
    time_writes(c.ours, c.sample, 100);
  }
  for (int round = 0; round < options.rounds; ++round)
    for (Case& c : cases) {
      c.cyclone_us.push_back(time_writes(c.cyclone, c.sample, options.writes));
      c.ours_us.push_back(time_writes(c.ours, c.sample, options.writes));
    }

  std::printf("dds_write of a cell45 report (45 pairs), %d rounds x %d writes, medians:\n",
              options.rounds, options.writes);
  std::printf("%-12s %16s %16s %14s %8s\n", "sample", "cyclone us", "nearpoint us", "saved us/upd",
              "ratio");
  for (Case& c : cases) {
    std::sort(c.cyclone_us.begin(), c.cyclone_us.end());
    std::sort(c.ours_us.begin(), c.ours_us.end());
    const double cyclone = c.cyclone_us[c.cyclone_us.size() / 2];
    const double ours = c.ours_us[c.ours_us.size() / 2];
    std::printf("%-12s %16.2f %16.2f %14.2f %7.2fx\n", c.name, cyclone, ours,
                (cyclone - ours) / double(c.updates), cyclone / ours);
  }
  dds_delete(participant);
  return 0;
}
