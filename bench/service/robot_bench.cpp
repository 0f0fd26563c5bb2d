// SPDX-License-Identifier: Apache-2.0
// nearpoint_robot_bench: what a robot scene costs per update (issue 32), against MuJoCo's own
// pipeline on the same model. In-process through the scene API (SceneService and PoseStream, as
// every transport uses them): per update, joint positions in → forward kinematics, broad phase,
// the pairs' distances → report (ReportTiming::server_us, the server-side time). Beside it, per
// step, MuJoCo's mj_kinematics + mj_collision with every geom's margin at the same cutoff (so
// that it reports the pairs we report closer than the cutoff), and the largest difference
// between its contact distances and ours on capsule/sphere pairs. Wire bytes: a PoseUpdate with
// the joint positions against one with the carried objects' poses (protobuf ByteSizeLong).
//
//   nearpoint_robot_bench MODEL.xml|.urdf [...] [--updates 200] [--cutoff 0.3] [--workers 1]
//                         [--within] [--csv FILE]
// --within: reports hold the pairs within the cutoff (REPORT_MODE_WITHIN_CUTOFF), as MuJoCo's
// contact list does; otherwise every selected pair.
// Joint trajectories: each one-dof joint sweeps sinusoidally within its limits (±1 rad when
// unlimited); free joints stay at their reference with a small drift, ball joints turn slowly.
#include <mujoco/mujoco.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <future>
#include <map>
#include <string>
#include <vector>

#ifdef NEARPOINT_BENCH_MESHES
#include "nearpoint/client/mesh_loader.hpp"
#endif
#include "nearpoint/model/percentile.hpp"
#include "nearpoint/robots/robot.hpp"
#include "nearpoint/server/scene_service.hpp"
#include "proto_convert.hpp"

namespace {

using namespace nearpoint;
using namespace nearpoint::server;
using nearpoint::model::percentile;

std::vector<double> positions_at(const robots::KinematicTree& tree, int step) {
  std::vector<double> q = tree.neutral();
  const double t = 0.01 * step;
  int k = 0;
  for (const robots::Joint& joint : tree.joints) {
    ++k;
    const double phase = 0.37 * k;
    if (joint.nq() == 1) {
      const double lo = joint.limited ? joint.lower : -1.0;
      const double hi = joint.limited ? joint.upper : 1.0;
      q[joint.q_index] = 0.5 * (lo + hi) + 0.45 * (hi - lo) * std::sin(t * 3 + phase);
    } else if (joint.type == robots::JointType::free) {
      const robots::Pose3d& at = tree.links[joint.link].offset;
      for (int c = 0; c < 3; ++c) q[joint.q_index + c] = at.translation[c] + 0.05 * std::sin(t + c);
      const Eigen::Quaterniond r(at.rotation);
      const Eigen::Quaterniond turn(Eigen::AngleAxisd(0.2 * std::sin(t), Eigen::Vector3d::UnitZ()));
      const Eigen::Quaterniond qr = turn * r;
      q[joint.q_index + 3] = qr.w(), q[joint.q_index + 4] = qr.x();
      q[joint.q_index + 5] = qr.y(), q[joint.q_index + 6] = qr.z();
    } else if (joint.type == robots::JointType::ball) {
      const Eigen::Quaterniond qr(
          Eigen::AngleAxisd(0.3 * std::sin(t + phase), Eigen::Vector3d(1, 1, 0).normalized()));
      q[joint.q_index] = qr.w(), q[joint.q_index + 1] = qr.x();
      q[joint.q_index + 2] = qr.y(), q[joint.q_index + 3] = qr.z();
    }
  }
  return q;
}

model::JointPositionsInput joint_input(const robots::KinematicTree& tree,
                                       const std::vector<double>& q) {
  model::JointPositionsInput out;
  for (const robots::Joint& joint : tree.joints) {
    if (joint.nq() == 0) continue;
    out.names.push_back(joint.name);
    for (int c = 0; c < joint.nq(); ++c) out.positions.push_back(q[joint.q_index + c]);
  }
  return out;
}

struct Row {
  std::string model;
  std::size_t objects = 0, pairs = 0, nq = 0;
  double cold_us = 0, warm_p50_us = 0, warm_p90_us = 0;
  double evaluated = 0, pruned = 0;
  std::size_t joint_bytes = 0, pose_bytes = 0;
  double mujoco_p50_us = 0;
  int compared = 0;
  double worst = 0;
};

std::string geom_name(const mjModel* m, int g) {
  if (const char* name = mj_id2name(m, mjOBJ_GEOM, g); name != nullptr && *name) return name;
  const int body = m->geom_bodyid[g];
  const char* body_name = mj_id2name(m, mjOBJ_BODY, body);
  return std::string(body_name != nullptr && *body_name ? body_name
                                                        : "body" + std::to_string(body)) +
         "/geom" + std::to_string(g - m->body_geomadr[body]);
}

bool run_model(const std::string& path, int updates, double cutoff, std::size_t workers,
               bool within, Row& row) {
  formats::SceneFile file;
  robots::ImportOptions options;
#ifdef NEARPOINT_BENCH_MESHES
  options.meshes = client::mesh_loader();
#endif
  if (std::string error = robots::load_robot_scene(path, options, {}, file); !error.empty()) {
    std::fprintf(stderr, "%s\n", error.c_str());
    return false;
  }
  const robots::RobotImport imported = robots::load_robot(path, options);
  const robots::KinematicTree& tree = imported.robot.tree;
  ServiceLimits limits;
  limits.max_pairs_per_scene = 10'000'000;
  limits.max_piece_pairs_per_scene = 10'000'000;
  limits.max_objects_per_scene = 100'000;
  SceneService service(limits, workers);
  std::map<std::string, std::string> ids;
  for (const auto& [name, geometry] : file.geometries) {
    auto info = service.register_geometry(geometry);
    if (!info) {
      std::fprintf(stderr, "%s: %s\n", name.c_str(), info.error().describe().c_str());
      return false;
    }
    ids[name] = info->geometry_id;
  }
  for (std::size_t i = 0; i < file.scene.objects.size(); ++i)
    file.scene.objects[i].geometry_id = ids.at(file.geometry_names[i]);
  file.scene.default_options.distance_cutoff = cutoff;
  if (within) file.scene.default_options.report_mode = model::ReportMode::within_cutoff;
  auto created = service.create_scene(file.scene);
  if (!created) {
    std::fprintf(stderr, "create: %s\n", created.error().describe().c_str());
    return false;
  }
  row.model = std::filesystem::path(path).filename().string() + (within ? " (within)" : " (all)");
  row.objects = file.scene.objects.size();
  row.pairs = created->pair_count;
  row.nq = std::size_t(tree.nq());

  // Wire bytes: the joint positions against the carried objects' poses.
  {
    const std::vector<double> q = positions_at(tree, 1);
    v1::PoseUpdate joints;
    joints.set_scene_id(created->scene_id);
    joints.set_sequence(1000);
    proto::to_proto(joint_input(tree, q), *joints.mutable_joints());
    row.joint_bytes = joints.ByteSizeLong();
    v1::PoseUpdate poses;
    poses.set_scene_id(created->scene_id);
    poses.set_sequence(1000);
    robots::KinematicState state;
    tree.forward(q, state);
    for (std::size_t o = 0; o < imported.robot.objects.size(); ++o) {
      if (imported.robot.objects[o].link < 0) continue;
      const robots::Pose3d pose = imported.robot.object_pose(state, int(o));
      const Eigen::Quaterniond r(pose.rotation);
      model::ObjectPoseInput input{imported.robot.objects[o].name, {}};
      input.pose.rotation_wxyz = {r.w(), r.x(), r.y(), r.z()};
      input.pose.translation = pose.translation;
      proto::to_proto(input, *poses.add_poses());
    }
    row.pose_bytes = poses.ByteSizeLong();
  }

  // MuJoCo on the same model, every geom's margin at the cutoff.
  char error[1000] = "";
  mjModel* m = path.size() > 4 && path.substr(path.size() - 4) == ".xml"
                   ? mj_loadXML(path.c_str(), nullptr, error, sizeof error)
                   : nullptr;
  mjData* d = nullptr;
  std::map<std::string, int> geom_of;
  if (m != nullptr) {
    m->nconmax = 1'000'000;
    for (int g = 0; g < m->ngeom; ++g) m->geom_margin[g] = cutoff;
    for (int p = 0; p < m->npair; ++p) m->pair_margin[p] = cutoff;
    d = mj_makeData(m);
    for (int g = 0; g < m->ngeom; ++g) geom_of[geom_name(m, g)] = g;
  }

  std::unique_ptr<PoseStream> stream = std::move(service.open_stream().value());
  std::vector<double> warm, mujoco;
  for (int step = 0; step < updates; ++step) {
    const std::vector<double> q = positions_at(tree, step);
    model::PoseUpdateInput update;
    update.scene_id = created->scene_id;
    update.sequence = std::uint64_t(step) + 1;
    update.joints = joint_input(tree, q);
    Expected<PreparedUpdate> prepared = stream->prepare(update, Clock::now());
    if (!prepared) {
      std::fprintf(stderr, "update: %s\n", prepared.error().describe().c_str());
      return false;
    }
    std::promise<Report> done;
    stream->evaluate(std::move(*prepared), [&](Report r) { done.set_value(std::move(r)); });
    const Report report = done.get_future().get();
    // server_us runs from `received` (taken before prepare): the kinematics are inside it.
    if (step == 0) {
      row.cold_us = report.timing.server_us;
    } else {
      warm.push_back(report.timing.server_us);
      row.evaluated += report.counts.pairs_evaluated;
      row.pruned += report.counts.pairs_pruned;
    }
    if (d == nullptr) continue;
    for (int i = 0; i < m->nq; ++i) d->qpos[i] = q[std::size_t(i)];
    const auto begin = std::chrono::steady_clock::now();
    mj_kinematics(m, d);
    mj_collision(m, d);
    mujoco.push_back(
        std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - begin)
            .count());
    std::map<std::pair<int, int>, double> theirs;
    for (int c = 0; c < d->ncon; ++c) {
      const auto key = std::minmax(d->contact[c].geom1, d->contact[c].geom2);
      auto [it, inserted] = theirs.emplace(key, d->contact[c].dist);
      if (!inserted) it->second = std::min(it->second, d->contact[c].dist);
    }
    for (const model::PairReport& pair : report.pairs) {
      if (pair.status != model::PairStatus::separated) continue;
      const int ga = geom_of.at(report.scene->objects[pair.object_a].id);
      const int gb = geom_of.at(report.scene->objects[pair.object_b].id);
      auto round = [&](int g) {
        return m->geom_type[g] == mjGEOM_CAPSULE || m->geom_type[g] == mjGEOM_SPHERE;
      };
      if (!round(ga) || !round(gb)) continue;
      const auto it = theirs.find(std::minmax(ga, gb));
      if (it == theirs.end()) continue;
      row.worst = std::max(row.worst, std::abs(it->second - pair.distance));
      ++row.compared;
    }
  }
  row.warm_p50_us = percentile(warm, 0.5);
  row.warm_p90_us = percentile(warm, 0.9);
  row.evaluated /= double(std::max<std::size_t>(1, warm.size()));
  row.pruned /= double(std::max<std::size_t>(1, warm.size()));
  row.mujoco_p50_us = mujoco.empty() ? std::nan("") : percentile(mujoco, 0.5);
  if (d != nullptr) mj_deleteData(d);
  if (m != nullptr) mj_deleteModel(m);
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> models;
  int updates = 200;
  double cutoff = 0.3;
  std::size_t workers = 1;
  std::string csv;
  bool within = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&] { return i + 1 < argc ? std::string(argv[++i]) : std::string(); };
    if (arg == "--updates")
      updates = std::stoi(value());
    else if (arg == "--cutoff")
      cutoff = std::stod(value());
    else if (arg == "--workers")
      workers = std::size_t(std::stoul(value()));
    else if (arg == "--csv")
      csv = value();
    else if (arg == "--within")
      within = true;
    else
      models.push_back(arg);
  }
  std::printf(
      "| model | objects | pairs | nq | server µs cold | warm p50 | p90 | evaluated | pruned | "
      "joint bytes | pose bytes | MuJoCo kin+coll µs p50 | pairs vs MuJoCo | max |Δd| |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  std::ofstream out;
  if (!csv.empty()) {
    out.open(csv);
    out << "model,objects,pairs,nq,cold_us,warm_p50_us,warm_p90_us,evaluated,pruned,joint_bytes,"
           "pose_bytes,mujoco_p50_us,compared,max_abs_diff\n";
  }
  for (const std::string& path : models) {
    Row row;
    if (!run_model(path, updates, cutoff, workers, within, row)) return 1;
    std::printf(
        "| %s | %zu | %zu | %zu | %.0f | %.1f | %.1f | %.0f | %.0f | %zu | %zu | %.1f | %d "
        "| %.2g |\n",
        row.model.c_str(), row.objects, row.pairs, row.nq, row.cold_us, row.warm_p50_us,
        row.warm_p90_us, row.evaluated, row.pruned, row.joint_bytes, row.pose_bytes,
        row.mujoco_p50_us, row.compared, row.worst);
    if (out)
      out << row.model << ',' << row.objects << ',' << row.pairs << ',' << row.nq << ','
          << row.cold_us << ',' << row.warm_p50_us << ',' << row.warm_p90_us << ',' << row.evaluated
          << ',' << row.pruned << ',' << row.joint_bytes << ',' << row.pose_bytes << ','
          << row.mujoco_p50_us << ',' << row.compared << ',' << row.worst << '\n';
  }
  return 0;
}
