// SPDX-License-Identifier: Apache-2.0
// Scenes spread over three nearpointd replicas behind HAProxy (issue 24), as real processes on
// 127.0.0.1: deploy/haproxy/nearpoint.cfg hashes the x-nearpoint-scene header that the client
// library puts on every call about a scene (consistent hashing), and checks each replica with the
// gRPC health protocol.
//
// What these tests guard:
// - Placement: 30 scenes created through the proxy land on all three replicas (each replica's log
//   names its scenes), each on exactly one; every later call about a scene reaches that replica
//   (a scene exists on one replica only, so a raw call with the header that succeeds was routed
//   there; one routed elsewhere would get NOT_FOUND).
// - Answers: every stream's reports agree with the engine run in this process.
// - Failover without silent loss: a replica is stopped (SIGSTOP, so that its streams surely have
//   updates in flight) and killed (SIGKILL). Only its scenes' sessions see UNAVAILABLE error
//   reports and then a resumed stream (ResumeEvent, Report::resumed) on another replica; the other
//   sessions lose nothing and never reconnect; every pushed update is answered exactly once, in
//   order, by a report or by an error report naming it.
// - Return: the replica is started again on its port; HAProxy's ring gives it its scenes back
//   (HAProxy's consistent hashing: a server's points on the ring depend only on its id and
//   weight), open streams stay where they are and go on, and queries and new sessions on the
//   moved-back scenes work (the client re-creates a scene that is not where the call went).
// Skipped, saying so, only when haproxy is not installed (deploy/install-deps.sh installs it).
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "common/child_process.hpp"
#include "nearpoint/client/client.hpp"
#include "nearpoint/distance.hpp"
#include "nearpoint_distance.grpc.pb.h"

namespace {

using namespace std::chrono_literals;
using nearpoint::testkit::ChildProcess;
namespace npc = nearpoint::client;
namespace v1 = nearpoint::v1;
using Clock = std::chrono::steady_clock;

constexpr int kReplicas = 3;
constexpr int kScenes = 30;

std::string find_haproxy() {
  for (const char* path : {"/usr/sbin/haproxy", "/usr/bin/haproxy", "/usr/local/sbin/haproxy"})
    if (access(path, X_OK) == 0) return path;
  return {};
}

// A port of 127.0.0.1 free right now (bound, read back, released), for HAProxy's frontend, which
// cannot report a port it picked itself.
int free_port() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return 0;
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  socklen_t length = sizeof address;
  int port = 0;
  if (bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0 &&
      getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) == 0)
    port = ntohs(address.sin_port);
  close(fd);
  return port;
}

std::string scene_name(int k) {
  return "sharded-" + std::to_string(k);
}

// The mover's position at step `step` of scene `k`: a sphere of radius 0.25 sliding along x
// past a unit box at the origin (always separated, 0.4 to 1.9 m apart).
Eigen::Vector3d mover_at(int k, std::uint64_t step) {
  return {1.15 + 0.05 * (k % 10) + 0.01 * double(step % 100), 0.3, -0.2};
}

// The engine's distance for that pose, computed here without any server.
double engine_distance(const Eigen::Vector3d& mover) {
  using nearpoint::Pose;
  using nearpoint::Shape;
  const Shape<double> box{nearpoint::Box<double>{Eigen::Vector3d(0.5, 0.5, 0.5)}};
  const Shape<double> sphere = Shape<double>::sphere(0.25);
  nearpoint::DistanceOptions<double> options;
  const auto identity = Eigen::Quaterniond::Identity();
  const auto result =
      nearpoint::distance(box, Pose<double>::from_quaternion(identity, {0, 0, 0}), sphere,
                          Pose<double>::from_quaternion(identity, mover), options, nullptr);
  return result.distance;
}

class Replica {
 public:
  // Starts nearpointd on `port` (0: any; the chosen one is read back).
  std::string start(int port) {
    const std::string port_file =
        (std::filesystem::temp_directory_path() /
         ("nearpoint-sharded." + std::to_string(getpid()) + "." + std::to_string(port) + "." +
          std::to_string(Clock::now().time_since_epoch().count())))
            .string();
    process_ = std::make_unique<ChildProcess>(
        std::vector<std::string>{NEARPOINTD_PATH, "--listen", "127.0.0.1:" + std::to_string(port),
                                 "--port-file", port_file, "--workers", "1"});
    if (!process_->started()) return "nearpointd did not start";
    if (process_->wait_for_stderr("event=listening", 20s).empty())
      return "nearpointd did not listen: " + process_->stderr_text();
    std::ifstream(port_file) >> port_;
    std::filesystem::remove(port_file);
    return port_ > 0 ? "" : "no port in the port file";
  }
  int port() const { return port_; }
  ChildProcess& process() { return *process_; }
  std::string log() { return process_ ? process_->stderr_text() : ""; }
  // The scenes this replica's log says it created (with any routing key).
  std::multiset<std::string> created() {
    std::multiset<std::string> out;
    std::istringstream lines(log());
    for (std::string line; std::getline(lines, line);) {
      if (line.find("event=scene_created") == std::string::npos) continue;
      const auto at = line.find(" scene=");
      if (at == std::string::npos) continue;
      std::string id = line.substr(at + 7);
      id = id.substr(0, id.find(' '));
      if (!id.empty() && id.front() == '"') id = id.substr(1, id.size() - 2);
      out.insert(id);
    }
    return out;
  }
  void kill_now() {
    if (process_) {
      process_->signal(SIGKILL);
      process_->wait_exit(10s);
    }
  }

 private:
  std::unique_ptr<ChildProcess> process_;
  int port_ = 0;
};

class Sharded : public ::testing::Test {
 protected:
  void SetUp() override {
    haproxy_path_ = find_haproxy();
    if (haproxy_path_.empty())
      GTEST_SKIP() << "haproxy is not installed (deploy/install-deps.sh installs it): the sharded "
                      "setup cannot be tested";
    for (Replica& replica : replicas_) ASSERT_EQ(replica.start(0), "");
    proxy_port_ = free_port();
    ASSERT_GT(proxy_port_, 0);
    // deploy/haproxy/nearpoint.cfg reads the addresses from the environment.
    setenv("NEARPOINT_PROXY_LISTEN", ("127.0.0.1:" + std::to_string(proxy_port_)).c_str(), 1);
    for (int i = 0; i < kReplicas; ++i)
      setenv(("NEARPOINT_REPLICA_" + std::to_string(i + 1)).c_str(),
             ("127.0.0.1:" + std::to_string(replicas_[i].port())).c_str(), 1);
    haproxy_ = std::make_unique<ChildProcess>(std::vector<std::string>{
        haproxy_path_, "-db", "-f",
        std::string(NEARPOINT_SOURCE_DIR) + "/deploy/haproxy/nearpoint.cfg"});
    ASSERT_TRUE(haproxy_->started());
    npc::ClientOptions options;
    options.call_timeout = 5000ms;
    client_ = npc::Client::connect(target(), options);
    ASSERT_TRUE(client_->wait_connected(Clock::now() + 20s)) << haproxy_->stderr_text();
    // Every replica answers through the proxy (calls without the routing header go
    // round-robin: 2 × 3 in a row reach each replica twice).
    const Clock::time_point give_up = Clock::now() + 20s;
    int answered = 0;
    while (answered < 2 * kReplicas && Clock::now() < give_up)
      answered = client_->list_geometries().ok() ? answered + 1 : 0;
    ASSERT_EQ(answered, 2 * kReplicas) << haproxy_->stderr_text();
  }

  void TearDown() override {
    client_.reset();
    if (haproxy_) {
      haproxy_->signal(SIGTERM);
      haproxy_->wait_exit(10s);
      // Which replica the proxy took out of the ring, when, and why (its health checks' verdicts).
      if (HasFailure()) std::printf("haproxy's log:\n%s\n", haproxy_->stderr_text().c_str());
    }
    for (Replica& replica : replicas_) replica.kill_now();
  }

  std::string target() const { return "127.0.0.1:" + std::to_string(proxy_port_); }

  // Registers the two geometries and creates the 30 scenes through the proxy.
  void create_scenes() {
    npc::Geometry box;
    box.name = "box";
    box.pieces.push_back(npc::Piece{nearpoint::Box<double>{Eigen::Vector3d(0.5, 0.5, 0.5)}, 0, {}});
    npc::Geometry ball;
    ball.name = "ball";
    ball.pieces.push_back(npc::Piece{nearpoint::Point{}, 0.25, {}});
    auto box_info = client_->register_geometry(box);
    ASSERT_TRUE(box_info.ok()) << box_info.status().describe();
    box_id_ = box_info->geometry_id;
    auto ball_info = client_->register_geometry(ball);
    ASSERT_TRUE(ball_info.ok()) << ball_info.status().describe();
    // Content ids: the same geometry gives the same id, whichever replica answered.
    for (int again = 0; again < 2 * kReplicas; ++again) {
      auto same = client_->register_geometry(box);
      ASSERT_TRUE(same.ok()) << same.status().describe();
      EXPECT_EQ(same->geometry_id, box_info->geometry_id);
    }
    for (int k = 0; k < kScenes; ++k) {
      npc::Scene scene;
      scene.requested_id = scene_name(k);
      npc::SceneObject base;
      base.id = "base";
      base.geometry_id = box_info->geometry_id;
      npc::SceneObject mover;
      mover.id = "mover";
      mover.geometry_id = ball_info->geometry_id;
      mover.pose = npc::to_pose_input(Eigen::Quaterniond::Identity(), mover_at(k, 0));
      scene.objects = {base, mover};
      auto created = client_->create_scene(scene);
      ASSERT_TRUE(created.ok()) << scene.requested_id << ": " << created.status().describe();
      ASSERT_EQ(created->scene_id, scene.requested_id);
    }
  }

  // Which replica holds each scene, from the replicas' logs; every scene on exactly one. A log
  // line may trail the answer to its call by a moment: waits (bounded) until `expected` scenes
  // are logged.
  std::map<std::string, int> placement(std::size_t expected = kScenes) {
    const Clock::time_point give_up = Clock::now() + 10s;
    for (;;) {
      std::size_t logged = 0;
      for (Replica& replica : replicas_) logged += replica.created().size();
      if (logged >= expected || Clock::now() > give_up) break;
      std::this_thread::sleep_for(10ms);
    }
    std::map<std::string, int> where;
    for (int i = 0; i < kReplicas; ++i)
      for (const std::string& id : replicas_[i].created()) {
        EXPECT_EQ(where.count(id), 0u) << id << " was created on two replicas";
        where[id] = i;
      }
    return where;
  }

  std::string haproxy_path_;
  Replica replicas_[kReplicas];
  int proxy_port_ = 0;
  std::unique_ptr<ChildProcess> haproxy_;
  std::unique_ptr<npc::Client> client_;
  std::string box_id_;
};

// One session's record: what was pushed and what came back, in order.
struct Recorder {
  std::mutex mutex;
  std::vector<std::uint64_t> pushed;
  std::vector<npc::Report> reports;
  std::vector<npc::ResumeEvent> resumes;
  std::map<std::uint64_t, Eigen::Vector3d> sent_pose;
};

// One session per scene, through `client`, each recording its reports and resume events in its
// own Recorder; up to 4 updates in flight, 20 s to reconnect.
void open_recorded_sessions(npc::Client& client, std::vector<std::unique_ptr<Recorder>>& records,
                            std::vector<std::unique_ptr<npc::Session>>& sessions) {
  for (int k = 0; k < kScenes; ++k) {
    records.push_back(std::make_unique<Recorder>());
    Recorder* record = records.back().get();
    npc::SessionOptions options;
    options.max_in_flight = 4;
    options.reconnect_timeout = 20000ms;
    options.on_report = [record](const npc::Report& report) {
      std::lock_guard lock(record->mutex);
      record->reports.push_back(report);
    };
    options.on_resumed = [record](const npc::ResumeEvent& event) {
      std::lock_guard lock(record->mutex);
      record->resumes.push_back(event);
    };
    auto session = client.open_session(scene_name(k), options);
    ASSERT_TRUE(session.ok()) << session.status().describe();
    sessions.push_back(std::move(*session));
  }
}

TEST_F(Sharded, ScenesSpreadOverEveryReplicaAndStayThere) {
  ASSERT_NO_FATAL_FAILURE(create_scenes());
  const std::map<std::string, int> where = placement();
  ASSERT_EQ(where.size(), std::size_t(kScenes));
  int share[kReplicas] = {};
  for (const auto& [id, replica] : where) ++share[replica];
  for (int i = 0; i < kReplicas; ++i)
    EXPECT_GT(share[i], 0) << "replica " << i << " holds none of the " << kScenes << " scenes";
  std::printf("shares of %d scenes: %d / %d / %d\n", kScenes, share[0], share[1], share[2]);

  // Raw calls with the header and nothing else: no client-side re-creation could hide a
  // misrouted call (a replica without the scene answers NOT_FOUND).
  auto channel = grpc::CreateChannel(target(), grpc::InsecureChannelCredentials());
  auto stub = v1::DistanceService::NewStub(channel);
  for (int round = 0; round < 3; ++round)
    for (int k = 0; k < kScenes; ++k) {
      grpc::ClientContext context;
      context.set_deadline(std::chrono::system_clock::now() + 5s);
      context.AddMetadata("x-nearpoint-scene", scene_name(k));
      v1::QueryRequest request;
      request.set_scene_id(scene_name(k));
      v1::DistanceReport report;
      const grpc::Status status = stub->Query(&context, request, &report);
      ASSERT_TRUE(status.ok()) << scene_name(k) << " round " << round << ": "
                               << status.error_message();
      ASSERT_EQ(report.pairs_size(), 1);
      EXPECT_NEAR(report.pairs(0).distance(), engine_distance(mover_at(k, 0)), 1e-12);
    }

  // Streams through the proxy: every report agrees with the engine.
  std::vector<std::unique_ptr<npc::Session>> sessions;
  for (int k = 0; k < kScenes; ++k) {
    auto session = client_->open_session(scene_name(k));
    ASSERT_TRUE(session.ok()) << session.status().describe();
    sessions.push_back(std::move(*session));
  }
  constexpr int kSteps = 10;
  for (int step = 1; step <= kSteps; ++step)
    for (int k = 0; k < kScenes; ++k) {
      auto pushed = sessions[k]->push(
          {npc::ObjectPose("mover", Eigen::Quaterniond::Identity(), mover_at(k, step))},
          Clock::now() + 10s);
      ASSERT_TRUE(pushed.ok()) << pushed.status().describe();
    }
  for (int k = 0; k < kScenes; ++k) {
    for (int step = 1; step <= kSteps; ++step) {
      auto report = sessions[k]->next(Clock::now() + 10s);
      ASSERT_TRUE(report.ok()) << report.status().describe();
      ASSERT_TRUE(report->error.ok()) << report->error.describe();
      EXPECT_EQ(report->sequence, std::uint64_t(step));
      ASSERT_EQ(report->pairs.size(), 1u);
      EXPECT_NEAR(report->pairs[0].distance, engine_distance(mover_at(k, step)), 1e-12);
      EXPECT_FALSE(report->resumed);
    }
    EXPECT_TRUE(sessions[k]->close(Clock::now() + 10s).ok());
    EXPECT_EQ(sessions[k]->reconnects(), 0u);
  }
  // Nothing was created twice: no call was routed where its scene is not.
  EXPECT_EQ(placement().size(), std::size_t(kScenes));
  for (Replica& replica : replicas_)
    EXPECT_EQ(replica.created().size(), std::size_t(share[&replica - replicas_]));

  // A scene created without an id gets one chosen by the client, so that it is routable.
  npc::Scene unnamed;
  unnamed.objects = {{"a", box_id_, {}, {}, {}}, {"b", box_id_, {}, {}, {}}};
  unnamed.objects[1].pose.translation = Eigen::Vector3d(3, 0, 0);
  auto created = client_->create_scene(unnamed);
  ASSERT_TRUE(created.ok()) << created.status().describe();
  EXPECT_EQ(created->scene_id.rfind("s-", 0), 0u) << created->scene_id;
  auto report = client_->query(created->scene_id, {});
  ASSERT_TRUE(report.ok()) << report.status().describe();
  EXPECT_NEAR(report->pairs.at(0).distance, 2.0, 1e-12);
}

TEST_F(Sharded, AReplicaDiesOnlyItsScenesResumeAndItComesBack) {
  ASSERT_NO_FATAL_FAILURE(create_scenes());
  const std::map<std::string, int> where = placement();
  ASSERT_EQ(where.size(), std::size_t(kScenes));
  // The victim: the replica with the most scenes.
  int share[kReplicas] = {};
  for (const auto& [id, replica] : where) ++share[replica];
  const int victim = int(std::max_element(share, share + kReplicas) - share);
  std::set<int> victims;
  for (int k = 0; k < kScenes; ++k)
    if (where.at(scene_name(k)) == victim) victims.insert(k);
  ASSERT_FALSE(victims.empty());

  std::vector<std::unique_ptr<Recorder>> records;
  std::vector<std::unique_ptr<npc::Session>> sessions;
  ASSERT_NO_FATAL_FAILURE(open_recorded_sessions(*client_, records, sessions));
  std::uint64_t step = 0;
  auto push_all = [&](const std::set<int>& only = {}) {
    ++step;
    for (int k = 0; k < kScenes; ++k) {
      if (!only.empty() && !only.count(k)) continue;
      const Eigen::Vector3d at = mover_at(k, step);
      auto pushed = sessions[k]->push(
          {npc::ObjectPose("mover", Eigen::Quaterniond::Identity(), at)}, Clock::now() + 30s);
      ASSERT_TRUE(pushed.ok()) << scene_name(k) << ": " << pushed.status().describe();
      std::lock_guard lock(records[k]->mutex);
      records[k]->pushed.push_back(*pushed);
      records[k]->sent_pose[*pushed] = at;
    }
  };
  auto settle = [&](int k) {
    // Everything pushed so far answered (a report or an error report), within a bound.
    const Clock::time_point give_up = Clock::now() + 30s;
    for (;;) {
      {
        std::lock_guard lock(records[k]->mutex);
        if (records[k]->reports.size() >= records[k]->pushed.size()) return;
      }
      if (Clock::now() > give_up) {
        ADD_FAILURE() << scene_name(k) << ": updates left unanswered";
        return;
      }
      std::this_thread::sleep_for(5ms);
    }
  };
  for (int i = 0; i < 5; ++i) ASSERT_NO_FATAL_FAILURE(push_all());
  for (int k = 0; k < kScenes; ++k) settle(k);

  // Stop the victim so that its streams surely hold an unanswered update each, then kill it.
  replicas_[victim].process().signal(SIGSTOP);
  ASSERT_NO_FATAL_FAILURE(push_all());
  replicas_[victim].kill_now();
  for (int i = 0; i < 10; ++i) ASSERT_NO_FATAL_FAILURE(push_all());
  for (int k = 0; k < kScenes; ++k) settle(k);

  // The victim's scenes now live on the survivors (re-created there by the sessions), each on
  // one of them.
  std::map<std::string, int> survivors;
  const Clock::time_point logged_by = Clock::now() + 10s;
  do {
    survivors.clear();
    for (int i = 0; i < kReplicas; ++i) {
      if (i == victim) continue;
      for (const std::string& id : replicas_[i].created()) survivors[id] += 1;
    }
    if (survivors.size() >= std::size_t(kScenes)) break;
    std::this_thread::sleep_for(10ms);
  } while (Clock::now() < logged_by);
  for (const int k : victims) EXPECT_EQ(survivors[scene_name(k)], 1) << scene_name(k);

  // HAProxy's health check takes the victim out of the ring (the sessions did not wait for it:
  // a refused connection is redispatched to the next server of the ring at once).
  const std::string name = "replica" + std::to_string(victim + 1);
  ASSERT_FALSE(haproxy_->wait_for_stderr(name + " is DOWN", 20s).empty());
  // Bring it back on its port; wait for HAProxy to see it up again.
  ASSERT_EQ(replicas_[victim].start(replicas_[victim].port()), "");
  ASSERT_FALSE(haproxy_->wait_for_stderr(name + " is UP", 20s).empty());
  for (int i = 0; i < 5; ++i) ASSERT_NO_FATAL_FAILURE(push_all());
  for (int k = 0; k < kScenes; ++k) settle(k);

  std::size_t unavailable = 0;
  for (int k = 0; k < kScenes; ++k) {
    const bool victim_scene = victims.count(k) != 0;
    std::lock_guard lock(records[k]->mutex);
    const Recorder& record = *records[k];
    // Exactly once, in order: one report per pushed update, by its sequence number.
    ASSERT_EQ(record.reports.size(), record.pushed.size()) << scene_name(k);
    bool resumed_seen = false;
    for (std::size_t i = 0; i < record.reports.size(); ++i) {
      const npc::Report& report = record.reports[i];
      EXPECT_EQ(report.sequence, record.pushed[i]) << scene_name(k);
      if (!report.error.ok()) {
        // Named in an error: only the victim's scenes, only UNAVAILABLE, never after resuming.
        EXPECT_TRUE(victim_scene) << scene_name(k) << ": " << report.error.describe();
        EXPECT_EQ(report.error.code, npc::kUnavailable) << report.error.describe();
        EXPECT_FALSE(resumed_seen) << scene_name(k) << ": an error after the stream resumed";
        ++unavailable;
        continue;
      }
      resumed_seen = resumed_seen || report.resumed;
      ASSERT_EQ(report.pairs.size(), 1u);
      EXPECT_NEAR(report.pairs[0].distance, engine_distance(record.sent_pose.at(report.sequence)),
                  1e-12)
          << scene_name(k) << " update " << report.sequence;
    }
    if (victim_scene) {
      EXPECT_TRUE(resumed_seen) << scene_name(k) << ": no report says the stream resumed";
      EXPECT_EQ(record.resumes.size(), 1u) << scene_name(k);
      EXPECT_EQ(sessions[k]->reconnects(), 1u) << scene_name(k);
    } else {
      EXPECT_TRUE(record.resumes.empty()) << scene_name(k) << " resumed but its replica lived";
      EXPECT_EQ(sessions[k]->reconnects(), 0u) << scene_name(k);
    }
  }
  // The victim was stopped with updates in flight, and they were named in errors, not lost (the
  // checks above). How many of its streams still held one when it died depends on timing: all
  // of them in the normal build, 2 of 11 in one TSan run, where the rest were answered by their
  // resumed streams (counted, in order, above); why TSan shifts that is not yet understood.
  EXPECT_GE(unavailable, 1u);
  std::printf(
      "replica %d killed: %zu of %d scenes resumed elsewhere, %zu updates answered "
      "UNAVAILABLE, the other streams lost nothing\n",
      victim + 1, victims.size(), kScenes, unavailable);

  for (auto& session : sessions) EXPECT_TRUE(session->close(Clock::now() + 10s).ok());

  // With the victim back, the ring sends its scenes to it again, and it does not hold them. A
  // new session on such a scene gets UNAVAILABLE for its first update (an error report whose
  // message quotes the replica's NOT_FOUND: never evaluated, as for a dead replica's updates),
  // re-creates the scene there and resumes; on the other scenes nothing happens. Then a query on
  // every scene works.
  for (int k = 0; k < kScenes; ++k) {
    const bool victim_scene = victims.count(k) != 0;
    std::vector<npc::ResumeEvent> resumes;
    npc::SessionOptions options;
    options.on_resumed = [&resumes](const npc::ResumeEvent& event) { resumes.push_back(event); };
    auto session = client_->open_session(scene_name(k), options);
    ASSERT_TRUE(session.ok());
    auto pushed =
        (*session)->push({npc::ObjectPose("mover", Eigen::Quaterniond::Identity(), mover_at(k, 7))},
                         Clock::now() + 10s);
    ASSERT_TRUE(pushed.ok());
    auto answer = (*session)->next(Clock::now() + 20s);
    ASSERT_TRUE(answer.ok()) << answer.status().describe();
    if (victim_scene) {
      EXPECT_EQ(answer->error.code, npc::kUnavailable)
          << scene_name(k) << ": " << answer->error.describe();
      EXPECT_NE(answer->error.message.find("NOT_FOUND"), std::string::npos)
          << answer->error.describe();
      pushed = (*session)->push(
          {npc::ObjectPose("mover", Eigen::Quaterniond::Identity(), mover_at(k, 7))},
          Clock::now() + 20s);
      ASSERT_TRUE(pushed.ok()) << pushed.status().describe();
      answer = (*session)->next(Clock::now() + 20s);
      ASSERT_TRUE(answer.ok()) << answer.status().describe();
      EXPECT_TRUE(answer->resumed) << scene_name(k);
    }
    ASSERT_TRUE(answer->error.ok()) << scene_name(k) << ": " << answer->error.describe();
    EXPECT_NEAR(answer->pairs.at(0).distance, engine_distance(mover_at(k, 7)), 1e-12);
    EXPECT_TRUE((*session)->close(Clock::now() + 10s).ok());
    EXPECT_EQ(resumes.size(), victim_scene ? 1u : 0u) << scene_name(k);
    auto report = client_->query(scene_name(k), {});
    ASSERT_TRUE(report.ok()) << scene_name(k) << ": " << report.status().describe();
    EXPECT_NEAR(report->pairs.at(0).distance, engine_distance(mover_at(k, 0)), 1e-12);
  }
  // The returned replica holds exactly the victim's scenes again (its ring points are the same).
  std::set<std::string> back;
  const Clock::time_point back_by = Clock::now() + 10s;
  do {
    back.clear();
    for (const std::string& id : replicas_[victim].created()) back.insert(id);
    if (back.size() >= victims.size()) break;
    std::this_thread::sleep_for(10ms);
  } while (Clock::now() < back_by);
  std::set<std::string> expected;
  for (const int k : victims) expected.insert(scene_name(k));
  EXPECT_EQ(back, expected);
}

}  // namespace

namespace {

// A rolling update (Kubernetes replaces pods one by one with SIGTERM): the draining replica ends
// its streams at once ("draining"), refuses new calls and answers health NOT_SERVING until it
// exits, so HAProxy drops it from the ring. Its sessions must resume on another replica without
// losing an update: every pushed update answered once, by a report or an UNAVAILABLE error report
// (a drain's says the update was never evaluated); the other sessions see nothing.
TEST_F(Sharded, ADrainingReplicaHandsItsScenesOnWithoutLoss) {
  ASSERT_NO_FATAL_FAILURE(create_scenes());
  const std::map<std::string, int> where = placement();
  ASSERT_EQ(where.size(), std::size_t(kScenes));
  const int victim = where.at(scene_name(0));
  std::set<int> victims;
  for (int k = 0; k < kScenes; ++k)
    if (where.at(scene_name(k)) == victim) victims.insert(k);

  std::vector<std::unique_ptr<Recorder>> records;
  std::vector<std::unique_ptr<npc::Session>> sessions;
  ASSERT_NO_FATAL_FAILURE(open_recorded_sessions(*client_, records, sessions));
  std::uint64_t step = 0;
  auto push_all = [&] {
    ++step;
    for (int k = 0; k < kScenes; ++k) {
      const Eigen::Vector3d at = mover_at(k, step);
      auto pushed = sessions[k]->push(
          {npc::ObjectPose("mover", Eigen::Quaterniond::Identity(), at)}, Clock::now() + 30s);
      ASSERT_TRUE(pushed.ok()) << scene_name(k) << ": " << pushed.status().describe();
      std::lock_guard lock(records[k]->mutex);
      records[k]->pushed.push_back(*pushed);
      records[k]->sent_pose[*pushed] = at;
    }
  };
  for (int i = 0; i < 3; ++i) ASSERT_NO_FATAL_FAILURE(push_all());
  replicas_[victim].process().signal(SIGTERM);
  for (int i = 0; i < 10; ++i) ASSERT_NO_FATAL_FAILURE(push_all());
  EXPECT_EQ(replicas_[victim].process().wait_exit(30s), 0) << "the drain did not end cleanly";
  for (int i = 0; i < 3; ++i) ASSERT_NO_FATAL_FAILURE(push_all());
  for (auto& session : sessions) EXPECT_TRUE(session->close(Clock::now() + 20s).ok());

  std::size_t unavailable = 0;
  for (int k = 0; k < kScenes; ++k) {
    const bool victim_scene = victims.count(k) != 0;
    std::lock_guard lock(records[k]->mutex);
    const Recorder& record = *records[k];
    ASSERT_EQ(record.reports.size(), record.pushed.size()) << scene_name(k);
    for (std::size_t i = 0; i < record.reports.size(); ++i) {
      const npc::Report& report = record.reports[i];
      EXPECT_EQ(report.sequence, record.pushed[i]) << scene_name(k);
      if (!report.error.ok()) {
        EXPECT_TRUE(victim_scene) << scene_name(k) << ": " << report.error.describe();
        EXPECT_EQ(report.error.code, npc::kUnavailable) << report.error.describe();
        ++unavailable;
        continue;
      }
      ASSERT_EQ(report.pairs.size(), 1u);
      EXPECT_NEAR(report.pairs[0].distance, engine_distance(record.sent_pose.at(report.sequence)),
                  1e-12)
          << scene_name(k) << " update " << report.sequence;
    }
    EXPECT_EQ(record.resumes.size(), victim_scene ? 1u : 0u) << scene_name(k);
  }
  std::printf(
      "replica %d drained: %zu scenes resumed elsewhere, %zu updates answered "
      "UNAVAILABLE\n",
      victim + 1, victims.size(), unavailable);
}

}  // namespace
