// SPDX-License-Identifier: Apache-2.0
// The robot importers and kinematics (robots/) against references we did not write:
//   - URDF forward kinematics and Jacobians against KDL, read by kdl_parser from the same file;
//   - MJCF forward kinematics against MuJoCo's mj_kinematics on MuJoCo's own samples
//     (humanoid, 22 humanoids, humanoid with 100 objects), at random joint positions;
//   - MJCF pair selection and capsule/sphere distances against MuJoCo's collision pipeline;
//   - joint-space gradients against central finite differences of the engine's distances and
//     against KDL's Jacobian;
//   - hostile descriptions (malformed XML, missing meshes, cycles, NaN) give messages, not crashes.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>

#include <kdl/chainjnttojacsolver.hpp>
#include <kdl/tree.hpp>
#include <kdl/treefksolverpos_recursive.hpp>
#include <kdl_parser/kdl_parser.hpp>

#include "nearpoint/client/mesh_loader.hpp"
#include "nearpoint/compound.hpp"
#include "nearpoint/robots/robot.hpp"

namespace {

namespace fs = std::filesystem;
using namespace nearpoint;
using namespace nearpoint::robots;

const fs::path kExamples = NEARPOINT_EXAMPLES_DIR;
const fs::path kMujocoModels = NEARPOINT_MUJOCO_MODELS_DIR;

using client::mesh_loader;

ImportOptions arm_options() {
  ImportOptions options;
  options.meshes = mesh_loader();
  return options;
}

Robot load_arm(const fs::path& srdf = {}) {
  RobotImport imported = load_urdf(kExamples / "arm7.urdf", arm_options(), srdf);
  EXPECT_TRUE(imported.ok()) << imported.error;
  return std::move(imported.robot);
}

// Random joint positions: one-dof joints within their limits (±π when unlimited), ball and
// free rotations as random quaternions deliberately not of unit length (both sides normalise).
std::vector<double> random_q(const KinematicTree& tree, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(-1, 1);
  std::vector<double> q = tree.neutral();
  for (const Joint& joint : tree.joints) {
    const int i = joint.q_index;
    switch (joint.type) {
      case JointType::fixed:
        break;
      case JointType::revolute:
      case JointType::continuous:
      case JointType::prismatic: {
        const double lo = joint.limited ? joint.lower : -M_PI;
        const double hi = joint.limited ? joint.upper : M_PI;
        q[i] = lo + (hi - lo) * (unit(rng) + 1) / 2;
        break;
      }
      case JointType::free:
        for (int k = 0; k < 3; ++k) q[i + k] = 2 * unit(rng);
        [[fallthrough]];
      case JointType::ball: {
        const int r = joint.type == JointType::free ? i + 3 : i;
        Eigen::Vector4d quat(unit(rng), unit(rng), unit(rng), unit(rng));
        quat = quat.normalized() * 1.3;
        for (int k = 0; k < 4; ++k) q[r + k] = quat[k];
        break;
      }
    }
  }
  return q;
}

Pose3d from_kdl(const KDL::Frame& frame) {
  Pose3d pose;
  for (int r = 0; r < 3; ++r) {
    pose.translation[r] = frame.p[r];
    for (int c = 0; c < 3; ++c) pose.rotation(r, c) = frame.M(r, c);
  }
  return pose;
}

// ---------------------------------------------------------------------------------------------
// URDF

TEST(Urdf, ArmImportsItsLinksShapesAndPairs) {
  const Robot robot = load_arm();
  EXPECT_EQ(robot.name, "arm7");
  EXPECT_EQ(robot.tree.nq(), 8);  // 7 revolute/continuous + the finger's prismatic joint
  // One object per link with collision elements (world has none).
  EXPECT_EQ(robot.objects.size(), robot.tree.links.size() - 1);
  const auto object = [&](const std::string& name) {
    for (std::size_t i = 0; i < robot.objects.size(); ++i)
      if (robot.objects[i].name == name) return static_cast<int>(i);
    ADD_FAILURE() << "no object " << name;
    return -1;
  };
  EXPECT_EQ(robot.objects[object("table")].geometry.pieces.size(), 5u);  // top and four legs
  const auto& hand = robot.objects[object("hand")].geometry.pieces;
  ASSERT_EQ(hand.size(), 1u);
  const auto* hull = std::get_if<model::PolytopeInput>(&hand[0].shape);
  ASSERT_NE(hull, nullptr);
  EXPECT_EQ(hull->vertices.size(), 16u);
  // The mesh's scale (1.2, 1.0, 1.1) is applied per axis: the top ring at z = 0.07·1.1.
  double top = 0;
  for (const auto& v : hull->vertices) top = std::max(top, v.z());
  EXPECT_NEAR(top, 0.077, 1e-6);
  const std::set<std::pair<int, int>> pairs(robot.pairs.begin(), robot.pairs.end());
  auto has = [&](const char* a, const char* b) {
    return pairs.count(std::minmax(object(a), object(b))) > 0;
  };
  // Adjacent links excluded (table–base, link7–hand, hand–finger), others kept.
  EXPECT_FALSE(has("table", "base_link"));
  EXPECT_FALSE(has("link7", "hand"));
  EXPECT_FALSE(has("hand", "finger"));
  EXPECT_FALSE(has("table", "fixture"));
  EXPECT_TRUE(has("link5", "link7"));
  EXPECT_TRUE(has("finger", "table"));
  EXPECT_TRUE(has("table", "link1"));
  const std::size_t n = robot.objects.size();
  EXPECT_EQ(robot.pairs.size(), n * (n - 1) / 2 - 11);  // 11 parent–child link pairs

  const Robot with_srdf = load_arm(kExamples / "arm7.srdf");
  EXPECT_EQ(with_srdf.pairs.size(), robot.pairs.size() - 3);  // table–base was already out
  const std::set<std::pair<int, int>> srdf_pairs(with_srdf.pairs.begin(), with_srdf.pairs.end());
  EXPECT_EQ(srdf_pairs.count(std::minmax(object("link5"), object("link7"))), 0u);
  EXPECT_EQ(srdf_pairs.count(std::minmax(object("table"), object("link1"))), 0u);
}

TEST(Urdf, PackageUrisResolveAgainstTheSearchPath) {
  const fs::path dir =
      fs::temp_directory_path() / ("nearpoint-robots-pkg-" + std::to_string(getpid()));
  fs::create_directories(dir / "share" / "arm_description" / "meshes");
  fs::copy_file(kExamples / "meshes" / "gripper_housing.obj",
                dir / "share" / "arm_description" / "meshes" / "gripper_housing.obj",
                fs::copy_options::overwrite_existing);
  std::ifstream in(kExamples / "arm7.urdf");
  std::string xml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string from = "\"meshes/gripper_housing.obj";
  xml.replace(xml.find(from), from.size(),
              "\"package://arm_description/meshes/gripper_housing.obj");
  ImportOptions options = arm_options();
  RobotImport missing = parse_urdf(xml, "arm.urdf", dir, options);
  EXPECT_FALSE(missing.ok());
  EXPECT_NE(missing.error.find("package://arm_description"), std::string::npos) << missing.error;
  options.search_path = {dir / "nowhere", dir / "share"};
  RobotImport found = parse_urdf(xml, "arm.urdf", dir, options);
  EXPECT_TRUE(found.ok()) << found.error;
  fs::remove_all(dir);
}

TEST(Urdf, ForwardKinematicsEqualsKdl) {
  const Robot robot = load_arm();
  KDL::Tree tree;
  ASSERT_TRUE(kdl_parser::treeFromFile((kExamples / "arm7.urdf").string(), tree));
  ASSERT_EQ(tree.getNrOfJoints(), static_cast<unsigned>(robot.tree.nq()));
  KDL::TreeFkSolverPos_recursive fk(tree);
  std::mt19937_64 rng(32);
  double worst = 0;
  for (int sample = 0; sample < 200; ++sample) {
    const std::vector<double> q = random_q(robot.tree, rng);
    KinematicState state;
    ASSERT_EQ(robot.tree.forward(q, state), "");
    KDL::JntArray kq(tree.getNrOfJoints());
    for (const auto& [name, element] : tree.getSegments()) {
      const KDL::Joint& joint = GetTreeElementSegment(element).getJoint();
      if (joint.getType() == KDL::Joint::None) continue;
      const int j = robot.tree.find_joint(joint.getName());
      ASSERT_GE(j, 0) << joint.getName();
      kq(GetTreeElementQNr(element)) = q[robot.tree.joints[j].q_index];
    }
    for (std::size_t l = 0; l < robot.tree.links.size(); ++l) {
      KDL::Frame frame;
      ASSERT_GE(fk.JntToCart(kq, frame, robot.tree.links[l].name), 0);
      const Pose3d expected = from_kdl(frame);
      worst = std::max(worst, (expected.translation - state.links[l].translation).norm());
      worst = std::max(worst, (expected.rotation - state.links[l].rotation).norm());
    }
  }
  EXPECT_LT(worst, 1e-13);
}

// The 6×nv Jacobian of the finger's frame against KDL's (reference point: the frame's origin,
// expressed in the base frame — the layout of the engine's pose gradient).
TEST(Urdf, JacobianEqualsKdl) {
  const Robot robot = load_arm();
  KDL::Tree tree;
  ASSERT_TRUE(kdl_parser::treeFromFile((kExamples / "arm7.urdf").string(), tree));
  KDL::Chain chain;
  ASSERT_TRUE(tree.getChain("world", "finger", chain));
  KDL::ChainJntToJacSolver solver(chain);
  std::vector<int> chain_joints;  // my joint index of each movable chain joint, in chain order
  for (const KDL::Segment& segment : chain.segments)
    if (segment.getJoint().getType() != KDL::Joint::None)
      chain_joints.push_back(robot.tree.find_joint(segment.getJoint().getName()));
  ASSERT_EQ(chain_joints.size(), chain.getNrOfJoints());
  const int finger = robot.tree.find_link("finger");
  std::mt19937_64 rng(7);
  double worst = 0;
  for (int sample = 0; sample < 100; ++sample) {
    const std::vector<double> q = random_q(robot.tree, rng);
    KinematicState state;
    ASSERT_EQ(robot.tree.forward(q, state), "");
    KDL::JntArray kq(chain.getNrOfJoints());
    for (std::size_t k = 0; k < chain_joints.size(); ++k)
      kq(k) = q[robot.tree.joints[chain_joints[k]].q_index];
    KDL::Jacobian kjac(chain.getNrOfJoints());
    ASSERT_GE(solver.JntToJac(kq, kjac), 0);
    const auto jac = robot.tree.jacobian(state, finger, state.links[finger].translation);
    for (std::size_t k = 0; k < chain_joints.size(); ++k)
      for (int r = 0; r < 6; ++r)
        worst = std::max(worst,
                         std::abs(kjac(r, k) - jac(r, robot.tree.joints[chain_joints[k]].v_index)));
  }
  EXPECT_LT(worst, 1e-13);
}

// Distances of robot pairs, in-process as the server computes them.
struct Evaluator {
  const Robot& robot;
  std::vector<Compound<double>> compounds;
  explicit Evaluator(const Robot& r) : robot(r) {
    compounds.resize(robot.objects.size());
    for (std::size_t i = 0; i < robot.objects.size(); ++i)
      EXPECT_EQ(make_compound(robot.objects[i].geometry, compounds[i]), "");
  }
  CompoundResult<double> evaluate(const KinematicState& state, int a, int b) const {
    DistanceOptions<double> options;
    options.gradient = true;
    options.near_points = true;
    return distance(compounds[a], robot.object_pose(state, a), compounds[b],
                    robot.object_pose(state, b), options);
  }
  double at(const std::vector<double>& q, int a, int b) const {
    KinematicState state;
    EXPECT_EQ(robot.tree.forward(q, state), "");
    return evaluate(state, a, b).nearest.distance;
  }
};

// Whether every piece of an object is a shape on which GJK ends exactly (points, segments, boxes,
// polytopes): their distances are exact to rounding, so that central differences of the
// distance itself resolve the gradient. Curved cores (cylinders, ellipsoids) converge to the
// engine's tolerance, ~1e-10 m, which a step of 1e-6 cannot resolve to 1e-6.
bool exact_shapes(const RobotObject& object) {
  for (const model::PieceInput& piece : object.geometry.pieces)
    if (std::holds_alternative<Cylinder<double>>(piece.shape) ||
        std::holds_alternative<Ellipsoid<double>>(piece.shape) ||
        std::holds_alternative<Cone<double>>(piece.shape))
      return false;
  return true;
}

// ∂d/∂q from the engine's pose gradient and the kinematics, against central differences (step
// 1e-6): of the engine's own distances for pairs of exact shapes, and for every pair of the
// first-order distance n·(x_B(q) − x_A(q)) with the near points carried by their links (the
// envelope theorem: its derivative at q is ∂d/∂q); and against Jᵀg with KDL's Jacobian for the
// pairs of the finger with the static objects.
TEST(Urdf, JointGradientEqualsFiniteDifferencesAndKdl) {
  const Robot robot = load_arm();
  const Evaluator evaluator(robot);
  KDL::Tree tree;
  ASSERT_TRUE(kdl_parser::treeFromFile((kExamples / "arm7.urdf").string(), tree));
  KDL::Chain chain;
  ASSERT_TRUE(tree.getChain("world", "finger", chain));
  KDL::ChainJntToJacSolver solver(chain);
  const int finger = robot.tree.find_link("finger");
  std::mt19937_64 rng(99);
  const double h = 1e-6;
  int checked = 0;
  int exact = 0;
  int against_kdl = 0;
  double worst = 0;
  for (int sample = 0; sample < 40; ++sample) {
    const std::vector<double> q = random_q(robot.tree, rng);
    KinematicState state;
    ASSERT_EQ(robot.tree.forward(q, state), "");
    for (const auto& [pair_a, pair_b] : robot.pairs) {
      // Copies: clang before 16 cannot capture structured bindings in a lambda (P1091).
      const auto a = pair_a;
      const auto b = pair_b;
      const CompoundResult<double> r = evaluator.evaluate(state, a, b);
      // Smooth points only: separated by more than the step moves anything.
      if (r.nearest.status != Status::separated || r.nearest.distance < 1e-3) continue;
      const Eigen::VectorXd g =
          robot.joint_gradient(state, a, r.nearest.gradient_a, b, r.nearest.gradient_b);
      const double scale = std::max(1.0, g.lpNorm<Eigen::Infinity>());
      const Vec3d local_a = robot.object_pose(state, a).inverse().apply(r.nearest.point_a);
      const Vec3d local_b = robot.object_pose(state, b).inverse().apply(r.nearest.point_b);
      const Vec3d normal = r.nearest.normal;
      auto first_order = [&](const std::vector<double>& at) {
        KinematicState moved;
        EXPECT_EQ(robot.tree.forward(at, moved), "");
        return normal.dot(robot.object_pose(moved, b).apply(local_b) -
                          robot.object_pose(moved, a).apply(local_a));
      };
      const bool exact_pair = exact_shapes(robot.objects[a]) && exact_shapes(robot.objects[b]);
      for (int i = 0; i < robot.tree.nv(); ++i) {
        std::vector<double> plus = q;
        std::vector<double> minus = q;
        plus[i] += h;
        minus[i] -= h;
        const double linear = (first_order(plus) - first_order(minus)) / (2 * h);
        EXPECT_LT(std::abs(linear - g[i]) / scale, 1e-6)
            << robot.objects[a].name << "–" << robot.objects[b].name << " joint " << i << ": "
            << g[i] << " vs " << linear;
        if (!exact_pair) continue;
        const double fd = (evaluator.at(plus, a, b) - evaluator.at(minus, a, b)) / (2 * h);
        const double error = std::abs(fd - g[i]) / scale;
        worst = std::max(worst, error);
        EXPECT_LT(error, 1e-6) << robot.objects[a].name << "–" << robot.objects[b].name << " joint "
                               << i << ": " << g[i] << " vs " << fd;
      }
      exact += exact_pair;
      ++checked;
      // Against KDL: the finger with a static object (the table, the fixture).
      const bool a_finger = robot.objects[a].link == finger;
      const bool b_finger = robot.objects[b].link == finger;
      const int other = a_finger ? b : a;
      const std::string& other_link = robot.tree.links[robot.objects[other].link].name;
      if ((a_finger || b_finger) && (other_link == "table" || other_link == "fixture")) {
        KDL::JntArray kq(chain.getNrOfJoints());
        std::vector<int> v_of;
        int k = 0;
        for (const KDL::Segment& segment : chain.segments)
          if (segment.getJoint().getType() != KDL::Joint::None) {
            const Joint& joint =
                robot.tree.joints[robot.tree.find_joint(segment.getJoint().getName())];
            kq(k++) = q[joint.q_index];
            v_of.push_back(joint.v_index);
          }
        KDL::Jacobian kjac(chain.getNrOfJoints());
        ASSERT_GE(solver.JntToJac(kq, kjac), 0);
        const Vec6d pose_gradient = a_finger ? r.nearest.gradient_a : r.nearest.gradient_b;
        for (int c = 0; c < static_cast<int>(v_of.size()); ++c) {
          double expected = 0;
          for (int row = 0; row < 6; ++row) expected += kjac(row, c) * pose_gradient[row];
          EXPECT_NEAR(g[v_of[c]], expected, 1e-12);
        }
        ++against_kdl;
      }
    }
  }
  EXPECT_GT(checked, 500);
  EXPECT_GT(exact, 100);
  EXPECT_GT(against_kdl, 20);
  std::cout << checked << " pairs checked, " << exact << " against the distance itself (worst "
            << "relative error " << worst << ")\n";
}

TEST(Urdf, LimitsAreReportedNotEnforced) {
  const Robot robot = load_arm();
  std::vector<double> q = robot.tree.neutral();
  const Joint& joint4 = robot.tree.joints[robot.tree.find_joint("joint4")];
  q[joint4.q_index] = 1.0;  // above its upper limit 0.1
  KinematicState state;
  EXPECT_EQ(robot.tree.forward(q, state), "");
  const auto violations = robot.tree.limit_violations(q);
  ASSERT_EQ(violations.size(), 1u);
  EXPECT_NE(violations[0].find("joint4"), std::string::npos);
}

TEST(Urdf, SceneCarriesObjectsPosesAndPairs) {
  const Robot robot = load_arm(kExamples / "arm7.srdf");
  KinematicState state;
  ASSERT_EQ(robot.tree.forward(robot.tree.neutral(), state), "");
  const formats::SceneFile scene = robot.to_scene(state);
  ASSERT_EQ(scene.scene.objects.size(), robot.objects.size());
  const auto& selection = scene.scene.pair_selection;
  const std::size_t n = robot.objects.size();
  if (selection.mode == model::PairSelectionInput::Mode::excluded_pairs)
    EXPECT_EQ(selection.pairs.size(), n * (n - 1) / 2 - robot.pairs.size());
  else
    EXPECT_EQ(selection.pairs.size(), robot.pairs.size());
  const auto& hand = scene.scene.objects[3];
  EXPECT_TRUE(hand.pose.translation.allFinite());
}

// ---------------------------------------------------------------------------------------------
// MJCF against MuJoCo

struct MujocoModel {
  mjModel* m = nullptr;
  mjData* d = nullptr;
  explicit MujocoModel(const fs::path& file, int nconmax = 0) {
    char error[1000] = "";
    m = mj_loadXML(file.c_str(), nullptr, error, sizeof error);
    EXPECT_NE(m, nullptr) << error;
    if (m != nullptr && nconmax > 0) m->nconmax = nconmax;
    if (m != nullptr) d = mj_makeData(m);
  }
  ~MujocoModel() {
    if (d != nullptr) mj_deleteData(d);
    if (m != nullptr) mj_deleteModel(m);
  }
  std::string geom_name(int g) const {
    if (const char* name = mj_id2name(m, mjOBJ_GEOM, g); name != nullptr && *name) return name;
    const int body = m->geom_bodyid[g];
    const char* body_name = mj_id2name(m, mjOBJ_BODY, body);
    return std::string(body_name != nullptr && *body_name ? body_name
                                                          : "body" + std::to_string(body)) +
           "/geom" + std::to_string(g - m->body_geomadr[body]);
  }
};

std::map<std::string, int> object_index(const Robot& robot) {
  std::map<std::string, int> out;
  for (std::size_t i = 0; i < robot.objects.size(); ++i) out[robot.objects[i].name] = i;
  return out;
}

void check_mujoco_kinematics(const fs::path& file, int samples) {
  const RobotImport imported = load_mjcf(file);
  ASSERT_TRUE(imported.ok()) << imported.error;
  const Robot& robot = imported.robot;
  MujocoModel mj(file);
  ASSERT_NE(mj.d, nullptr);
  ASSERT_EQ(robot.tree.links.size() + 1, static_cast<std::size_t>(mj.m->nbody));
  ASSERT_EQ(robot.tree.joints.size(), static_cast<std::size_t>(mj.m->njnt));
  ASSERT_EQ(robot.tree.nq(), mj.m->nq);
  ASSERT_EQ(robot.tree.nv(), mj.m->nv);
  ASSERT_EQ(robot.objects.size(), static_cast<std::size_t>(mj.m->ngeom));
  for (int j = 0; j < mj.m->njnt; ++j) {
    EXPECT_EQ(robot.tree.joints[j].q_index, mj.m->jnt_qposadr[j]);
    if (const char* name = mj_id2name(mj.m, mjOBJ_JOINT, j); name != nullptr && *name) {
      EXPECT_EQ(robot.tree.joints[j].name, name);
    }
  }
  const auto objects = object_index(robot);
  std::vector<int> object_of_geom(mj.m->ngeom);
  for (int g = 0; g < mj.m->ngeom; ++g) {
    const auto it = objects.find(mj.geom_name(g));
    ASSERT_NE(it, objects.end()) << mj.geom_name(g);
    object_of_geom[g] = it->second;
  }
  std::mt19937_64 rng(2222);
  double worst = 0;
  for (int sample = 0; sample < samples; ++sample) {
    const std::vector<double> q = random_q(robot.tree, rng);
    for (int i = 0; i < mj.m->nq; ++i) mj.d->qpos[i] = q[i];
    mj_kinematics(mj.m, mj.d);
    KinematicState state;
    ASSERT_EQ(robot.tree.forward(q, state), "");
    for (int b = 1; b < mj.m->nbody; ++b) {
      const Pose3d& pose = state.links[b - 1];
      const Eigen::Map<const Eigen::Vector3d> xpos(mj.d->xpos + 3 * b);
      const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> xmat(mj.d->xmat + 9 * b);
      worst = std::max(worst, (pose.translation - xpos).norm());
      worst = std::max(worst, (pose.rotation - xmat).norm());
    }
    for (int g = 0; g < mj.m->ngeom; ++g) {
      const Pose3d pose = robot.object_pose(state, object_of_geom[g]);
      const Eigen::Map<const Eigen::Vector3d> xpos(mj.d->geom_xpos + 3 * g);
      const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> xmat(mj.d->geom_xmat +
                                                                                9 * g);
      worst = std::max(worst, (pose.translation - xpos).norm());
      worst = std::max(worst, (pose.rotation - xmat).norm());
    }
  }
  EXPECT_LT(worst, 1e-12) << file;
}

TEST(Mjcf, HumanoidKinematicsEqualMujoco) {
  check_mujoco_kinematics(kMujocoModels / "humanoid" / "humanoid.xml", 200);
}
TEST(Mjcf, TwentyTwoHumanoidsKinematicsEqualMujoco) {
  check_mujoco_kinematics(kMujocoModels / "humanoid" / "22_humanoids.xml", 20);
}
TEST(Mjcf, Humanoid100KinematicsEqualMujoco) {
  check_mujoco_kinematics(kMujocoModels / "humanoid100" / "humanoid100.xml", 20);
}

bool capsule_or_sphere(const mjModel* m, int g) {
  return m->geom_type[g] == mjGEOM_CAPSULE || m->geom_type[g] == mjGEOM_SPHERE;
}

// MuJoCo's collision pipeline with every geom's margin at `margin` reports a contact for each
// pair it selects (contype/conaffinity, welds, parents, excludes) whose distance is below the
// margin, with dist = the pair's distance (negative when penetrating) for capsules and spheres.
void check_mujoco_distances(const fs::path& file, double margin, int samples, int nconmax,
                            bool every_pair, int at_least = 100) {
  const RobotImport imported = load_mjcf(file);
  ASSERT_TRUE(imported.ok()) << imported.error;
  const Robot& robot = imported.robot;
  const Evaluator evaluator(robot);
  MujocoModel mj(file, nconmax);
  ASSERT_NE(mj.d, nullptr);
  for (int g = 0; g < mj.m->ngeom; ++g) mj.m->geom_margin[g] = margin;
  for (int p = 0; p < mj.m->npair; ++p) mj.m->pair_margin[p] = margin;  // <pair>s have their own
  const auto objects = object_index(robot);
  std::vector<int> object_of_geom(mj.m->ngeom);
  std::vector<int> geom_of_object(robot.objects.size());
  for (int g = 0; g < mj.m->ngeom; ++g) {
    object_of_geom[g] = objects.at(mj.geom_name(g));
    geom_of_object[object_of_geom[g]] = g;
  }
  const std::set<std::pair<int, int>> ours(robot.pairs.begin(), robot.pairs.end());
  std::mt19937_64 rng(5);
  double worst = 0;
  int compared = 0;
  for (int sample = 0; sample < samples; ++sample) {
    std::vector<double> q = random_q(robot.tree, rng);
    // Keep free bodies near their places so the scene stays a scene.
    for (const Joint& joint : robot.tree.joints)
      if (joint.type == JointType::free)
        for (int k = 0; k < 3; ++k)
          q[joint.q_index + k] =
              robot.tree.links[joint.link].offset.translation[k] + 0.1 * q[joint.q_index + k];
    for (int i = 0; i < mj.m->nq; ++i) mj.d->qpos[i] = q[i];
    mj_fwdPosition(mj.m, mj.d);
    ASSERT_LT(mj.d->ncon, mj.m->nconmax) << "contact buffer full";
    std::map<std::pair<int, int>, double> theirs;
    for (int c = 0; c < mj.d->ncon; ++c) {
      const mjContact& contact = mj.d->contact[c];
      const auto key = std::minmax(object_of_geom[contact.geom1], object_of_geom[contact.geom2]);
      auto [it, inserted] = theirs.emplace(key, contact.dist);
      if (!inserted) it->second = std::min(it->second, contact.dist);
    }
    KinematicState state;
    ASSERT_EQ(robot.tree.forward(q, state), "");
    // Every pair MuJoCo reports is one of ours.
    for (const auto& [pair, dist] : theirs)
      EXPECT_TRUE(ours.count(pair))
          << robot.objects[pair.first].name << "–" << robot.objects[pair.second].name;
    for (const auto& [pair_a, pair_b] : robot.pairs) {
      // Copies: clang before 16 cannot capture structured bindings in a lambda (P1091).
      const auto a = pair_a;
      const auto b = pair_b;
      const int ga = geom_of_object[a];
      const int gb = geom_of_object[b];
      const auto it = theirs.find({a, b});
      if (every_pair) {
        EXPECT_NE(it, theirs.end()) << robot.objects[a].name << "–" << robot.objects[b].name;
      }
      if (!capsule_or_sphere(mj.m, ga) || !capsule_or_sphere(mj.m, gb)) continue;
      const CompoundResult<double> r = evaluator.evaluate(state, a, b);
      if (it == theirs.end()) {
        // Not reported: farther than the margin.
        EXPECT_GT(r.nearest.distance, margin - 1e-9);
        continue;
      }
      if (it->second < 0) {
        EXPECT_EQ(r.nearest.status, Status::intersecting);
        continue;
      }
      ASSERT_EQ(r.nearest.status, Status::separated);
      worst = std::max(worst, std::abs(r.nearest.distance - it->second));
      ++compared;
    }
  }
  EXPECT_GE(compared, at_least);
  EXPECT_LT(worst, 1e-9) << file;
  std::cout << compared << " capsule/sphere distances compared, largest difference " << worst
            << " m\n";
}

TEST(Mjcf, HumanoidPairsAndDistancesEqualMujoco) {
  check_mujoco_distances(kMujocoModels / "humanoid" / "humanoid.xml", 10.0, 50, 20000, true);
}
TEST(Mjcf, TwentyTwoHumanoidsPairsAndDistancesEqualMujoco) {
  check_mujoco_distances(kMujocoModels / "humanoid" / "22_humanoids.xml", 0.3, 5, 100000, false);
}

// The MJCF features MuJoCo's humanoids do not use — eulerseq, axisangle, xyaxes, zaxis, quat,
// nested default classes and childclass, ball and slide joints with anchors, a cylinder and an
// ellipsoid from fromto/size, contype/conaffinity, <exclude>, <pair>, radians — against MuJoCo.
TEST(Mjcf, FeaturesEqualMujoco) {
  const fs::path dir =
      fs::temp_directory_path() / ("nearpoint-robots-mjcf-" + std::to_string(getpid()));
  fs::create_directories(dir);
  for (const char* angle : {"degree", "radian"}) {
    std::ofstream(dir / "features.xml") << R"(<mujoco model="features">
  <compiler angle=")" << angle << R"(" eulerseq="zYx"/>
  <default><geom type="capsule" size="0.05"/>
    <default class="limb"><joint type="hinge" limited="true" range="-1 1" axis="0 1 0"/>
      <default class="ball"><joint type="ball" range="0 1"/></default></default></default>
  <worldbody>
    <geom name="floor" type="plane" size="0 0 0.1"/>
    <geom name="post" type="box" size="0.1 0.1 0.5" pos="1 0 0.5" zaxis="0 1 1"/>
    <body name="fixed" pos="0.5 0.5 0.2" euler="10 20 30"><geom name="rock" type="sphere" size="0.1"/></body>
    <body name="base" pos="0 0 1" quat="0.9 0 0.1 0" childclass="limb">
      <freejoint name="root"/>
      <geom name="torso" fromto="0 -0.1 0 0 0.1 0"/>
      <body name="arm" pos="0 0 0.2" euler="10 20 30">
        <joint name="shoulder" class="ball" pos="0 0 0.05"/>
        <geom name="upper" type="cylinder" fromto="0 0 0 0.3 0 0.1"/>
        <body name="fore" pos="0.35 0 0" axisangle="0 0 1 0.7">
          <joint name="elbow" pos="0.01 0 0" axis="1 1 0" ref="0.2"/>
          <joint name="slide" type="slide" axis="1 0 1" limited="false" range="0 0.1" ref="0.05"/>
          <geom name="hand" type="ellipsoid" size="0.05 0.06 0.08" xyaxes="1 0 0 0 1 1"/>
          <geom name="tool" type="box" size="0.02 0.03 0.04" pos="0.1 0 0" contype="2" conaffinity="2"/>
          <geom type="sphere" size="0.04" pos="0.1 0 0"/>
          <body name="tip" pos="0.2 0 0"><geom name="nail" size="0.01 0.02" euler="0.1 0.2 0.3"/></body>
        </body>
      </body>
    </body>
  </worldbody>
  <contact><exclude body1="base" body2="fore"/><pair geom1="tool" geom2="post"/></contact>
</mujoco>)";
    check_mujoco_kinematics(dir / "features.xml", 100);
    check_mujoco_distances(dir / "features.xml", 10.0, 20, 5000, true, 10);
  }
  fs::remove_all(dir);
}

// Gradients through ball and free joints (the humanoid100's objects, the humanoid's root) and
// hinges, against central differences along each velocity coordinate (MuJoCo's integration).
TEST(Mjcf, JointGradientEqualsFiniteDifferences) {
  const RobotImport imported = load_mjcf(kMujocoModels / "humanoid" / "humanoid.xml");
  ASSERT_TRUE(imported.ok()) << imported.error;
  Robot robot = imported.robot;
  const Evaluator evaluator(robot);
  std::mt19937_64 rng(11);
  const double h = 1e-6;
  int checked = 0;
  for (int sample = 0; sample < 10; ++sample) {
    const std::vector<double> q = random_q(robot.tree, rng);
    KinematicState state;
    ASSERT_EQ(robot.tree.forward(q, state), "");
    for (const auto& [pair_a, pair_b] : robot.pairs) {
      // Copies: clang before 16 cannot capture structured bindings in a lambda (P1091).
      const auto a = pair_a;
      const auto b = pair_b;
      const CompoundResult<double> r = evaluator.evaluate(state, a, b);
      if (r.nearest.status != Status::separated || r.nearest.distance < 1e-3) continue;
      const Eigen::VectorXd g =
          robot.joint_gradient(state, a, r.nearest.gradient_a, b, r.nearest.gradient_b);
      const double scale = std::max(1.0, g.lpNorm<Eigen::Infinity>());
      for (int i = 0; i < robot.tree.nv(); ++i) {
        std::vector<double> v(robot.tree.nv(), 0.0);
        v[i] = 1;
        const double fd = (evaluator.at(robot.tree.integrate(q, v, h), a, b) -
                           evaluator.at(robot.tree.integrate(q, v, -h), a, b)) /
                          (2 * h);
        EXPECT_LT(std::abs(fd - g[i]) / scale, 1e-6)
            << robot.objects[a].name << "–" << robot.objects[b].name << " dof " << i;
      }
      ++checked;
    }
  }
  EXPECT_GT(checked, 50);
}

TEST(Mjcf, BallJointGradientEqualsFiniteDifferences) {
  const std::string xml = R"(<mujoco>
    <compiler angle="radian" eulerseq="ZyX"/>
    <default><geom type="capsule" size="0.05"/>
      <default class="arm"><joint type="ball" pos="0 0 0.1"/></default></default>
    <worldbody>
      <geom name="post" type="box" size="0.1 0.1 0.5" pos="0.6 0 0.5"/>
      <body name="a" pos="0 0 1" euler="0.3 -0.2 0.1" childclass="arm">
        <joint name="shoulder"/>
        <geom name="upper" fromto="0 0 0 0.3 0 0"/>
        <body name="b" pos="0.35 0 0" axisangle="0 1 0 0.5">
          <joint name="elbow" type="slide" axis="1 1 0"/>
          <joint name="twist" type="hinge" axis="0 0 1"/>
          <geom name="fore" type="box" size="0.05 0.06 0.15" zaxis="1 0 1"/>
        </body>
      </body>
    </worldbody></mujoco>)";
  const RobotImport imported = parse_mjcf(xml, "ball.xml", ".");
  ASSERT_TRUE(imported.ok()) << imported.error;
  const Robot& robot = imported.robot;
  ASSERT_EQ(robot.tree.nv(), 5);
  const Evaluator evaluator(robot);
  std::mt19937_64 rng(3);
  int checked = 0;
  for (int sample = 0; sample < 50; ++sample) {
    const std::vector<double> q = random_q(robot.tree, rng);
    KinematicState state;
    ASSERT_EQ(robot.tree.forward(q, state), "");
    for (const auto& [pair_a, pair_b] : robot.pairs) {
      // Copies: clang before 16 cannot capture structured bindings in a lambda (P1091).
      const auto a = pair_a;
      const auto b = pair_b;
      const CompoundResult<double> r = evaluator.evaluate(state, a, b);
      if (r.nearest.status != Status::separated || r.nearest.distance < 1e-3) continue;
      const Eigen::VectorXd g =
          robot.joint_gradient(state, a, r.nearest.gradient_a, b, r.nearest.gradient_b);
      for (int i = 0; i < robot.tree.nv(); ++i) {
        std::vector<double> v(robot.tree.nv(), 0.0);
        v[i] = 1;
        const double fd = (evaluator.at(robot.tree.integrate(q, v, 1e-6), a, b) -
                           evaluator.at(robot.tree.integrate(q, v, -1e-6), a, b)) /
                          2e-6;
        EXPECT_LT(std::abs(fd - g[i]) / std::max(1.0, g.lpNorm<Eigen::Infinity>()), 1e-6);
      }
      ++checked;
    }
  }
  EXPECT_GT(checked, 20);
}

// ---------------------------------------------------------------------------------------------
// Hostile descriptions: an error naming the file and what is wrong, never a crash.

void expect_error(const RobotImport& imported, const std::vector<std::string>& words) {
  ASSERT_FALSE(imported.ok()) << "accepted; expected an error with '" << words[0] << "'";
  for (const std::string& word : words)
    EXPECT_NE(imported.error.find(word), std::string::npos)
        << "'" << word << "' not in: " << imported.error;
}

TEST(Hostile, Urdf) {
  const ImportOptions options = arm_options();
  expect_error(parse_urdf("<robot name='x'><link name='a'>", "bad.urdf", ".", options),
               {"bad.urdf", "not valid XML"});
  expect_error(parse_urdf("", "empty.urdf", ".", options), {"empty.urdf"});
  // A cycle: every link has a parent, so there is no root.
  expect_error(parse_urdf(R"(<robot name="c"><link name="a"/><link name="b"/>
      <joint name="j1" type="fixed"><parent link="a"/><child link="b"/></joint>
      <joint name="j2" type="fixed"><parent link="b"/><child link="a"/></joint></robot>)",
                          "cycle.urdf", ".", options),
               {"cycle.urdf", "cycle through link"});
  expect_error(parse_urdf(R"(<robot name="s"><link name="a"/>
      <joint name="self" type="fixed"><parent link="a"/><child link="a"/></joint></robot>)",
                          "self.urdf", ".", options),
               {"self.urdf", "cycle through link 'a'"});
  expect_error(parse_urdf(R"(<robot name="t"><link name="a"/><link name="b"/><link name="c"/>
      <joint name="j1" type="fixed"><parent link="a"/><child link="c"/></joint>
      <joint name="j2" type="fixed"><parent link="b"/><child link="c"/></joint></robot>)",
                          "two.urdf", ".", options),
               {"two.urdf", "joint 'j2'", "link 'c' already has a parent"});
  expect_error(parse_urdf(R"(<robot name="n"><link name="a"><collision><origin xyz="nan 0 0"/>
      <geometry><box size="1 1 1"/></geometry></collision></link></robot>)",
                          "nan.urdf", ".", options),
               {"nan.urdf", "Link [a]", "nan"});
  expect_error(parse_urdf(R"(<robot name="n"><link name="a"><collision>
      <geometry><box size="inf 1 1"/></geometry></collision></link></robot>)",
                          "inf.urdf", ".", options),
               {"inf.urdf", "Link [a]", "inf"});
  expect_error(parse_urdf(R"(<robot name="z"><link name="a"/><link name="b"/>
      <joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 0"/>
      <limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>)",
                          "axis.urdf", ".", options),
               {"axis.urdf", "joint 'j'", "<axis>", "non-zero"});
  expect_error(parse_urdf(R"(<robot name="n"><link name="a"><collision>
      <geometry><sphere radius="-1"/></geometry></collision></link></robot>)",
                          "neg.urdf", ".", options),
               {"neg.urdf", "radius"});
  expect_error(parse_urdf(R"(<robot name="m"><link name="a"><collision>
      <geometry><mesh filename="missing.stl"/></geometry></collision></link></robot>)",
                          "mesh.urdf", ".", options),
               {"mesh.urdf", "link 'a'", "missing.stl", "not found"});
  expect_error(parse_urdf(R"(<robot name="f"><link name="a"/><link name="b"/>
      <joint name="float" type="floating"><parent link="a"/><child link="b"/></joint></robot>)",
                          "float.urdf", ".", options),
               {"float.urdf", "joint 'float'", "floating"});
  Robot robot = load_arm();
  EXPECT_NE(
      apply_srdf("<robot><disable_collisions link1='nope' link2='hand'/></robot>", "x.srdf", robot)
          .find("link 'nope'"),
      std::string::npos);
  EXPECT_NE(apply_srdf("<robot><surprise/></robot>", "x.srdf", robot).find("<surprise>"),
            std::string::npos);
  EXPECT_NE(apply_srdf("<robot", "x.srdf", robot).find("not valid XML"), std::string::npos);
  ImportOptions padded = arm_options();
  padded.link_padding["no_such_link"] = 0.01;
  expect_error(load_urdf(kExamples / "arm7.urdf", padded), {"no_such_link"});
}

TEST(Hostile, Mjcf) {
  expect_error(parse_mjcf("<mujoco><worldbody>", "bad.xml", "."), {"bad.xml", "not valid XML"});
  expect_error(parse_mjcf("<robot/>", "r.xml", "."), {"r.xml", "<mujoco>"});
  expect_error(parse_mjcf(R"(<mujoco><worldbody><body pos="0 nan 0"><geom size="1"/></body>
      </worldbody></mujoco>)",
                          "nan.xml", "."),
               {"nan.xml", "line 1", "<body", "'pos'", "not finite"});
  expect_error(parse_mjcf(R"(<mujoco><worldbody><geom type="hfield" hfield="h"/></worldbody>
      </mujoco>)",
                          "h.xml", "."),
               {"h.xml", "<geom", "hfield", "not supported"});
  expect_error(parse_mjcf(R"(<mujoco><worldbody><body><composite type="grid"/></body>
      </worldbody></mujoco>)",
                          "c.xml", "."),
               {"c.xml", "<composite>", "not supported"});
  expect_error(parse_mjcf(R"(<mujoco><worldbody><geom class="nope" size="1"/></worldbody>
      </mujoco>)",
                          "k.xml", "."),
               {"k.xml", "unknown default class 'nope'"});
  expect_error(parse_mjcf(R"(<mujoco><worldbody><geom type="capsule" size="0.1"
      fromto="0 0 0 0 0 0"/></worldbody></mujoco>)",
                          "f.xml", "."),
               {"f.xml", "fromto"});
  expect_error(parse_mjcf(R"(<mujoco><worldbody><body><joint/><freejoint/><geom size="1"/></body>
      </worldbody></mujoco>)",
                          "j.xml", "."),
               {"j.xml", "free joint"});
  expect_error(parse_mjcf(R"(<mujoco><asset><mesh file="gone.stl"/></asset><worldbody>
      <geom type="mesh" mesh="gone"/></worldbody></mujoco>)",
                          "m.xml", "."),
               {"m.xml", "gone.stl", "not found"});
  expect_error(parse_mjcf(R"(<mujoco><worldbody><geom size="1" quat="1 0 0 0" euler="0 0 1"/>
      </worldbody></mujoco>)",
                          "o.xml", "."),
               {"o.xml", "more than one orientation"});
  expect_error(parse_mjcf(R"(<mujoco><contact><exclude body1="a" body2="b"/></contact>
      <worldbody/></mujoco>)",
                          "x.xml", "."),
               {"x.xml", "unknown body 'a'"});
  // An include cycle.
  const fs::path dir =
      fs::temp_directory_path() / ("nearpoint-robots-inc-" + std::to_string(getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "a.xml")
      << "<mujoco><worldbody><body><include file='a.xml'/></body></worldbody></mujoco>";
  expect_error(load_mjcf(dir / "a.xml"), {"a.xml", "include"});
  expect_error(load_mjcf(dir / "none.xml"), {"none.xml", "cannot open"});
  fs::remove_all(dir);
}

TEST(Hostile, KinematicsInputs) {
  const Robot robot = load_arm();
  KinematicState state;
  std::vector<double> q = robot.tree.neutral();
  q.pop_back();
  EXPECT_NE(robot.tree.forward(q, state).find("expected 8"), std::string::npos);
  q = robot.tree.neutral();
  q[2] = std::nan("");
  EXPECT_NE(robot.tree.forward(q, state).find("not finite"), std::string::npos);
}

}  // namespace
