// SPDX-License-Identifier: Apache-2.0
// nearpoint_big_scene_bench: what a big scene costs the server per update when only a few of its
// objects move (issue 22). In-process, through the scene API (SceneService and PoseStream, as
// every transport uses them), so the figures are server-side only: from the update being handed
// over to its report being ready (ReportTiming::server_us), plus the pairs evaluated, pruned by
// the broad phase and skipped as unmoved.
//
// The scene generator: n objects (the 10 paper-family polytopes of bench_scene.hpp scaled to
// ~0.5 m, boxes and capsules) on a jittered grid whose spacing sets the density (--spacing, metres
// between neighbours); k of them drift and turn along smooth trajectories around their places,
// the others stay put. All pairs are selected (--selection all), or only the pairs with a moving
// object (--selection moving: the moving objects are one group, the static world another that
// does not collide with itself, as a robot cell is modelled; the only way to n = 10,000, whose
// all pairs are 50 M). Ways of asking, in the same run (broad phase on and off):
//   recompute   — a unary query per update, no cutoff: every pair through the engine (the cost of
//                 an update before this change);
//   moved       — a pose stream, no cutoff: only pairs with a moved object are evaluated;
//   moved+bp    — a pose stream with --cutoff: only moved pairs, and only those the broad phase
//                 cannot prove beyond the cutoff;
//   bp only     — a unary query with --cutoff: the broad phase alone (every object counts as
//                 moved);
//   moved+bp, within — moved+bp with REPORT_MODE_WITHIN_CUTOFF: the report holds only the pairs
//                 not beyond the cutoff;
//   moved+bp, changed / nearest / global — moved+bp in the other report modes.
// Report bytes: the report as the gRPC service sends it (nearpoint.v1.DistanceReport,
// ByteSizeLong), converted outside the timed part.
//
//   nearpoint_big_scene_bench [--sizes 100,1000] [--moving 1,10,all] [--updates 20]
//                             [--recompute-updates 3] [--spacing 2] [--cutoff 0.5] [--workers 2]
//                             [--selection all|moving]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "bench_scene.hpp"
#include "nearpoint/model/percentile.hpp"
#include "nearpoint/server/scene_service.hpp"
#include "proto_convert.hpp"

namespace {

using namespace nearpoint::server;
namespace model = nearpoint::model;
using Vec3 = Eigen::Vector3d;
using nearpoint::model::percentile;

struct Settings {
  std::vector<std::size_t> sizes{100, 1000};
  std::vector<std::string> moving{"1", "10", "all"};
  int updates = 20;
  int recompute_updates = 3;
  double spacing = 2.0;
  double cutoff = 0.5;
  std::size_t workers = 2;
  bool moving_selection = false;
};

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream stream(text);
  for (std::string item; std::getline(stream, item, ',');) out.push_back(item);
  return out;
}

/// The geometries: the 10 paper-family polytopes scaled by 1/4, a box and a capsule.
std::vector<std::string> register_geometries(SceneService& service) {
  std::vector<std::string> ids;
  for (const std::vector<Vec3>& vertices : bench_scene::paper_like_polytopes()) {
    model::GeometryInput geometry;
    model::PolytopeInput polytope;
    for (const Vec3& v : vertices) polytope.vertices.push_back(0.25 * v);
    geometry.pieces.emplace_back().shape = std::move(polytope);
    ids.push_back(service.register_geometry(geometry)->geometry_id);
  }
  model::GeometryInput box;
  box.pieces.emplace_back().shape = nearpoint::Box<double>{Vec3(0.3, 0.2, 0.15)};
  ids.push_back(service.register_geometry(box)->geometry_id);
  model::GeometryInput capsule;
  capsule.pieces.emplace_back().shape =
      nearpoint::Segment<double>{Vec3(-0.2, 0, 0), Vec3(0.2, 0, 0)};
  capsule.pieces.back().radius = 0.1;
  ids.push_back(service.register_geometry(capsule)->geometry_id);
  return ids;
}

/// Object i's home: a cubic grid of `spacing`, jittered by up to a quarter of it.
std::vector<Vec3> homes(std::size_t n, double spacing) {
  std::mt19937_64 rng(22);
  std::uniform_real_distribution<double> jitter(-0.25 * spacing, 0.25 * spacing);
  const std::size_t side = std::size_t(std::ceil(std::cbrt(double(n))));
  std::vector<Vec3> out;
  for (std::size_t i = 0; i < n; ++i)
    out.push_back(spacing *
                      Vec3(double(i % side), double(i / side % side), double(i / side / side)) +
                  Vec3(jitter(rng), jitter(rng), jitter(rng)));
  return out;
}

/// Object i at `step`: around its home, drifting 0.4 m and turning (smooth, period ~1000 steps).
model::PoseInput pose_at(const Vec3& home, std::size_t i, int step) {
  const auto [q, offset] = bench_scene::object_pose(int(i % 10), step, double(i));
  model::PoseInput pose;
  pose.rotation_wxyz = {q.w(), q.x(), q.y(), q.z()};
  // object_pose circles 3.2 m around the origin; keep only its drift, scaled to ±0.4 m.
  const double theta = 2 * std::numbers::pi * double(i % 10) / 10;
  pose.translation = home + 0.66 * (offset - 3.2 * Vec3(std::cos(theta), std::sin(theta), 0));
  return pose;
}

struct Row {
  double median_us = 0;
  double p90_us = 0;
  double evaluated = 0, pruned = 0, unmoved = 0, reported = 0, bytes = 0;
  std::size_t pairs = 0;
  int updates = 0;
};

/// What a row keeps of one report (not its pairs: 500,000 of them are 115 MB).
struct Sample {
  double server_us = 0;
  model::ReportCounts counts;
  std::size_t pairs = 0;     // selected in the scene
  std::size_t reported = 0;  // in the report
  std::size_t bytes = 0;     // nearpoint.v1.DistanceReport on the wire
};

Sample sample(const Report& report) {
  nearpoint::v1::DistanceReport message;
  to_proto(report, message);
  return Sample{report.timing.server_us, report.counts, report.scene->pairs.size(),
                report.pairs.size(), message.ByteSizeLong()};
}

Row summarise(const std::vector<Sample>& reports) {
  Row row;
  std::vector<double> times;
  for (const Sample& report : reports) {
    times.push_back(report.server_us);
    row.evaluated += report.counts.pairs_evaluated;
    row.pruned += report.counts.pairs_pruned;
    row.unmoved += report.counts.pairs_unmoved;
    row.pairs = report.pairs;
    row.reported += double(report.reported);
    row.bytes += double(report.bytes);
  }
  const double count = double(std::max<std::size_t>(1, reports.size()));
  row.evaluated /= count;
  row.pruned /= count;
  row.unmoved /= count;
  row.reported /= count;
  row.bytes /= count;
  row.median_us = percentile(times, 0.5);
  row.p90_us = percentile(times, 0.9);
  row.updates = int(reports.size());
  return row;
}

/// `updates` updates moving the first k objects; a stream's first report (everything evaluated,
/// nothing to reuse yet) is left out of the figures and measured separately.
std::vector<Sample> run_stream(SceneService& service, const std::string& scene,
                               const std::vector<Vec3>& home, std::size_t k, int updates,
                               std::optional<double> cutoff, Sample* first,
                               model::ReportMode mode = model::ReportMode::unspecified) {
  std::unique_ptr<PoseStream> stream = std::move(service.open_stream().value());
  std::vector<Sample> reports;
  for (int u = 0; u <= updates; ++u) {
    model::PoseUpdateInput update;
    update.scene_id = scene;
    update.sequence = std::uint64_t(u) + 1;
    update.options.distance_cutoff = cutoff;
    update.options.report_mode = mode;
    for (std::size_t i = 0; i < k; ++i)
      update.poses.push_back({"o" + std::to_string(i), pose_at(home[i], i, u + 1)});
    Expected<PreparedUpdate> prepared = stream->prepare(update, Clock::now());
    if (!prepared) {
      std::fprintf(stderr, "update refused: %s\n", prepared.error().describe().c_str());
      std::exit(1);
    }
    std::promise<Report> done;
    stream->evaluate(std::move(*prepared), [&](Report r) { done.set_value(std::move(r)); });
    const Sample got = sample(done.get_future().get());
    if (u == 0) {
      if (first) *first = got;
    } else {
      reports.push_back(got);
    }
  }
  return reports;
}

std::vector<Sample> run_queries(SceneService& service, const std::string& scene,
                                const std::vector<Vec3>& home, std::size_t k, int updates,
                                std::optional<double> cutoff) {
  std::vector<Sample> reports;
  for (int u = 1; u <= updates; ++u) {
    model::QueryInput query;
    query.scene_id = scene;
    query.options.distance_cutoff = cutoff;
    query.options.warm_start = false;
    for (std::size_t i = 0; i < k; ++i)
      query.poses.push_back({"o" + std::to_string(i), pose_at(home[i], i, u)});
    std::promise<Report> done;
    const Outcome started =
        service.query(query, Clock::now(), [&](Report r) { done.set_value(std::move(r)); });
    if (!started.ok()) {
      std::fprintf(stderr, "query refused: %s\n", started.error().describe().c_str());
      std::exit(1);
    }
    reports.push_back(sample(done.get_future().get()));
  }
  return reports;
}

}  // namespace

int main(int argc, char** argv) {
  Settings settings;
  for (int a = 1; a + 1 < argc; a += 2) {
    const std::string key = argv[a], value = argv[a + 1];
    if (key == "--sizes") {
      settings.sizes.clear();
      for (const std::string& s : split(value)) settings.sizes.push_back(std::stoul(s));
    } else if (key == "--moving") {
      settings.moving = split(value);
    } else if (key == "--updates") {
      settings.updates = std::max(1, std::stoi(value));
    } else if (key == "--recompute-updates") {
      settings.recompute_updates = std::max(0, std::stoi(value));
    } else if (key == "--spacing") {
      settings.spacing = std::stod(value);
    } else if (key == "--cutoff") {
      settings.cutoff = std::stod(value);
    } else if (key == "--workers") {
      settings.workers = std::stoul(value);
    } else if (key == "--selection") {
      settings.moving_selection = value == "moving";
    } else {
      std::fprintf(stderr, "unknown option %s (see the header of big_scene_bench.cpp)\n",
                   key.c_str());
      return 2;
    }
  }

  ServiceLimits limits;
  limits.max_objects_per_scene = 100'000;
  limits.max_pairs_per_scene = 100'000'000;
  limits.max_piece_pairs_per_scene = 100'000'000;
  // In-process: an all-pairs report of n = 1,000 (~35 MB) is measured, though no transport
  // would send it (nearpointd refuses that scene in mode all-pairs; see "report bytes").
  limits.max_report_bytes = std::size_t(1) << 40;
  SceneService service(limits, settings.workers);
  const std::vector<std::string> geometries = register_geometries(service);

  std::printf(
      "spacing %.2f m, cutoff %.2f m, workers %zu, %d updates per row (recompute: %d), "
      "selection %s\n\n",
      settings.spacing, settings.cutoff, settings.workers, settings.updates,
      settings.recompute_updates, settings.moving_selection ? "moving" : "all");
  std::printf(
      "| n | pairs | k | mode | server µs/update p50 | p90 | evaluated | pruned | unmoved | "
      "reach the engine | reported | report bytes |\n"
      "|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  for (const std::size_t n : settings.sizes) {
    const std::vector<Vec3> home = homes(n, settings.spacing);
    // The scene for `k` moving objects (with --selection moving, its pairs depend on k).
    auto create = [&](std::size_t k) {
      model::SceneInput input;
      for (std::size_t i = 0; i < n; ++i) {
        model::ObjectInput& object = input.objects.emplace_back();
        object.id = "o" + std::to_string(i);
        object.geometry_id = geometries[i % geometries.size()];
        object.pose = pose_at(home[i], i, 0);
        if (settings.moving_selection) {
          // Moving: group 1, meets everything; static: group 2, meets only group 1.
          object.group = i < k ? 1u : 2u;
          object.mask = i < k ? 3u : 1u;
        }
      }
      Expected<model::SceneInfo> scene = service.create_scene(input);
      if (!scene) {
        std::fprintf(stderr, "scene refused: %s\n", scene.error().describe().c_str());
        std::exit(1);
      }
      return scene.value();
    };
    std::optional<model::SceneInfo> scene;
    if (!settings.moving_selection) scene = create(n);
    auto print = [&](std::size_t k, const char* mode, const Row& row) {
      std::printf(
          "| %zu | %zu | %zu | %s | %.0f | %.0f | %.1f | %.1f | %.1f | %.3f %% | %.1f | %.0f |\n",
          n, row.pairs, k, mode, row.median_us, row.p90_us, row.evaluated, row.pruned, row.unmoved,
          100.0 * row.evaluated / double(std::max<std::size_t>(1, row.pairs)), row.reported,
          row.bytes);
      std::fflush(stdout);
    };
    std::vector<std::size_t> done;
    for (const std::string& moving : settings.moving) {
      const std::size_t k = moving == "all" ? n : std::min(n, std::size_t(std::stoul(moving)));
      if (std::find(done.begin(), done.end(), k) != done.end())
        continue;  // "10" and "all" at n = 10
      done.push_back(k);
      if (settings.moving_selection) {
        if (scene) (void)service.delete_scene(scene->scene_id);
        scene = create(k);
      }
      if (settings.recompute_updates > 0)
        print(k, "recompute",
              summarise(run_queries(service, scene->scene_id, home, k, settings.recompute_updates,
                                    std::nullopt)));
      const int stream_updates =
          k == n ? std::min(settings.updates, settings.recompute_updates + 2) : settings.updates;
      print(k, "moved",
            summarise(run_stream(service, scene->scene_id, home, k, stream_updates, std::nullopt,
                                 nullptr)));
      Sample first;
      print(k, "moved+bp",
            summarise(run_stream(service, scene->scene_id, home, k, settings.updates,
                                 settings.cutoff, &first)));
      print(k, "moved+bp, within",
            summarise(run_stream(service, scene->scene_id, home, k, settings.updates,
                                 settings.cutoff, nullptr, model::ReportMode::within_cutoff)));
      print(k, "moved+bp, changed",
            summarise(run_stream(service, scene->scene_id, home, k, settings.updates,
                                 settings.cutoff, nullptr, model::ReportMode::changed)));
      print(k, "moved+bp, nearest",
            summarise(run_stream(service, scene->scene_id, home, k, settings.updates,
                                 settings.cutoff, nullptr, model::ReportMode::nearest_per_object)));
      print(k, "moved+bp, global",
            summarise(run_stream(service, scene->scene_id, home, k, settings.updates,
                                 settings.cutoff, nullptr, model::ReportMode::global_minimum)));
      print(k, "bp only",
            summarise(
                run_queries(service, scene->scene_id, home, k, settings.updates, settings.cutoff)));
      print(k, "moved+bp, 1st", summarise({first}));
    }
    if (scene) (void)service.delete_scene(scene->scene_id);
  }
  return 0;
}
