// SPDX-License-Identifier: Apache-2.0
#include "dds_topics.hpp"

#include <algorithm>
#include <array>
#include <map>
#include <ostream>
#include <thread>
#include <tuple>

namespace nearpoint::cli {
namespace {

using Clock = std::chrono::steady_clock;

struct Seen {
  std::size_t publishers = 0;
  std::size_t subscribers = 0;
};

/// Reads every sample of a builtin discovery topic into `topics`, by (topic, type).
void collect(dds_entity_t reader, bool publications,
             std::map<std::pair<std::string, std::string>, Seen>& topics) {
  for (;;) {
    std::array<void*, 32> samples{};
    std::array<dds_sample_info_t, 32> infos{};
    const dds_return_t n = dds_read(reader, samples.data(), infos.data(), 32, 32);
    if (n <= 0) return;
    for (dds_return_t i = 0; i < n; ++i) {
      const dds_sample_info_t& info = infos[std::size_t(i)];
      if (!info.valid_data || info.instance_state != DDS_IST_ALIVE) continue;
      const auto* e = static_cast<const dds_builtintopic_endpoint_t*>(samples[std::size_t(i)]);
      Seen& seen = topics[{e->topic_name ? e->topic_name : "", e->type_name ? e->type_name : ""}];
      ++(publications ? seen.publishers : seen.subscribers);
    }
    dds_return_loan(reader, samples.data(), n);
    if (n < 32) return;
  }
}

}  // namespace

int run_dds_topics(const DdsTopicsOptions& options, std::ostream& out, std::ostream& err) {
  if (std::string problem = dds::check_configuration(options.dds.allow_default_config);
      !problem.empty()) {
    err << "nearpoint dds topics: " << problem << "\n";
    return kStreamBadConfiguration;
  }
  const dds_entity_t participant = dds_create_participant(options.dds.domain_id, nullptr, nullptr);
  if (participant < 0) {
    err << "nearpoint dds topics: " << dds::describe("dds_create_participant", participant) << "\n";
    return kStreamCannotRun;
  }
  const dds_entity_t publications =
      dds_create_reader(participant, DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr);
  const dds_entity_t subscriptions =
      dds_create_reader(participant, DDS_BUILTIN_TOPIC_DCPSSUBSCRIPTION, nullptr, nullptr);
  if (publications < 0 || subscriptions < 0) {
    err << "nearpoint dds topics: "
        << dds::describe("dds_create_reader(builtin)", std::min(publications, subscriptions))
        << "\n";
    dds_delete(participant);
    return kStreamCannotRun;
  }
  // Discovery is continuous: wait, then read what is known (the builtin readers keep the
  // endpoints alive now, so reading at the end is enough).
  std::this_thread::sleep_for(options.wait);
  std::map<std::pair<std::string, std::string>, Seen> topics;
  collect(publications, true, topics);
  collect(subscriptions, false, topics);
  dds_delete(participant);

  std::size_t listed = 0;
  for (const auto& [key, seen] : topics) {
    const auto& [topic, type] = key;
    if (topic.starts_with("DCPS")) continue;  // Cyclone's own discovery topics
    if (!options.filter.empty() && !topic.starts_with(options.filter)) continue;
    out << dds::ros_topic_name(topic) << " [" << dds::ros_type_name(type) << "]  dds: " << topic
        << " " << type << "  publishers: " << seen.publishers
        << "  subscribers: " << seen.subscribers << "\n";
    ++listed;
  }
  if (listed == 0)
    err << "nearpoint dds topics: no topics seen on domain " << options.dds.domain_id << " within "
        << options.wait.count() << " ms\n";
  return kStreamOk;
}

int run_dds_echo(const DdsEchoOptions& options, std::ostream& out, std::ostream& err) {
  std::string error;
  std::unique_ptr<DdsPoseClient> client = DdsPoseClient::create(options.dds, error);
  if (!client) {
    err << "nearpoint dds echo: " << error << "\n";
    return error.starts_with("CYCLONEDDS_URI") || error.starts_with("--dds-prefix")
               ? kStreamBadConfiguration
               : kStreamCannotRun;
  }
  // Matched on both topics means a nearpointd is there; its reports from now on are seen.
  if (!client->wait_matched(options.timeout, error)) {
    err << "nearpoint dds echo: " << error << "\n";
    return kStreamCannotRun;
  }
  err << "nearpoint dds echo: listening on "
      << dds::distance_reports_topic(options.dds.topic_prefix) << "\n"
      << std::flush;
  std::uint64_t printed = 0;
  for (;;) {
    const int taken = client->take_any_reports(
        options.timeout,
        [&](const DistanceReportSample& report) {
          if (options.count > 0 && printed >= options.count) return;
          if (!options.scene_id.empty() &&
              options.scene_id != (report.scene_id ? report.scene_id : ""))
            return;
          nlohmann::ordered_json line;
          line["scene_id"] = report.scene_id ? report.scene_id : "";
          line["client_id"] = report.client_id ? report.client_id : "";
          line.update(report_json(report));
          out << line.dump() << "\n" << std::flush;
          ++printed;
        },
        error);
    if (taken < 0) {
      err << "nearpoint dds echo: " << error << "\n";
      return kStreamCannotRun;
    }
    if (options.count > 0 && printed >= options.count) return kStreamOk;
    if (taken == 0) break;
  }
  if (options.count > 0) {
    err << "nearpoint dds echo: " << printed << " of " << options.count << " reports within "
        << options.timeout.count() << " ms of each other\n";
    return kStreamIncomplete;
  }
  return printed > 0 ? kStreamOk : kStreamIncomplete;
}

}  // namespace nearpoint::cli
