// SPDX-License-Identifier: Apache-2.0
// Robot scenes over the wire (issue 32, items 2–4): a real nearpointd process on 127.0.0.1, a
// scene created from a robot description, joint positions streamed by name, and every answer
// held to references we did not write:
//   - the arm (examples/robots/arm7.urdf): each reported distance against KDL's forward
//     kinematics (kdl_parser reads the same URDF) and the engine run here on the links' geometry;
//   - the joint-space gradient against central differences of the distances the server reports;
//   - MuJoCo's humanoid (nearpointd --scene humanoid.xml): distances against MuJoCo's own
//     kinematics and collision pipeline (capsules and spheres);
//   - `nearpoint scene create arm7.urdf` and `nearpoint stream --joints` (the CLI) against KDL;
//   - bad updates (unknown joint, NaN, wrong count, a carried object's pose) are error reports
//     naming the field, and the stream and other clients go on.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>

#include <kdl/tree.hpp>
#include <kdl/treefksolverpos_recursive.hpp>
#include <kdl_parser/kdl_parser.hpp>
#include <nlohmann/json.hpp>

#include "common/child_process.hpp"
#include "nearpoint/client/client.hpp"
#include "nearpoint/client/mesh_loader.hpp"
#include "nearpoint/compound.hpp"
#include "nearpoint/robots/robot.hpp"

namespace {

namespace fs = std::filesystem;
using namespace nearpoint;
using namespace nearpoint::robots;
using ::nearpoint::testkit::ChildProcess;
using Clock = std::chrono::steady_clock;

const fs::path kExamples = NEARPOINT_EXAMPLES_DIR;
const fs::path kMujocoModels = NEARPOINT_MUJOCO_MODELS_DIR;

using client::mesh_loader;

std::string temp_path(const std::string& name) {
  return (fs::temp_directory_path() /
          (name + "." + std::to_string(getpid()) + "." +
           ::testing::UnitTest::GetInstance()->current_test_info()->name()))
      .string();
}

/// nearpointd on 127.0.0.1:0 with `extra` flags, until the test ends.
struct Server {
  std::string port_file;
  std::unique_ptr<ChildProcess> process;
  int port = 0;
  explicit Server(std::vector<std::string> extra = {}) {
    port_file = temp_path("nearpointd.port");
    fs::remove(port_file);
    std::vector<std::string> argv = {
        NEARPOINTD_PATH, "--listen", "127.0.0.1:0", "--port-file", port_file, "--workers", "2"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    process = std::make_unique<ChildProcess>(argv);
    EXPECT_TRUE(process->started());
    const std::string listening =
        process->wait_for_stderr("event=listening", std::chrono::seconds(30));
    EXPECT_FALSE(listening.empty()) << process->stderr_text();
    std::ifstream(port_file) >> port;
  }
  ~Server() { fs::remove(port_file); }
  std::string target() const { return "127.0.0.1:" + std::to_string(port); }
};

// Random positions of the one-dof joints within their limits (±π when unlimited).
std::vector<double> random_q(const KinematicTree& tree, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(0, 1);
  std::vector<double> q = tree.neutral();
  for (const Joint& joint : tree.joints) {
    if (joint.nq() != 1) continue;
    const double lo = joint.limited ? joint.lower : -M_PI;
    const double hi = joint.limited ? joint.upper : M_PI;
    q[joint.q_index] = lo + (hi - lo) * unit(rng);
  }
  return q;
}

/// Every joint with a position, by name, in the tree's q layout.
client::JointPositions joint_positions(const KinematicTree& tree, const std::vector<double>& q) {
  client::JointPositions out;
  for (const Joint& joint : tree.joints) {
    if (joint.nq() == 0) continue;
    out.names.push_back(joint.name);
    for (int c = 0; c < joint.nq(); ++c) out.positions.push_back(q[joint.q_index + c]);
  }
  return out;
}

model::PoseInput to_input(const Pose3d& pose) {
  const Eigen::Quaterniond r(pose.rotation);
  model::PoseInput out;
  out.rotation_wxyz = {r.w(), r.x(), r.y(), r.z()};
  out.translation = pose.translation;
  return out;
}

/// Registers the scene file's geometries and creates its scene; the scene id.
std::string create(client::Client& client, formats::SceneFile file) {
  std::map<std::string, std::string> ids;
  for (const auto& [name, geometry] : file.geometries) {
    auto info = client.register_geometry(geometry);
    EXPECT_TRUE(info.ok()) << info.status().describe();
    if (!info) return {};
    ids[name] = info->geometry_id;
  }
  for (std::size_t i = 0; i < file.scene.objects.size(); ++i)
    file.scene.objects[i].geometry_id = ids.at(file.geometry_names[i]);
  auto created = client.create_scene(file.scene);
  EXPECT_TRUE(created.ok()) << created.status().describe();
  return created ? created->scene_id : std::string();
}

client::Report next(client::Session& session) {
  auto report = session.next(Clock::now() + std::chrono::seconds(30));
  EXPECT_TRUE(report.ok()) << report.status().describe();
  return report ? std::move(report.value()) : client::Report{};
}

/// The arm as the test sees it: our import (for the objects' geometry and their offsets on
/// their links), KDL's tree (for the links' poses) and the engine's compounds.
struct Arm {
  Robot robot;
  formats::SceneFile scene;
  KDL::Tree kdl;
  std::vector<Compound<double>> compounds;
  std::map<std::string, int> object_of;

  Arm() {
    ImportOptions options;
    options.meshes = mesh_loader();
    RobotImport imported = load_urdf(kExamples / "arm7.urdf", options, kExamples / "arm7.srdf");
    EXPECT_TRUE(imported.ok()) << imported.error;
    robot = std::move(imported.robot);
    EXPECT_EQ(load_robot_scene(kExamples / "arm7.urdf", options, {}, scene), "");
    EXPECT_TRUE(kdl_parser::treeFromFile((kExamples / "arm7.urdf").string(), kdl));
    compounds.resize(robot.objects.size());
    for (std::size_t i = 0; i < robot.objects.size(); ++i) {
      EXPECT_EQ(make_compound(robot.objects[i].geometry, compounds[i]), "");
      object_of[robot.objects[i].name] = int(i);
    }
  }

  /// Each object's pose at q with the base at `base`, from KDL's forward kinematics.
  std::vector<Pose3d> kdl_poses(const std::vector<double>& q, const Pose3d& base) const {
    KDL::TreeFkSolverPos_recursive fk(kdl);
    KDL::JntArray kq(kdl.getNrOfJoints());
    for (const auto& [name, element] : kdl.getSegments()) {
      const KDL::Joint& joint = GetTreeElementSegment(element).getJoint();
      if (joint.getType() == KDL::Joint::None) continue;
      kq(GetTreeElementQNr(element)) =
          q[robot.tree.joints[robot.tree.find_joint(joint.getName())].q_index];
    }
    std::vector<Pose3d> out;
    for (const RobotObject& object : robot.objects) {
      KDL::Frame frame;
      EXPECT_GE(fk.JntToCart(kq, frame, robot.tree.links[object.link].name), 0);
      Pose3d link;
      for (int r = 0; r < 3; ++r) {
        link.translation[r] = frame.p[r];
        for (int c = 0; c < 3; ++c) link.rotation(r, c) = frame.M(r, c);
      }
      out.push_back(base.compose(link.compose(object.offset)));
    }
    return out;
  }

  /// The engine's answer for a pair at those poses.
  CompoundResult<double> expected(const std::vector<Pose3d>& poses, const std::string& a,
                                  const std::string& b) const {
    const int ia = object_of.at(a);
    const int ib = object_of.at(b);
    return distance(compounds[ia], poses[ia], compounds[ib], poses[ib]);
  }
};

/// Every pair of `report` against KDL's kinematics and the engine; how many were compared.
int check_against_kdl(const Arm& arm, const client::Report& report, const std::vector<double>& q,
                      const Pose3d& base) {
  EXPECT_TRUE(report.error.ok()) << report.error.describe();
  const std::vector<Pose3d> poses = arm.kdl_poses(q, base);
  int compared = 0;
  for (const client::PairDistance& pair : report.pairs) {
    const CompoundResult<double> expected = arm.expected(poses, pair.object_a, pair.object_b);
    if (expected.nearest.status == Status::separated) {
      EXPECT_EQ(pair.status, model::PairStatus::separated) << pair.object_a << "–" << pair.object_b;
      EXPECT_NEAR(pair.distance, expected.nearest.distance, 1e-9)
          << pair.object_a << "–" << pair.object_b;
    } else {
      EXPECT_TRUE(model::in_contact(pair.status)) << pair.object_a << "–" << pair.object_b;
    }
    ++compared;
  }
  return compared;
}

Pose3d some_base() {
  return Pose3d::from_quaternion(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Vec3d(0.3, -0.2, 1).normalized())),
      Vec3d(0.4, -1.5, 0.25));
}

// The scene from arm7.urdf (with arm7.srdf beside it) on a real nearpointd: streamed joint
// positions by name, with and without a base pose, each report's every pair equal to KDL's
// kinematics with the engine run here, and the pairs those an importer's selection leaves.
TEST(RobotWire, ArmDistancesEqualKdlAndTheEngine) {
  const Arm arm;
  Server server;
  auto client = client::Client::connect(server.target());
  const std::string scene_id = create(*client, arm.scene);
  ASSERT_EQ(scene_id, "arm7");
  client::SessionOptions options;
  auto session = client->open_session(scene_id, options);
  ASSERT_TRUE(session.ok()) << session.status().describe();
  std::mt19937_64 rng(32);
  int compared = 0;
  Pose3d base;
  for (int step = 0; step < 40; ++step) {
    const std::vector<double> q = random_q(arm.robot.tree, rng);
    client::JointPositions joints = joint_positions(arm.robot.tree, q);
    if (step == 20) {  // from here on the robot stands elsewhere (kept by later updates)
      base = some_base();
      joints.base_pose = to_input(base);
    }
    ASSERT_TRUE((*session)->push_joints(joints).ok());
    const client::Report report = next(**session);
    EXPECT_EQ(report.pairs.size(), arm.robot.pairs.size());
    compared += check_against_kdl(arm, report, q, base);
  }
  EXPECT_GE(compared, 40 * 20);
  // A joint not named keeps its position: only joint2 moves.
  std::vector<double> q = random_q(arm.robot.tree, rng);
  ASSERT_TRUE((*session)->push_joints(joint_positions(arm.robot.tree, q)).ok());
  check_against_kdl(arm, next(**session), q, base);
  const Joint& joint2 = arm.robot.tree.joints[arm.robot.tree.find_joint("joint2")];
  q[joint2.q_index] = 0.25;
  ASSERT_TRUE((*session)->push_joints(client::JointPositions{{"joint2"}, {0.25}, {}}).ok());
  const client::Report report = next(**session);
  check_against_kdl(arm, report, q, base);
  EXPECT_GT(report.counts.pairs_unmoved, 0u);  // links below joint2 did not move
  EXPECT_TRUE((*session)->close().ok());
  // A unary query: joints not named are at their reference positions, the base as given.
  std::vector<double> at = arm.robot.tree.neutral();
  const Joint& joint4 = arm.robot.tree.joints[arm.robot.tree.find_joint("joint4")];
  at[joint4.q_index] = -1.2;
  client::JointPositions joints{{"joint4"}, {-1.2}, to_input(some_base())};
  auto queried = client->query_joints(scene_id, joints);
  ASSERT_TRUE(queried.ok()) << queried.status().describe();
  EXPECT_EQ(check_against_kdl(arm, *queried, at, some_base()), int(arm.robot.pairs.size()));
}

// ∂d/∂q as the server reports it, against central differences of the distances it reports at
// q ± h·e_i (pairs of exact shapes — boxes, polytopes, capsule cores — separated by more than
// the step moves anything). Joints the report leaves out move neither object relative to the
// other: their differences are 0.
TEST(RobotWire, JointGradientEqualsCentralDifferencesOverTheWire) {
  const Arm arm;
  Server server;
  auto client = client::Client::connect(server.target());
  const std::string scene_id = create(*client, arm.scene);
  client::SessionOptions options;
  options.options.gradient = true;
  options.max_in_flight = 64;
  auto session = client->open_session(scene_id, options);
  ASSERT_TRUE(session.ok());
  auto exact = [&](const std::string& id) {
    for (const model::PieceInput& piece : arm.robot.objects[arm.object_of.at(id)].geometry.pieces)
      if (std::holds_alternative<Cylinder<double>>(piece.shape) ||
          std::holds_alternative<Ellipsoid<double>>(piece.shape) ||
          std::holds_alternative<Cone<double>>(piece.shape))
        return false;
    return true;
  };
  const KinematicTree& tree = arm.robot.tree;
  const double h = 1e-6;
  std::mt19937_64 rng(7);
  int checked = 0;
  double worst = 0;
  for (int sample = 0; sample < 6; ++sample) {
    const std::vector<double> q = random_q(tree, rng);
    client::JointPositions at_q = joint_positions(tree, q);
    at_q.base_pose = to_input(sample % 2 ? some_base() : Pose3d{});
    ASSERT_TRUE((*session)->push_joints(at_q).ok());
    const client::Report center = next(**session);
    ASSERT_TRUE(center.error.ok()) << center.error.describe();
    std::map<std::pair<std::string, std::string>, std::vector<double>> plus, minus;
    std::vector<std::string> names;
    for (const Joint& joint : tree.joints) {
      if (joint.nq() != 1) continue;
      names.push_back(joint.name);
      for (const double sign : {1.0, -1.0}) {
        client::JointPositions moved{{joint.name}, {q[joint.q_index] + sign * h}, {}};
        ASSERT_TRUE((*session)->push_joints(moved).ok());
        const client::Report report = next(**session);
        for (const client::PairDistance& p : report.pairs)
          (sign > 0 ? plus : minus)[{p.object_a, p.object_b}].push_back(p.distance);
        // Back to q for the next joint.
        client::JointPositions back{{joint.name}, {q[joint.q_index]}, {}};
        ASSERT_TRUE((*session)->push_joints(back).ok());
        next(**session);
      }
    }
    for (const client::PairDistance& pair : center.pairs) {
      if (pair.status != model::PairStatus::separated || pair.distance < 1e-3) continue;
      if (!exact(pair.object_a) || !exact(pair.object_b)) continue;
      ASSERT_TRUE(pair.has_gradient);
      std::map<std::string, double> reported;
      for (const client::JointDerivative& d : pair.joint_gradient) reported[d.joint] = d.value;
      const auto& p = plus.at({pair.object_a, pair.object_b});
      const auto& m = minus.at({pair.object_a, pair.object_b});
      double scale = 1;
      for (const auto& [name, value] : reported) scale = std::max(scale, std::abs(value));
      for (std::size_t i = 0; i < names.size(); ++i) {
        const double fd = (p[i] - m[i]) / (2 * h);
        const auto it = reported.find(names[i]);
        const double g = it == reported.end() ? 0.0 : it->second;
        const double error = std::abs(fd - g) / scale;
        worst = std::max(worst, error);
        EXPECT_LT(error, 1e-6) << pair.object_a << "–" << pair.object_b << " " << names[i]
                               << ": reported " << g << ", differences " << fd;
      }
      ++checked;
    }
  }
  EXPECT_GT(checked, 30);
  std::cout << checked << " pairs' joint gradients checked over the wire (worst relative error "
            << worst << ")\n";
}

// Bad joint updates are error reports naming the field; the stream goes on, and so does another
// client's stream on the same scene. Limits are reported, not enforced.
TEST(RobotWire, BadJointUpdatesAreRefusedAndTheStreamGoesOn) {
  const Arm arm;
  Server server;
  auto client = client::Client::connect(server.target());
  const std::string scene_id = create(*client, arm.scene);
  auto session = client->open_session(scene_id);
  auto other = client->open_session(scene_id);
  ASSERT_TRUE(session.ok() && other.ok());
  auto refused = [&](const client::JointPositions& joints, const std::string& field,
                     const std::string& says) {
    ASSERT_TRUE((*session)->push_joints(joints).ok());
    const client::Report report = next(**session);
    EXPECT_EQ(report.error.code, 3) << report.error.describe();  // INVALID_ARGUMENT
    EXPECT_EQ(report.error_field, field) << report.error.describe();
    EXPECT_NE(report.error.message.find(says), std::string::npos) << report.error.describe();
    EXPECT_TRUE(report.pairs.empty());
  };
  refused({{"joint1", "elbow"}, {0.1, 0.2}, {}}, "joints.names[1]", "no joint 'elbow'");
  refused({{"joint1", "joint2"}, {0.1, std::nan("")}, {}}, "joints.positions[1]", "finite");
  refused({{"joint1", "joint2"}, {0.1}, {}}, "joints.positions", "need 2");
  refused({{"joint1"}, {0.1, 0.2}, {}}, "joints.positions", "take 1");
  refused({{"joint1", "joint1"}, {0.1, 0.2}, {}}, "joints.names[1]", "named twice");
  refused({{"hand_joint"}, {0.1}, {}}, "joints.names[0]", "fixed");
  // A carried object's pose: the robot moves it.
  const std::string carried = arm.robot.objects[arm.object_of.at("link3")].name;
  ASSERT_TRUE((*session)->push({client::ObjectPose(carried, Eigen::Isometry3d::Identity())}).ok());
  const client::Report pose_report = next(**session);
  EXPECT_EQ(pose_report.error.code, 3);
  EXPECT_EQ(pose_report.error_field, "poses[0].object_id");
  // The stream goes on, at the positions of its last accepted update; the other one too.
  std::mt19937_64 rng(1);
  const std::vector<double> q = random_q(arm.robot.tree, rng);
  ASSERT_TRUE((*session)->push_joints(joint_positions(arm.robot.tree, q)).ok());
  check_against_kdl(arm, next(**session), q, Pose3d{});
  ASSERT_TRUE((*other)->push_joints(joint_positions(arm.robot.tree, q)).ok());
  check_against_kdl(arm, next(**other), q, Pose3d{});
  // Limits: reported, not enforced (the distances are those at the positions given).
  std::vector<double> beyond = q;
  const Joint& joint1 = arm.robot.tree.joints[arm.robot.tree.find_joint("joint1")];
  ASSERT_TRUE(joint1.limited);
  beyond[joint1.q_index] = joint1.upper + 0.3;
  ASSERT_TRUE((*session)
                  ->push_joints(client::JointPositions{{"joint1"}, {beyond[joint1.q_index]}, {}})
                  .ok());
  const client::Report report = next(**session);
  check_against_kdl(arm, report, beyond, Pose3d{});
  ASSERT_EQ(report.joint_limit_violations.size(), 1u);
  EXPECT_EQ(report.joint_limit_violations[0].joint, "joint1");
  EXPECT_DOUBLE_EQ(report.joint_limit_violations[0].position, joint1.upper + 0.3);
  EXPECT_DOUBLE_EQ(report.joint_limit_violations[0].upper, joint1.upper);
  // Joint positions on a scene without a robot: FAILED_PRECONDITION naming "joints".
  formats::SceneFile plain = arm.scene;
  plain.scene.robot = {};
  plain.scene.requested_id = "plain";
  const std::string plain_id = create(*client, plain);
  auto plain_session = client->open_session(plain_id);
  ASSERT_TRUE(plain_session.ok());
  ASSERT_TRUE((*plain_session)->push_joints(client::JointPositions{{"joint1"}, {0.1}, {}}).ok());
  const client::Report no_robot = next(**plain_session);
  EXPECT_EQ(no_robot.error.code, 9) << no_robot.error.describe();
  EXPECT_EQ(no_robot.error_field, "joints");
}

// MuJoCo's humanoid preloaded by nearpointd --scene (the server imports the MJCF itself, a free
// root joint and hinges): reported distances against MuJoCo's kinematics and its collision
// pipeline (capsules and spheres, margin large enough to report every pair).
TEST(RobotWire, HumanoidFromNearpointdSceneEqualsMujoco) {
  const fs::path file = kMujocoModels / "humanoid" / "humanoid.xml";
  const RobotImport imported = load_mjcf(file);
  ASSERT_TRUE(imported.ok()) << imported.error;
  const Robot& robot = imported.robot;
  Server server({"--scene", file.string()});
  auto client = client::Client::connect(server.target());
  const std::string scene_id = to_robot_scene(robot).scene.requested_id;
  auto session = client->open_session(scene_id);
  ASSERT_TRUE(session.ok());

  char error[1000] = "";
  mjModel* m = mj_loadXML(file.c_str(), nullptr, error, sizeof error);
  ASSERT_NE(m, nullptr) << error;
  m->nconmax = 20000;  // a margin of 10 m makes every selected pair a contact
  mjData* d = mj_makeData(m);
  const double margin = 10;
  for (int g = 0; g < m->ngeom; ++g) m->geom_margin[g] = margin;
  std::map<std::string, int> geom_of;
  for (int g = 0; g < m->ngeom; ++g) {
    const char* name = mj_id2name(m, mjOBJ_GEOM, g);
    const int body = m->geom_bodyid[g];
    const char* body_name = mj_id2name(m, mjOBJ_BODY, body);
    geom_of[name != nullptr && *name
                ? std::string(name)
                : std::string(body_name != nullptr && *body_name ? body_name
                                                                 : "body" + std::to_string(body)) +
                      "/geom" + std::to_string(g - m->body_geomadr[body])] = g;
  }
  std::mt19937_64 rng(22);
  std::uniform_real_distribution<double> unit(-1, 1);
  int compared = 0;
  double worst = 0;
  for (int sample = 0; sample < 20; ++sample) {
    std::vector<double> q = random_q(robot.tree, rng);
    for (const Joint& joint : robot.tree.joints)
      if (joint.type == JointType::free) {
        for (int k = 0; k < 3; ++k)
          q[joint.q_index + k] =
              robot.tree.links[joint.link].offset.translation[k] + 0.1 * unit(rng);
        Eigen::Vector4d quat(unit(rng), unit(rng), unit(rng), unit(rng));
        quat.normalize();
        for (int k = 0; k < 4; ++k) q[joint.q_index + 3 + k] = quat[k];
      }
    ASSERT_TRUE((*session)->push_joints(joint_positions(robot.tree, q)).ok());
    const client::Report report = next(**session);
    ASSERT_TRUE(report.error.ok()) << report.error.describe();
    for (int i = 0; i < m->nq; ++i) d->qpos[i] = q[i];
    mj_fwdPosition(m, d);
    std::map<std::pair<int, int>, double> theirs;
    for (int c = 0; c < d->ncon; ++c) {
      const auto key = std::minmax(d->contact[c].geom1, d->contact[c].geom2);
      auto [it, inserted] = theirs.emplace(key, d->contact[c].dist);
      if (!inserted) it->second = std::min(it->second, d->contact[c].dist);
    }
    for (const client::PairDistance& pair : report.pairs) {
      const int ga = geom_of.at(pair.object_a);
      const int gb = geom_of.at(pair.object_b);
      auto capsule_or_sphere = [&](int g) {
        return m->geom_type[g] == mjGEOM_CAPSULE || m->geom_type[g] == mjGEOM_SPHERE;
      };
      if (!capsule_or_sphere(ga) || !capsule_or_sphere(gb)) continue;
      const auto it = theirs.find(std::minmax(ga, gb));
      ASSERT_NE(it, theirs.end()) << pair.object_a << "–" << pair.object_b;
      if (it->second <= 0 || pair.status != model::PairStatus::separated) continue;
      worst = std::max(worst, std::abs(pair.distance - it->second));
      ++compared;
    }
  }
  mj_deleteData(d);
  mj_deleteModel(m);
  EXPECT_GT(compared, 200);
  EXPECT_LT(worst, 1e-9);
  std::cout << compared << " humanoid pairs against MuJoCo, largest difference " << worst << "\n";
}

// The CLI: `nearpoint scene create arm7.urdf`, then `nearpoint stream arm7 --joints FILE
// --gradient --json`; each printed report against KDL and the engine, gradients present.
TEST(RobotWire, CliStreamsAJointTrajectory) {
  const Arm arm;
  Server server;
  ChildProcess create_cli({NEARPOINT_PATH, "scene", "create", (kExamples / "arm7.urdf").string(),
                           "--target", server.target()});
  ASSERT_EQ(create_cli.wait_exit(std::chrono::seconds(60)), 0) << create_cli.stderr_text();
  const std::vector<std::string> created = create_cli.stdout_lines();
  ASSERT_FALSE(created.empty());
  EXPECT_EQ(created[0].rfind("arm7: ", 0), 0u) << created[0];

  const std::string trajectory = temp_path("joints.jsonl");
  std::vector<std::vector<double>> steps;
  {
    std::ofstream out(trajectory);
    std::mt19937_64 rng(5);
    for (int t = 0; t < 10; ++t) {
      steps.push_back(random_q(arm.robot.tree, rng));
      nlohmann::json line;
      line["t"] = 0.1 * t;
      for (const Joint& joint : arm.robot.tree.joints)
        if (joint.nq() == 1) line["joints"][joint.name] = steps.back()[joint.q_index];
      out << line.dump() << "\n";
    }
  }
  ChildProcess stream_cli({NEARPOINT_PATH, "stream", "arm7", "--joints", trajectory, "--gradient",
                           "--json", "--target", server.target()});
  ASSERT_EQ(stream_cli.wait_exit(std::chrono::seconds(60)), 0) << stream_cli.stderr_text();
  std::size_t index = 0;
  int with_gradient = 0;
  for (const std::string& text : stream_cli.stdout_lines()) {
    if (text.empty()) continue;
    const nlohmann::json report = nlohmann::json::parse(text);
    ASSERT_EQ(report.at("status"), "ok") << text;
    ASSERT_LT(index, steps.size());
    EXPECT_NEAR(report.at("t").get<double>(), 0.1 * double(index), 1e-12);
    const std::vector<Pose3d> poses = arm.kdl_poses(steps[index], Pose3d{});
    for (const nlohmann::json& pair : report.at("pairs")) {
      const CompoundResult<double> expected =
          arm.expected(poses, pair.at("object_a"), pair.at("object_b"));
      if (expected.nearest.status != Status::separated) continue;
      EXPECT_NEAR(pair.at("distance").get<double>(), expected.nearest.distance, 1e-9) << text;
      with_gradient += pair.contains("joint_gradient");
    }
    ++index;
  }
  EXPECT_EQ(index, steps.size()) << stream_cli.stderr_text();
  EXPECT_GT(with_gradient, 50);
  fs::remove(trajectory);
}

// A scene file naming a robot (examples/robots/arm7_cell.json: the arm plus a crate and a post)
// created by the CLI: the robot's pairs (SRDF and adjacency applied), the file's objects with
// every link, less the file's exclusion; the robot's pairs answer as in the robot's own scene.
TEST(RobotWire, SceneFileWithARobotAddsItsObjects) {
  const Arm arm;
  Server server;
  ChildProcess create_cli({NEARPOINT_PATH, "scene", "create",
                           (kExamples / "arm7_cell.json").string(), "--json", "--target",
                           server.target()});
  ASSERT_EQ(create_cli.wait_exit(std::chrono::seconds(60)), 0) << create_cli.stderr_text();
  const std::vector<std::string> lines = create_cli.stdout_lines();
  ASSERT_FALSE(lines.empty());
  const nlohmann::json created = nlohmann::json::parse(lines[0]);
  EXPECT_EQ(created.at("scene_id"), "arm7-cell");
  const std::size_t links = arm.robot.objects.size();
  EXPECT_EQ(created.at("pair_count").get<std::size_t>(), arm.robot.pairs.size() + 2 * links);

  auto client = client::Client::connect(server.target());
  ASSERT_EQ(create(*client, arm.scene), "arm7");
  auto cell = client->open_session("arm7-cell");
  auto alone = client->open_session("arm7");
  ASSERT_TRUE(cell.ok() && alone.ok());
  std::mt19937_64 rng(3);
  int compared = 0;
  for (int step = 0; step < 10; ++step) {
    const client::JointPositions joints =
        joint_positions(arm.robot.tree, random_q(arm.robot.tree, rng));
    ASSERT_TRUE((*cell)->push_joints(joints).ok());
    ASSERT_TRUE((*alone)->push_joints(joints).ok());
    const client::Report in_cell = next(**cell);
    const client::Report by_itself = next(**alone);
    ASSERT_TRUE(in_cell.error.ok()) << in_cell.error.describe();
    std::map<std::pair<std::string, std::string>, double> robot_pairs;
    for (const client::PairDistance& p : by_itself.pairs)
      robot_pairs[{p.object_a, p.object_b}] = p.distance;
    for (const client::PairDistance& p : in_cell.pairs) {
      const auto it = robot_pairs.find({p.object_a, p.object_b});
      // The cell's cutoff (1 m) reports farther pairs as beyond it, with a bound only.
      if (it == robot_pairs.end() || p.status != model::PairStatus::separated) continue;
      EXPECT_EQ(p.distance, it->second) << p.object_a << "–" << p.object_b;
      ++compared;
    }
  }
  EXPECT_GT(compared, 5 * int(arm.robot.pairs.size()));
}

}  // namespace
