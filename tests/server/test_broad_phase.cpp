// SPDX-License-Identifier: Apache-2.0
// Issue 22: the broad phase (world-frame boxes, sweep and prune) and "only moved objects cause
// work". Every check is against a brute-force reference: the boxes against the objects' vertices,
// the sweep against all boxes, pruned pairs against the engine run on every pair, and a stream
// that moves a few objects against a query that recomputes everything.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <future>
#include <limits>
#include <numbers>
#include <optional>
#include <random>
#include <set>
#include <tuple>

#include "broad_phase.hpp"
#include "incremental.hpp"
#include "nearpoint/distance.hpp"
#include "nearpoint/server/scene_service.hpp"
#include "validation.hpp"

namespace nearpoint::server {
namespace {

using namespace ::nearpoint::model;  // the scene model's types, unqualified in the tests

using Rng = std::mt19937_64;

double uniform(Rng& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

PoseInput random_pose(Rng& rng, const Vec3d& center, double spread) {
  PoseInput pose;
  std::normal_distribution<double> normal;
  Eigen::Quaterniond q(normal(rng), normal(rng), normal(rng), normal(rng));
  q.normalize();
  pose.rotation_wxyz = {q.w(), q.x(), q.y(), q.z()};
  pose.translation = center + Vec3d(uniform(rng, -spread, spread), uniform(rng, -spread, spread),
                                    uniform(rng, -spread, spread));
  return pose;
}

/// One of: box, sphere, capsule, random polytope, or a two-piece compound (box + offset sphere).
GeometryInput random_geometry(Rng& rng) {
  GeometryInput geometry;
  const int kind = std::uniform_int_distribution<int>(0, 4)(rng);
  PieceInput& piece = geometry.pieces.emplace_back();
  switch (kind) {
    case 0:
      piece.shape =
          Box<double>{Vec3d(uniform(rng, 0.1, 1), uniform(rng, 0.1, 1), uniform(rng, 0.1, 1))};
      break;
    case 1:
      piece.shape = Point{};
      piece.radius = uniform(rng, 0.1, 1);
      break;
    case 2:
      piece.shape =
          Segment<double>{Vec3d(-uniform(rng, 0.1, 1), 0, 0), Vec3d(uniform(rng, 0.1, 1), 0, 0)};
      piece.radius = uniform(rng, 0.05, 0.5);
      break;
    case 3: {
      PolytopeInput polytope;
      for (int i = 0; i < 12; ++i)
        polytope.vertices.emplace_back(uniform(rng, -1, 1), uniform(rng, -1, 1),
                                       uniform(rng, -0.5, 0.5));
      piece.shape = std::move(polytope);
      break;
    }
    default: {
      piece.shape = Box<double>{Vec3d(0.5, 0.2, 0.2)};
      PieceInput& second = geometry.pieces.emplace_back();
      second.shape = Point{};
      second.radius = 0.3;
      second.offset.translation = Vec3d(1.2, 0.3, 0);
      break;
    }
  }
  return geometry;
}

/// Every double of both reports, compared bit for bit (and every flag and count).
void expect_same_bits(const PairReport& a, const PairReport& b, const std::string& where) {
  auto same = [](const auto& x, const auto& y) { return std::memcmp(&x, &y, sizeof x) == 0; };
  EXPECT_EQ(a.object_a, b.object_a) << where;
  EXPECT_EQ(a.object_b, b.object_b) << where;
  EXPECT_EQ(a.status, b.status) << where;
  EXPECT_TRUE(same(a.distance, b.distance)) << where << ": " << a.distance << " vs " << b.distance;
  EXPECT_TRUE(same(a.distance_lower_bound, b.distance_lower_bound)) << where;
  EXPECT_TRUE(same(a.error_bound, b.error_bound)) << where;
  EXPECT_EQ(a.iterations, b.iterations) << where;
  EXPECT_EQ(a.piece_pairs_evaluated, b.piece_pairs_evaluated) << where;
  EXPECT_EQ(a.piece_a, b.piece_a) << where;
  EXPECT_EQ(a.piece_b, b.piece_b) << where;
  EXPECT_EQ(a.warm_started, b.warm_started) << where;
  EXPECT_EQ(a.has_near_points, b.has_near_points) << where;
  for (int k = 0; k < 3; ++k) {
    EXPECT_TRUE(same(a.point_a[k], b.point_a[k])) << where;
    EXPECT_TRUE(same(a.point_b[k], b.point_b[k])) << where;
    EXPECT_TRUE(same(a.normal[k], b.normal[k])) << where;
  }
}

Report run_query(SceneService& service, const QueryInput& query) {
  std::promise<Report> done;
  const Outcome started =
      service.query(query, Clock::now(), [&](Report report) { done.set_value(std::move(report)); });
  EXPECT_TRUE(started.ok()) << (started.ok() ? "" : started.error().describe());
  return done.get_future().get();
}

Report run_prepared(PoseStream& stream, PreparedUpdate prepared) {
  std::promise<Report> done;
  stream.evaluate(std::move(prepared), [&](Report report) { done.set_value(std::move(report)); });
  return done.get_future().get();
}

/// A random scene of `count` objects in a cube of side `side` centred at `center`.
struct RandomScene {
  SceneInput input;
  std::vector<PoseInput> poses;
};

RandomScene make_scene(SceneService& service, Rng& rng, std::size_t count, const Vec3d& center,
                       double side) {
  RandomScene scene;
  for (std::size_t i = 0; i < count; ++i) {
    Expected<GeometryInfo> info = service.register_geometry(random_geometry(rng));
    EXPECT_TRUE(info.ok());
    ObjectInput& object = scene.input.objects.emplace_back();
    object.id = "o" + std::to_string(i);
    object.geometry_id = info->geometry_id;
    object.pose = random_pose(rng, center, side / 2);
    scene.poses.push_back(object.pose);
  }
  return scene;
}

// ---- boxes and the sweep ----

// The margin of world_box is what makes pruning safe far from the origin: every vertex of every
// piece, placed in the world by the engine's own pose arithmetic, must lie inside the box.
TEST(BroadPhase, WorldBoxHoldsEveryVertexEvenFarFromTheOrigin) {
  Rng rng(7);
  const ServiceLimits limits;
  for (int trial = 0; trial < 400; ++trial) {
    GeometryInput input;
    PieceInput& piece = input.pieces.emplace_back();
    PolytopeInput polytope;
    for (int i = 0; i < 10; ++i)
      polytope.vertices.emplace_back(uniform(rng, -2, 2), uniform(rng, -2, 2), uniform(rng, -2, 2));
    piece.shape = polytope;
    piece.offset = random_pose(rng, Vec3d(0.5, -1, 2), 1);
    Expected<std::shared_ptr<StoredGeometry>> geometry = build_geometry(input, limits);
    ASSERT_TRUE(geometry.ok());
    const double offset = trial % 2 ? 1e6 : 0;
    Expected<Pose<double>> pose = check_pose(random_pose(rng, Vec3d::Constant(offset), 10), "pose");
    ASSERT_TRUE(pose.ok());
    const Aabb box = world_box(**geometry, *pose);
    const Pose<double> piece_pose = *check_pose(piece.offset, "offset");
    for (const Vec3d& v : polytope.vertices) {
      const Vec3d world = pose->apply(piece_pose.apply(v));
      for (int k = 0; k < 3; ++k) {
        EXPECT_LE(box.lo[k], world[k]) << "trial " << trial;
        EXPECT_GE(box.hi[k], world[k]) << "trial " << trial;
      }
    }
  }
}

// The sweep must find every box within the cutoff (a superset is allowed, a miss is not), also
// after boxes move (the insertion sort that keeps the order) and when they all move at once.
TEST(BroadPhase, SweepFindsEveryBoxWithinTheCutoff) {
  for (std::uint64_t seed = 0; seed < 20; ++seed) {
    Rng rng(seed);
    const std::size_t n = 200;
    const double offset = seed % 2 ? 1e6 : 0;
    auto random_box = [&] {
      Aabb box;
      const Vec3d center =
          Vec3d::Constant(offset) +
          Vec3d(uniform(rng, -20, 20), uniform(rng, -20, 20), uniform(rng, -20, 20));
      const Vec3d half(uniform(rng, 0, 2), uniform(rng, 0, 2), uniform(rng, 0, 2));
      box.lo = center - half;
      box.hi = center + half;
      return box;
    };
    SweepAndPrune sweep;
    sweep.reset(n);
    for (std::uint32_t i = 0; i < n; ++i) sweep.set(i, random_box());
    std::size_t near_total = 0;
    for (int round = 0; round < 6; ++round) {
      // Round 0: everything placed; rounds 1-4: a few boxes move; round 5: all move.
      const std::size_t moves = round == 0 ? 0 : round == 5 ? n : std::size_t(round * 3);
      for (std::size_t m = 0; m < moves; ++m)
        sweep.set(std::uint32_t(round == 5 ? m : rng() % n), random_box());
      sweep.sort();
      for (int q = 0; q < 20; ++q) {
        const Aabb query = random_box();
        const double cutoff = q == 0 ? 0.0 : uniform(rng, 0, 5);
        std::set<std::uint32_t> found;
        sweep.query(query, cutoff, [&](std::uint32_t j) { found.insert(j); });
        for (std::uint32_t j = 0; j < n; ++j) {
          if (box_gap(query, sweep.box(j)) > cutoff) continue;
          ++near_total;
          EXPECT_TRUE(found.count(j)) << "seed " << seed << " round " << round << " box " << j;
        }
      }
    }
    EXPECT_GT(near_total, 50u) << "seed " << seed << ": too few near boxes to test anything";
  }
}

// ---- pruning in the service ----

// A pair the broad phase prunes is one the engine proves beyond the cutoff too: its lower bound
// is at most the true distance and above the cutoff. Every pair that is not pruned is exactly what
// the engine returns for it alone (bit for bit). Random scenes, half of them 10⁶ m from the origin.
TEST(BroadPhase, PrunedPairsAreProvenBeyondTheCutoffAndTheRestAreExact) {
  std::size_t pruned_total = 0, evaluated_total = 0;
  for (std::uint64_t seed = 0; seed < 16; ++seed) {
    Rng rng(100 + seed);
    SceneService service(ServiceLimits{}, 1);
    const Vec3d center = Vec3d::Constant(seed % 2 ? 1e6 : 0);
    RandomScene scene = make_scene(service, rng, 30, center, 12);
    Expected<SceneInfo> info = service.create_scene(scene.input);
    ASSERT_TRUE(info.ok()) << info.error().describe();
    QueryInput query;
    query.scene_id = info->scene_id;
    query.options.distance_cutoff = uniform(rng, 0, 2);
    query.options.warm_start = false;
    const Report report = run_query(service, query);
    const SceneDefinition& definition = *report.scene;
    ASSERT_EQ(report.pairs.size(), definition.pairs.size());
    EXPECT_EQ(report.counts.pairs_evaluated + report.counts.pairs_pruned, report.pairs.size());
    EXPECT_EQ(report.counts.pairs_unmoved, 0u) << "a query has no previous report";

    const ResolvedOptions options =
        *resolve_options(definition.default_options, query.options, "options");
    DistanceOptions<double> unbounded = options.engine;
    unbounded.distance_cutoff = std::numeric_limits<double>::infinity();
    std::size_t pruned = 0;
    for (std::size_t p = 0; p < report.pairs.size(); ++p) {
      const PairReport& got = report.pairs[p];
      const SceneObject& a = definition.objects[got.object_a];
      const SceneObject& b = definition.objects[got.object_b];
      const std::string where = "seed " + std::to_string(seed) + " pair " + std::to_string(p);
      if (got.piece_pairs_evaluated == 0) {  // pruned: the engine never saw it
        ++pruned;
        const CompoundResult<double> truth =
            distance(a.geometry->compound, a.initial_pose, b.geometry->compound, b.initial_pose,
                     unbounded, std::span<SimplexCache>{});
        EXPECT_EQ(got.status, PairStatus::beyond_cutoff) << where;
        EXPECT_GT(got.distance_lower_bound, *query.options.distance_cutoff) << where;
        EXPECT_LE(got.distance_lower_bound,
                  truth.nearest.distance + truth.nearest.error_bound + 1e-9)
            << where;
        continue;
      }
      // Not pruned: exactly the engine's answer for this pair alone.
      const ScenePair& pair = definition.pairs[p];
      const CompoundResult<double> alone =
          distance(a.geometry->compound, a.initial_pose, b.geometry->compound, b.initial_pose,
                   options.engine, std::span<SimplexCache>{});
      EXPECT_EQ(got.object_a, pair.object_a);
      EXPECT_TRUE(std::memcmp(&got.error_bound, &alone.nearest.error_bound, sizeof(double)) == 0)
          << where;
      EXPECT_EQ(got.status == PairStatus::beyond_cutoff, alone.nearest.beyond_cutoff()) << where;
      if (got.status != PairStatus::beyond_cutoff) {
        EXPECT_TRUE(std::memcmp(&got.distance, &alone.nearest.distance, sizeof(double)) == 0)
            << where;
      }
    }
    EXPECT_EQ(pruned, report.counts.pairs_pruned);
    pruned_total += pruned;
    evaluated_total += report.counts.pairs_evaluated;
  }
  // The sample must exercise both sides (each seed has 435 pairs).
  EXPECT_GT(pruned_total, 16u * 435 / 5);
  EXPECT_GT(evaluated_total, 16u * 435 / 20);
}

// Two spheres exactly `cutoff` apart are within the cutoff: never pruned, whatever their distance
// from the origin and whichever axis separates them; a little farther apart, they are pruned.
TEST(BroadPhase, APairExactlyAtTheCutoffIsNeverPruned) {
  SceneService service(ServiceLimits{}, 1);
  GeometryInput sphere;
  sphere.pieces.emplace_back().shape = Point{};
  sphere.pieces.back().radius = 0.5;
  const std::string id = service.register_geometry(sphere)->geometry_id;
  const double cutoff = 0.25;  // every distance below is exact in binary
  int scene_number = 0;
  for (const double offset : {0.0, 1.0, 1e3, 1e6, -1e6}) {
    for (int axis = 0; axis < 3; ++axis) {
      for (const double extra : {0.0, 0.125}) {
        SceneInput scene;
        scene.requested_id = "s" + std::to_string(scene_number++);
        scene.objects.resize(2);
        scene.objects[0].id = "a";
        scene.objects[1].id = "b";
        scene.objects[0].geometry_id = scene.objects[1].geometry_id = id;
        scene.objects[0].pose.translation = Vec3d::Constant(offset);
        scene.objects[1].pose.translation = Vec3d::Constant(offset);
        scene.objects[1].pose.translation[axis] += 1.0 + cutoff + extra;
        ASSERT_TRUE(service.create_scene(scene).ok());
        QueryInput query;
        query.scene_id = scene.requested_id;
        query.options.distance_cutoff = cutoff;
        const Report report = run_query(service, query);
        ASSERT_EQ(report.pairs.size(), 1u);
        const std::string where =
            "offset " + std::to_string(offset) + " axis " + std::to_string(axis);
        if (extra == 0) {
          EXPECT_EQ(report.counts.pairs_pruned, 0u) << where;
          EXPECT_EQ(report.counts.pairs_evaluated, 1u) << where;
          EXPECT_NE(report.pairs[0].status, PairStatus::beyond_cutoff) << where;
        } else {
          EXPECT_EQ(report.counts.pairs_pruned, 1u) << where;
          EXPECT_EQ(report.pairs[0].status, PairStatus::beyond_cutoff) << where;
          EXPECT_GT(report.pairs[0].distance_lower_bound, cutoff) << where;
          EXPECT_LE(report.pairs[0].distance_lower_bound, cutoff + extra) << where;
        }
      }
    }
  }
}

// The same with rounding in play: a sphere off its geometry's origin, turned by a random rotation,
// at 2²⁰ m (where the spacing of doubles doubles), and its twin 1 + cutoff ± 1e-9 m away, so that
// the pair straddles the cutoff at the scale of the world-frame rounding. Truth: the centres'
// distance in long double. A pair within the cutoff must never be pruned (without the boxes'
// margin, the rounding of R·c + t prunes some of them).
TEST(BroadPhase, WithinTheCutoffAfterRoundingIsNeverPruned) {
  SceneService service(ServiceLimits{}, 1);
  GeometryInput sphere;
  sphere.pieces.emplace_back().shape = Point{};
  sphere.pieces.back().radius = 0.5;
  const Vec3d local_center(0.3, 0.7, 0.1);
  sphere.pieces.back().offset.translation = local_center;
  const std::string id = service.register_geometry(sphere)->geometry_id;
  SceneInput scene;
  scene.objects.resize(2);
  scene.objects[0].id = "a";
  scene.objects[1].id = "b";
  scene.objects[0].geometry_id = scene.objects[1].geometry_id = id;
  const std::string scene_id = service.create_scene(scene)->scene_id;
  Expected<std::unique_ptr<PoseStream>> stream = service.open_stream();
  ASSERT_TRUE(stream.ok());
  Rng rng(11);
  const double cutoff = 0.25;
  std::size_t within = 0;
  for (int update = 0; update < 4000; ++update) {
    PoseUpdateInput input;
    input.scene_id = scene_id;
    input.sequence = std::uint64_t(update) + 1;
    input.options.distance_cutoff = cutoff;
    PoseInput a = random_pose(rng, Vec3d::Constant(1048576.0), 1.5);
    PoseInput b = a;
    b.translation[update % 3] += 1.0 + cutoff + uniform(rng, -1e-9, 1e-9);
    input.poses = {{"a", a}, {"b", b}};
    Expected<PreparedUpdate> prepared = (*stream)->prepare(input, Clock::now());
    ASSERT_TRUE(prepared.ok());
    const Report report = run_prepared(**stream, std::move(*prepared));
    // The centres R·c + t of both, in long double (the poses exactly as the server holds them).
    const Pose<double> pose_a = *check_pose(a, "a");
    const Pose<double> pose_b = *check_pose(b, "b");
    long double gap_squared = 0;
    for (int k = 0; k < 3; ++k) {
      long double ca = pose_a.translation[k], cb = pose_b.translation[k];
      for (int j = 0; j < 3; ++j) {
        ca += static_cast<long double>(pose_a.rotation(k, j)) * local_center[j];
        cb += static_cast<long double>(pose_b.rotation(k, j)) * local_center[j];
      }
      gap_squared += (cb - ca) * (cb - ca);
    }
    const long double distance = std::sqrt(gap_squared) - 1.0L;
    if (distance > cutoff) continue;
    ++within;
    ASSERT_EQ(report.counts.pairs_pruned, 0u)
        << "update " << update << ": " << double(distance - cutoff) << " m within the cutoff";
  }
  EXPECT_GT(within, 1000u);  // the sample straddles the cutoff
}

// ---- only moved objects cause work ----

// A stream that moves a few objects per update (some updates resend an unchanged pose, some move
// nothing, some move everything, some change the options, some are coalesced) reports exactly,
// bit for bit, what a query recomputing every pair at the same poses reports; and it hands the
// engine only pairs that involve a moved object.
TEST(OnlyMovedObjects, StreamAnswersEqualRecomputingEverything) {
  for (std::uint64_t seed = 0; seed < 6; ++seed) {
    Rng rng(500 + seed);
    SceneService service(ServiceLimits{}, 2);
    const Vec3d center = Vec3d::Constant(seed % 3 == 2 ? 1e6 : 0);
    const std::size_t n = 24;
    RandomScene scene = make_scene(service, rng, n, center, 10);
    if (seed % 2) {  // half the scenes: some pairs excluded rather than all selected
      scene.input.pair_selection.mode = PairSelectionInput::Mode::excluded_pairs;
      for (int k = 0; k < 40; ++k) {
        const std::size_t a = rng() % n, b = rng() % n;
        if (a != b)
          scene.input.pair_selection.pairs.emplace_back(scene.input.objects[a].id,
                                                        scene.input.objects[b].id);
      }
    }
    Expected<SceneInfo> info = service.create_scene(scene.input);
    ASSERT_TRUE(info.ok()) << info.error().describe();
    Expected<std::unique_ptr<PoseStream>> stream = service.open_stream();
    ASSERT_TRUE(stream.ok());

    QueryOptionsInput options;
    options.warm_start = false;  // bit-for-bit comparisons need the same (cold) start
    options.near_points = true;
    const bool finite_cutoff = seed % 3 != 0;
    if (finite_cutoff) options.distance_cutoff = 1.0;

    std::vector<PoseInput> poses = scene.poses;
    std::uint64_t sequence = 0;
    std::size_t unmoved_total = 0;
    bool options_changed_before = false;
    for (int update = 0; update < 25; ++update) {
      // Which objects move: none, all, or a random few (plus an unchanged pose resent).
      std::vector<char> moved(n, 0);
      PoseUpdateInput input;
      input.scene_id = info->scene_id;
      const std::size_t k = update == 3 ? 0 : update == 7 ? n : 1 + rng() % 4;
      for (std::size_t m = 0; m < k; ++m) {
        const std::size_t i = k == n ? m : rng() % n;
        if (moved[i]) continue;
        moved[i] = 1;
        poses[i] = random_pose(rng, center, 5);
        input.poses.push_back({scene.input.objects[i].id, poses[i]});
      }
      const std::size_t resent = rng() % n;
      if (!moved[resent]) input.poses.push_back({scene.input.objects[resent].id, poses[resent]});
      const bool options_change = update == 12;
      input.options = options;
      if (options_change) input.options.epsilon = 1e-10;

      Report report;
      if (update % 5 == 4 && k < n) {
        // Coalesced: an earlier update (moving one more object) folded into this one; the
        // merged report must still cover what the earlier one moved.
        PoseUpdateInput earlier;
        earlier.scene_id = info->scene_id;
        earlier.options = input.options;
        earlier.sequence = ++sequence;
        const std::size_t i = rng() % n;
        if (!moved[i]) {
          moved[i] = 1;
          poses[i] = random_pose(rng, center, 5);
          earlier.poses.push_back({scene.input.objects[i].id, poses[i]});
        }
        Expected<PreparedUpdate> older = (*stream)->prepare(earlier, Clock::now());
        ASSERT_TRUE(older.ok());
        input.sequence = ++sequence;
        Expected<PreparedUpdate> newer = (*stream)->prepare(input, Clock::now());
        ASSERT_TRUE(newer.ok());
        PoseStream::coalesce(*newer, *older);
        report = run_prepared(**stream, std::move(*newer));
        EXPECT_EQ(report.coalesced_updates, 1u);
      } else {
        input.sequence = ++sequence;
        Expected<PreparedUpdate> prepared = (*stream)->prepare(input, Clock::now());
        ASSERT_TRUE(prepared.ok());
        report = run_prepared(**stream, std::move(*prepared));
      }

      QueryInput query;
      query.scene_id = info->scene_id;
      query.options = input.options;
      for (std::size_t i = 0; i < n; ++i)
        query.poses.push_back({scene.input.objects[i].id, poses[i]});
      const Report reference = run_query(service, query);
      ASSERT_EQ(report.pairs.size(), reference.pairs.size());
      const std::string where =
          "seed " + std::to_string(seed) + " update " + std::to_string(update);
      for (std::size_t p = 0; p < report.pairs.size(); ++p)
        expect_same_bits(report.pairs[p], reference.pairs[p], where + " pair " + std::to_string(p));

      // The counts: every pair of two unmoved objects is skipped, unless the options changed
      // (then nothing is reused) or this is the stream's first report.
      std::size_t both_unmoved = 0;
      for (const ScenePair& pair : report.scene->pairs)
        both_unmoved += !moved[pair.object_a] && !moved[pair.object_b];
      const std::size_t expected_unmoved =
          (update == 0 || options_change || options_changed_before) ? 0 : both_unmoved;
      EXPECT_EQ(report.counts.pairs_unmoved, expected_unmoved) << where;
      EXPECT_EQ(
          report.counts.pairs_evaluated + report.counts.pairs_pruned + report.counts.pairs_unmoved,
          report.pairs.size())
          << where;
      if (!finite_cutoff) {
        EXPECT_EQ(report.counts.pairs_pruned, 0u) << where;
      }
      unmoved_total += report.counts.pairs_unmoved;
      // Options changed for one update only: the next one changes them back (all recomputed).
      options_changed_before = options_change;
    }
    EXPECT_GT(unmoved_total, 0u) << "seed " << seed;
  }
}

}  // namespace
}  // namespace nearpoint::server

namespace nearpoint::server {
namespace {

using namespace ::nearpoint::model;  // the scene model's types, unqualified in the tests

// ---- report modes ----

// REPORT_MODE_WITHIN_CUTOFF is the all-pairs report less its BEYOND_CUTOFF pairs, in the same
// order, bit for bit, update after update while objects move in and out of range (the stream
// keeps its list of near pairs as results change). Switching a stream's mode recomputes nothing.
// A scene's default mode applies to queries.
TEST(ReportModes, WithinCutoffIsAllPairsLessThoseBeyondIt) {
  for (std::uint64_t seed = 0; seed < 4; ++seed) {
    Rng rng(900 + seed);
    SceneService service(ServiceLimits{}, 2);
    const Vec3d center = Vec3d::Constant(seed % 2 ? 1e6 : 0);
    const std::size_t n = 30;
    RandomScene scene = make_scene(service, rng, n, center, 12);
    Expected<SceneInfo> info = service.create_scene(scene.input);
    ASSERT_TRUE(info.ok());
    std::unique_ptr<PoseStream> all = std::move(service.open_stream().value());
    std::unique_ptr<PoseStream> near = std::move(service.open_stream().value());
    QueryOptionsInput options;
    options.warm_start = false;
    options.distance_cutoff = 0.75;
    std::vector<PoseInput> poses = scene.poses;
    std::size_t near_total = 0, beyond_total = 0;
    for (int update = 0; update < 30; ++update) {
      PoseUpdateInput input;
      input.scene_id = info->scene_id;
      input.sequence = std::uint64_t(update) + 1;
      input.options = options;
      for (std::size_t m = 0, k = 1 + rng() % 5; m < k; ++m) {
        const std::size_t i = rng() % n;
        bool listed = false;
        for (const ObjectPoseInput& pose : input.poses)
          listed |= pose.object_id == "o" + std::to_string(i);
        if (listed) continue;
        poses[i] = random_pose(rng, center, 6);
        input.poses.push_back({scene.input.objects[i].id, poses[i]});
      }
      const Report expected = run_prepared(*all, *all->prepare(input, Clock::now()));
      // The near stream switches to all pairs for a few updates and back.
      const bool switched = update >= 20 && update < 23;
      input.options.report_mode = switched ? ReportMode::all_pairs : ReportMode::within_cutoff;
      const Report got = run_prepared(*near, *near->prepare(input, Clock::now()));
      const std::string where =
          "seed " + std::to_string(seed) + " update " + std::to_string(update);
      EXPECT_EQ(expected.mode, ReportMode::all_pairs);
      EXPECT_EQ(got.mode, switched ? ReportMode::all_pairs : ReportMode::within_cutoff) << where;
      EXPECT_EQ(got.counts.pairs_evaluated, expected.counts.pairs_evaluated) << where;
      EXPECT_EQ(got.counts.pairs_pruned, expected.counts.pairs_pruned) << where;
      EXPECT_EQ(got.counts.pairs_unmoved, expected.counts.pairs_unmoved) << where;
      std::vector<const PairReport*> filtered;
      for (const PairReport& pair : expected.pairs)
        if (switched || within_cutoff(pair, 0.75)) filtered.push_back(&pair);
      ASSERT_EQ(got.pairs.size(), filtered.size()) << where;
      for (std::size_t j = 0; j < filtered.size(); ++j)
        expect_same_bits(got.pairs[j], *filtered[j], where + " entry " + std::to_string(j));
      near_total += filtered.size();
      beyond_total += expected.pairs.size() - filtered.size();
    }
    // Both sides of the cutoff occur.
    EXPECT_GT(near_total, 30u) << "seed " << seed;
    EXPECT_GT(beyond_total, 30u * 100) << "seed " << seed;

    // The scene's default mode applies to a query that does not choose one.
    SceneInput defaults = scene.input;
    defaults.default_options.report_mode = ReportMode::within_cutoff;
    defaults.default_options.distance_cutoff = 0.75;
    Expected<SceneInfo> near_scene = service.create_scene(defaults);
    ASSERT_TRUE(near_scene.ok());
    QueryInput query;
    query.scene_id = near_scene->scene_id;
    const Report report = run_query(service, query);
    EXPECT_EQ(report.mode, ReportMode::within_cutoff);
    for (const PairReport& pair : report.pairs) {
      EXPECT_NE(pair.status, PairStatus::beyond_cutoff);
      if (pair.status == PairStatus::separated) {
        EXPECT_LE(pair.distance, 0.75);
      }
    }
    EXPECT_LT(report.pairs.size(), report.scene->pairs.size());
  }
}

// ---- nearest per object, global minimum, changed: each against a brute-force reference ----

/// The reference: a unary query in all-pairs mode with warm starts off, which runs every pair
/// not pruned from scratch (a fresh state), at `poses`.
Report recompute_all(SceneService& service, const std::string& scene_id,
                     const std::vector<PoseInput>& poses, const SceneInput& scene, double cutoff) {
  QueryInput query;
  query.scene_id = scene_id;
  query.options.warm_start = false;
  query.options.distance_cutoff = cutoff;
  query.options.report_mode = ReportMode::all_pairs;
  for (std::size_t i = 0; i < poses.size(); ++i)
    query.poses.push_back({scene.objects[i].id, poses[i]});
  return run_query(service, query);
}

/// Brute force over every pair: may `pair` be a nearest pair (what within_cutoff reports), and
/// how near is it (written out again here rather than calling nearness()).
bool candidate(const PairReport& pair, double cutoff) {
  if (pair.status == PairStatus::beyond_cutoff) return false;
  return !(pair.status == PairStatus::separated && pair.distance > cutoff);
}
double how_near(const PairReport& pair) {
  return model::in_contact(pair.status) || pair.status == PairStatus::engine_error ? 0.0
                                                                                   : pair.distance;
}

/// Moves 1-5 random objects in `poses` and lists them in `input`.
void move_some(Rng& rng, const RandomScene& scene, const Vec3d& center, double spread,
               std::vector<PoseInput>& poses, PoseUpdateInput& input) {
  const std::size_t n = poses.size();
  for (std::size_t m = 0, k = 1 + rng() % 5; m < k; ++m) {
    const std::size_t i = rng() % n;
    bool listed = false;
    for (const ObjectPoseInput& pose : input.poses)
      listed |= pose.object_id == scene.input.objects[i].id;
    if (listed) continue;
    poses[i] = random_pose(rng, center, spread);
    input.poses.push_back({scene.input.objects[i].id, poses[i]});
  }
}

// NEAREST_PER_OBJECT and GLOBAL_MINIMUM, from streams that move a few objects per update (so
// most results are reused and many pairs pruned), against a recompute of every pair searched by
// brute force: per object the nearest candidate (ties: the earlier pair), each pair once, in the
// scene's order; and the single nearest. An object with no pair within the cutoff has no entry.
TEST(ReportModes, NearestPerObjectAndGlobalMinimumMatchBruteForce) {
  for (std::uint64_t seed = 0; seed < 4; ++seed) {
    Rng rng(1300 + seed);
    SceneService service(ServiceLimits{}, 2);
    const Vec3d center = Vec3d::Constant(seed % 2 ? 1e6 : 0);
    const std::size_t n = 30;
    const double cutoff = seed == 3 ? std::numeric_limits<double>::infinity() : 0.75;
    RandomScene scene = make_scene(service, rng, n, center, 12);
    Expected<SceneInfo> info = service.create_scene(scene.input);
    ASSERT_TRUE(info.ok());
    std::unique_ptr<PoseStream> nearest = std::move(service.open_stream().value());
    std::unique_ptr<PoseStream> global = std::move(service.open_stream().value());
    std::vector<PoseInput> poses = scene.poses;
    std::size_t lonely = 0, reported = 0, empty_global = 0;
    for (int update = 0; update < 30; ++update) {
      PoseUpdateInput input;
      input.scene_id = info->scene_id;
      input.sequence = std::uint64_t(update) + 1;
      input.options.warm_start = false;
      input.options.distance_cutoff = cutoff;
      move_some(rng, scene, center, 6, poses, input);
      input.options.report_mode = ReportMode::nearest_per_object;
      const Report got = run_prepared(*nearest, *nearest->prepare(input, Clock::now()));
      input.options.report_mode = ReportMode::global_minimum;
      const Report got_global = run_prepared(*global, *global->prepare(input, Clock::now()));
      const Report all = recompute_all(service, info->scene_id, poses, scene.input, cutoff);
      const std::string where =
          "seed " + std::to_string(seed) + " update " + std::to_string(update);
      EXPECT_EQ(got.mode, ReportMode::nearest_per_object) << where;
      EXPECT_EQ(got_global.mode, ReportMode::global_minimum) << where;

      std::set<std::size_t> expected;  // pair indices
      for (std::size_t object = 0; object < n; ++object) {
        std::size_t best = all.pairs.size();
        for (std::size_t p = 0; p < all.pairs.size(); ++p) {
          const PairReport& pair = all.pairs[p];
          if ((pair.object_a != object && pair.object_b != object) || !candidate(pair, cutoff))
            continue;
          if (best == all.pairs.size() || how_near(pair) < how_near(all.pairs[best])) best = p;
        }
        if (best == all.pairs.size())
          ++lonely;
        else
          expected.insert(best);
      }
      ASSERT_EQ(got.pairs.size(), expected.size()) << where;
      std::size_t j = 0;
      for (const std::size_t p : expected)
        expect_same_bits(got.pairs[j++], all.pairs[p], where + " pair " + std::to_string(p));
      reported += expected.size();

      std::size_t best = all.pairs.size();
      for (std::size_t p = 0; p < all.pairs.size(); ++p)
        if (candidate(all.pairs[p], cutoff) &&
            (best == all.pairs.size() || how_near(all.pairs[p]) < how_near(all.pairs[best])))
          best = p;
      if (best == all.pairs.size()) {
        EXPECT_TRUE(got_global.pairs.empty()) << where;
        ++empty_global;
      } else {
        ASSERT_EQ(got_global.pairs.size(), 1u) << where;
        expect_same_bits(got_global.pairs[0], all.pairs[best], where + " global");
      }
    }
    // The modes select something, and (with a cutoff) some objects have no near pair at all.
    EXPECT_GT(reported, 30u) << "seed " << seed;
    if (std::isfinite(cutoff)) {
      EXPECT_GT(lonely, 0u) << "seed " << seed;
    } else {
      EXPECT_EQ(lonely, 0u) << "seed " << seed;
      EXPECT_EQ(empty_global, 0u) << "seed " << seed;
    }
  }
}

// CHANGED: across a sequence of updates (some coalesced, one switched to another mode), each
// report holds exactly the pairs whose status differs from, or whose distance moved more than
// change_tolerance from, what the stream last reported for that pair; the baseline kept here by
// brute force from a recompute of every pair. The first report, and the first after another
// mode's, carries every pair. A coalesced update reports what changed since the last report sent,
// including changes made by the updates it absorbed.
TEST(ReportModes, ChangedReportsWhatChangedSinceTheLastReportSent) {
  for (std::uint64_t seed = 0; seed < 4; ++seed) {
    Rng rng(1700 + seed);
    SceneService service(ServiceLimits{}, 2);
    const Vec3d center = Vec3d::Constant(seed % 2 ? 1e6 : 0);
    const std::size_t n = 25;
    // Without a cutoff every pair carries a distance, so drift below the tolerance is exercised.
    const double cutoff = seed < 2 ? std::numeric_limits<double>::infinity() : 1.0;
    const double tolerance = seed == 2 ? 0.0 : 0.05;
    RandomScene scene = make_scene(service, rng, n, center, 10);
    Expected<SceneInfo> info = service.create_scene(scene.input);
    ASSERT_TRUE(info.ok());
    std::unique_ptr<PoseStream> stream = std::move(service.open_stream().value());
    std::vector<PoseInput> poses = scene.poses;
    std::vector<PairStatus> sent_status;
    std::vector<double> sent_distance;
    bool baseline = false;
    std::size_t partial_reports = 0, coalesced_reports = 0;
    std::uint64_t sequence = 0;
    for (int update = 0; update < 30; ++update) {
      const std::string where =
          "seed " + std::to_string(seed) + " update " + std::to_string(update);
      const bool other_mode = update == 15;
      // Every fourth report merges three updates, as FLOW_CONTROL_COALESCE does; the earlier
      // ones may move objects the last one does not.
      const int merged = update % 4 == 3 ? 3 : 1;
      std::optional<PreparedUpdate> prepared;
      for (int m = 0; m < merged; ++m) {
        PoseUpdateInput input;
        input.scene_id = info->scene_id;
        input.sequence = ++sequence;
        input.options.warm_start = false;
        input.options.distance_cutoff = cutoff;
        input.options.change_tolerance = tolerance;
        input.options.report_mode = other_mode ? ReportMode::all_pairs : ReportMode::changed;
        // Small moves (some objects barely move): some pairs change band, some do not.
        // Small moves go to three objects only, so that their drift adds up over reports: a
        // pair is reported once it moved more than the tolerance from what was last sent.
        const double spread = update % 3 == 0 ? 5 : 0.02;
        const std::size_t i = spread < 1 ? rng() % 3 : rng() % n;
        if (spread < 1) {
          poses[i].translation +=
              Vec3d(uniform(rng, -spread, spread), uniform(rng, -spread, spread),
                    uniform(rng, -spread, spread));
        } else {
          poses[i] = random_pose(rng, center, spread);
        }
        input.poses.push_back({scene.input.objects[i].id, poses[i]});
        Expected<PreparedUpdate> next = stream->prepare(input, Clock::now());
        ASSERT_TRUE(next.ok()) << where;
        if (prepared) PoseStream::coalesce(*next, *prepared);
        prepared = std::move(next.value());
      }
      const Report got = run_prepared(*stream, std::move(*prepared));
      const Report all = recompute_all(service, info->scene_id, poses, scene.input, cutoff);
      EXPECT_EQ(got.coalesced_updates, std::uint32_t(merged - 1)) << where;
      if (other_mode) {
        EXPECT_EQ(got.mode, ReportMode::all_pairs) << where;
        EXPECT_EQ(got.pairs.size(), all.pairs.size()) << where;
        baseline = false;
        continue;
      }
      EXPECT_EQ(got.mode, ReportMode::changed) << where;
      if (!baseline) {
        sent_status.assign(all.pairs.size(), PairStatus::engine_error);
        sent_distance.assign(all.pairs.size(), 0);
      }
      std::vector<std::size_t> expected;
      for (std::size_t p = 0; p < all.pairs.size(); ++p) {
        const PairReport& pair = all.pairs[p];
        bool changed = !baseline || pair.status != sent_status[p];
        if (!changed && pair.status != PairStatus::beyond_cutoff)
          changed = std::abs(pair.distance - sent_distance[p]) > tolerance;
        if (!changed) continue;
        expected.push_back(p);
        sent_status[p] = pair.status;
        sent_distance[p] = pair.distance;
      }
      if (!baseline || update == 16) {
        EXPECT_EQ(expected.size(), all.pairs.size()) << where;
      }
      baseline = true;
      ASSERT_EQ(got.pairs.size(), expected.size()) << where;
      for (std::size_t j = 0; j < expected.size(); ++j) {
        const PairReport& want = all.pairs[expected[j]];
        if (want.status == PairStatus::beyond_cutoff) {
          // The lower bound depends on which update pruned the pair, not on the pose alone.
          EXPECT_EQ(got.pairs[j].object_a, want.object_a) << where;
          EXPECT_EQ(got.pairs[j].object_b, want.object_b) << where;
          EXPECT_EQ(got.pairs[j].status, want.status) << where;
        } else {
          expect_same_bits(got.pairs[j], want, where + " pair " + std::to_string(expected[j]));
        }
      }
      if (!expected.empty() && expected.size() < all.pairs.size()) ++partial_reports;
      if (merged > 1 && !expected.empty()) ++coalesced_reports;
    }
    // The mode did filter, and coalesced reports did carry changes.
    EXPECT_GT(partial_reports, 4u) << "seed " << seed;
    EXPECT_GT(coalesced_reports, 0u) << "seed " << seed;
  }
}

// A negative or NaN change tolerance is refused, naming the field.
TEST(ReportModes, ABadChangeToleranceIsRefusedNamingTheField) {
  for (const double bad : {-0.1, std::numeric_limits<double>::quiet_NaN()}) {
    QueryOptionsInput options;
    options.change_tolerance = bad;
    Expected<ResolvedOptions> resolved = resolve_options(ResolvedOptions{}, options, "options");
    ASSERT_FALSE(resolved.ok());
    EXPECT_EQ(resolved.error().field, "options.change_tolerance");
  }
  QueryOptionsInput inf;
  inf.change_tolerance = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(resolve_options(ResolvedOptions{}, inf, "options").ok());
}

TEST(ReportModes, AnUnknownModeIsRefusedNamingTheField) {
  QueryOptionsInput options;
  options.report_mode = ReportMode::unknown;
  Expected<ResolvedOptions> resolved = resolve_options(ResolvedOptions{}, options, "options");
  ASSERT_FALSE(resolved.ok());
  EXPECT_EQ(resolved.error().field, "options.report_mode");
  EXPECT_EQ(resolved.error().code, ErrorCode::invalid_argument);
}

// ---- watched pairs: thresholds and events ----

// Events against a brute-force reference: every update (absorbed ones included) recomputed for
// every pair by a cold query, and a reference flag per (pair, threshold) driven by the rule
// "ENTER below distance, EXIT above distance + hysteresis". The stream must report exactly the
// reference's crossings, each once, with the sequence of the update that caused it, also when
// three updates are merged into one (as FLOW_CONTROL_COALESCE does): a merged report replays the
// poses of the updates it absorbed. Without the replay, crossings inside absorbed updates (an
// ENTER then an EXIT) would be lost; without hysteresis, pairs in the band would fire again.
TEST(Thresholds, EventsMatchABruteForceReferenceThroughCoalescedUpdates) {
  std::size_t enters = 0, exits = 0, absorbed_events = 0, band_holds = 0;
  for (std::uint64_t seed = 0; seed < 4; ++seed) {
    Rng rng(2200 + seed);
    SceneService service(ServiceLimits{}, 2);
    const Vec3d center = Vec3d::Constant(seed % 2 ? 1e6 : 0);
    const std::size_t n = 14;
    const double cutoff = seed < 2 ? std::numeric_limits<double>::infinity() : 1.5;
    RandomScene scene = make_scene(service, rng, n, center, 5);
    for (std::size_t i = 0; i < n; ++i) scene.input.objects[i].group = i % 4 == 0 ? 2u : 1u;
    Expected<SceneInfo> info = service.create_scene(scene.input);
    ASSERT_TRUE(info.ok());

    std::vector<ThresholdInput> thresholds(4);
    thresholds[0] = {"pair", 0.8, 0.2, "o0", "o1", 0};
    thresholds[1] = {"object", 0.5, 0.1, "o2", "", 0};
    thresholds[2] = {"group", 0.3, 0.3, "", "", 2};
    thresholds[3] = {"all", 0.2, 0.0, "", "", 0};
    // The reference's idea of what each threshold watches, written out from the rule.
    const Report first = recompute_all(service, info->scene_id, scene.poses, scene.input, cutoff);
    const std::size_t pairs = first.pairs.size();
    auto group = [&](std::uint32_t o) { return scene.input.objects[o].group.value_or(1); };
    auto watches = [&](std::size_t p, std::size_t t) {
      const PairReport& pair = first.pairs[p];
      const std::uint32_t a = pair.object_a, b = pair.object_b;
      switch (t) {
        case 0:
          return (a == 0 && b == 1) || (a == 1 && b == 0);
        case 1:
          return a == 2 || b == 2;
        case 2:
          return (group(a) & 2u) != 0 || (group(b) & 2u) != 0;
        default:
          return true;
      }
    };
    std::vector<std::vector<char>> inside(pairs, std::vector<char>(4, 0));

    std::unique_ptr<PoseStream> stream = std::move(service.open_stream().value());
    std::vector<PoseInput> poses = scene.poses;
    std::uint64_t sequence = 0;
    for (int report = 0; report < 40; ++report) {
      const std::string where =
          "seed " + std::to_string(seed) + " report " + std::to_string(report);
      const int merged = report % 3 == 2 ? 3 : 1;
      std::optional<PreparedUpdate> prepared;
      std::vector<std::tuple<std::uint64_t, std::uint32_t, std::uint32_t, Crossing>> expected;
      for (int m = 0; m < merged; ++m) {
        PoseUpdateInput input;
        input.scene_id = info->scene_id;
        input.sequence = ++sequence;
        input.options.warm_start = false;
        input.options.distance_cutoff = cutoff;
        if (sequence == 1) input.thresholds = thresholds;
        // A random walk of two objects, the watched o0..o2 often among them, so that pairs come
        // and go across the thresholds and through the hysteresis band.
        for (int k = 0; k < 2; ++k) {
          const std::size_t i = k == 0 ? rng() % 3 : 3 + rng() % (n - 3);
          poses[i].translation +=
              Vec3d(uniform(rng, -0.4, 0.4), uniform(rng, -0.4, 0.4), uniform(rng, -0.4, 0.4));
          poses[i].translation =
              center + (poses[i].translation - center).cwiseMax(-2.5).cwiseMin(2.5);
          bool listed = false;
          for (ObjectPoseInput& pose : input.poses)
            if (pose.object_id == scene.input.objects[i].id) pose.pose = poses[i], listed = true;
          if (!listed) input.poses.push_back({scene.input.objects[i].id, poses[i]});
        }
        Expected<PreparedUpdate> next = stream->prepare(input, Clock::now());
        ASSERT_TRUE(next.ok()) << where << ": " << next.error().describe();
        if (prepared) PoseStream::coalesce(*next, *prepared);
        prepared = std::move(next.value());

        const Report all = recompute_all(service, info->scene_id, poses, scene.input, cutoff);
        for (std::size_t p = 0; p < pairs; ++p) {
          const PairReport& pair = all.pairs[p];
          const double d = model::in_contact(pair.status)             ? 0.0
                           : pair.status == PairStatus::beyond_cutoff ? pair.distance_lower_bound
                                                                      : pair.distance;
          for (std::size_t t = 0; t < 4; ++t) {
            if (!watches(p, t)) continue;
            const double enter = thresholds[t].distance;
            const double exit = enter + thresholds[t].hysteresis;
            if (!inside[p][t] && d < enter) {
              inside[p][t] = 1;
              expected.emplace_back(sequence, std::uint32_t(p), std::uint32_t(t), Crossing::enter);
            } else if (inside[p][t] && d > exit) {
              inside[p][t] = 0;
              expected.emplace_back(sequence, std::uint32_t(p), std::uint32_t(t), Crossing::exit);
            } else if (inside[p][t] && d >= enter) {
              ++band_holds;  // no EXIT thanks to the hysteresis
            }
          }
        }
      }
      const Report got = run_prepared(*stream, std::move(*prepared));
      ASSERT_EQ(got.sequence, sequence) << where;
      ASSERT_EQ(got.events.size(), expected.size()) << where;
      ASSERT_TRUE(got.threshold_names) << where;
      for (std::size_t e = 0; e < expected.size(); ++e) {
        const ThresholdEvent& event = got.events[e];
        const auto& [want_sequence, want_pair, want_threshold, want_crossing] = expected[e];
        EXPECT_EQ(event.sequence, want_sequence) << where;
        EXPECT_EQ(event.pair, want_pair) << where;
        EXPECT_EQ(event.threshold, want_threshold) << where;
        EXPECT_EQ(event.crossing, want_crossing) << where;
        EXPECT_EQ(event.object_a, first.pairs[want_pair].object_a) << where;
        EXPECT_EQ(event.object_b, first.pairs[want_pair].object_b) << where;
        EXPECT_EQ((*got.threshold_names)[event.threshold], thresholds[want_threshold].name);
        (event.crossing == Crossing::enter ? enters : exits)++;
        if (event.sequence < got.sequence) ++absorbed_events;
      }
    }
  }
  // The sample crossed thresholds both ways, inside merged updates too, and sat in the band.
  EXPECT_GT(enters, 20u);
  EXPECT_GT(exits, 20u);
  EXPECT_GT(absorbed_events, 5u);
  EXPECT_GT(band_holds, 5u);
}

// Thresholds are checked when the stream's first update names them, each error naming its
// field; later updates cannot rename them, nor lower the cutoff below an exit distance (a pair
// beyond the cutoff has no distance to compare).
TEST(Thresholds, BadThresholdsAreRefusedNamingTheField) {
  Rng rng(77);
  SceneService service(ServiceLimits{}, 1);
  RandomScene scene = make_scene(service, rng, 4, Vec3d::Zero(), 4);
  scene.input.pair_selection.mode = PairSelectionInput::Mode::excluded_pairs;
  scene.input.pair_selection.pairs = {{"o2", "o3"}};
  Expected<SceneInfo> info = service.create_scene(scene.input);
  ASSERT_TRUE(info.ok());
  struct Case {
    ThresholdInput threshold;
    double cutoff;
    const char* field;
    ErrorCode code;
  };
  const double inf = std::numeric_limits<double>::infinity();
  const Case cases[] = {
      {{"", 0.0, 0, "", "", 0}, inf, "thresholds[0].distance", ErrorCode::invalid_argument},
      {{"", 0.1, -1, "", "", 0}, inf, "thresholds[0].hysteresis", ErrorCode::invalid_argument},
      {{"", 0.1, 0, "nope", "", 0}, inf, "thresholds[0].object_a", ErrorCode::not_found},
      {{"", 0.1, 0, "", "o1", 0}, inf, "thresholds[0].object_b", ErrorCode::invalid_argument},
      {{"", 0.1, 0, "o2", "o3", 0}, inf, "thresholds[0]", ErrorCode::invalid_argument},
      {{"", 0.1, 0, "", "", 8}, inf, "thresholds[0]", ErrorCode::invalid_argument},
      {{"", 0.5, 0.5, "o0", "", 0}, 0.9, "options.distance_cutoff", ErrorCode::invalid_argument},
  };
  for (const Case& c : cases) {
    std::unique_ptr<PoseStream> stream = std::move(service.open_stream().value());
    PoseUpdateInput input;
    input.scene_id = info->scene_id;
    input.sequence = 1;
    input.options.distance_cutoff = c.cutoff;
    input.thresholds = {c.threshold};
    Expected<PreparedUpdate> prepared = stream->prepare(input, Clock::now());
    ASSERT_FALSE(prepared.ok()) << c.field;
    EXPECT_EQ(prepared.error().field, c.field);
    EXPECT_EQ(prepared.error().code, c.code) << c.field;
    // The stream is still unbound: a good first update is accepted.
    input.thresholds = {{"ok", 0.5, 0.5, "o0", "o1", 0}};
    input.options.distance_cutoff = 1.0;
    ASSERT_TRUE(stream->prepare(input, Clock::now()).ok()) << c.field;
    input.sequence = 2;
    Expected<PreparedUpdate> again = stream->prepare(input, Clock::now());
    ASSERT_FALSE(again.ok());
    EXPECT_EQ(again.error().field, "thresholds");
    input.thresholds.clear();
    input.options.distance_cutoff = 0.5;
    Expected<PreparedUpdate> lower = stream->prepare(input, Clock::now());
    ASSERT_FALSE(lower.ok());
    EXPECT_EQ(lower.error().field, "options.distance_cutoff");
  }
}

// A stream whose thresholds' events could not fit in one report beside its pairs is refused at
// its first update, naming the thresholds and the limit, rather than answered with reports that
// could never be sent.
TEST(Thresholds, EventsThatCouldNotFitInAReportAreRefused) {
  Rng rng(78);
  ServiceLimits limits;
  SceneService probe(limits, 1);
  RandomScene scene = make_scene(probe, rng, 30, Vec3d::Zero(), 4);  // 435 pairs
  std::vector<ThresholdInput> thresholds;
  for (int t = 0; t < 3; ++t)
    thresholds.push_back({std::string(200, 'n'), 0.1 * (t + 1), 0, "", "", 0});
  for (const std::size_t limit : {std::size_t(60000), std::size_t(1000000)}) {
    limits.max_report_bytes = limit;
    SceneService service(limits, 1);
    for (ObjectInput& object : scene.input.objects) {
      Rng again(78);
      object.geometry_id = service.register_geometry(random_geometry(again))->geometry_id;
    }
    Expected<SceneInfo> info = service.create_scene(scene.input);
    ASSERT_TRUE(info.ok()) << info.error().describe();
    std::unique_ptr<PoseStream> stream = std::move(service.open_stream().value());
    PoseUpdateInput input;
    input.scene_id = info->scene_id;
    input.sequence = 1;
    input.thresholds = thresholds;
    Expected<PreparedUpdate> prepared = stream->prepare(input, Clock::now());
    if (limit < 1000000) {
      // 3 × 435 events of ~230 bytes: ~300 kB, beyond 60 kB.
      ASSERT_FALSE(prepared.ok());
      EXPECT_EQ(prepared.error().code, ErrorCode::resource_exhausted);
      EXPECT_EQ(prepared.error().field, "thresholds");
      EXPECT_NE(prepared.error().message.find("--max-message-bytes"), std::string::npos);
    } else {
      ASSERT_TRUE(prepared.ok()) << prepared.error().describe();
      EXPECT_GE(prepared->replay_limit, 1u);  // room for a few absorbed updates' events
    }
  }
}

// A scene's default thresholds (CreateSceneRequest.thresholds) are watched by every stream whose
// first update names none (how DDS and ROS 2 clients of a preloaded scene get events); a stream
// naming its own watches only those. Checked at creation like a stream's, with the scene's
// default cutoff and fields named from the request.
TEST(Thresholds, ASceneDefaultIsWatchedByStreamsThatNameNone) {
  SceneService service(ServiceLimits{}, 1);
  GeometryInput ball;
  ball.pieces.emplace_back().shape = Point{};
  ball.pieces.back().radius = 0.5;
  const std::string geometry = service.register_geometry(ball)->geometry_id;
  SceneInput scene;
  for (const char* id : {"a", "b"}) {
    ObjectInput& object = scene.objects.emplace_back();
    object.id = id;
    object.geometry_id = geometry;
    object.pose.translation = Vec3d(id[0] == 'a' ? 0 : 5, 0, 0);
  }
  scene.thresholds = {{"near", 0.5, 0.1, "a", "b", 0}};
  scene.default_options.distance_cutoff = 0.2;  // below the exit distance 0.6
  Expected<SceneInfo> refused = service.create_scene(scene);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().field, "default_options.distance_cutoff");
  scene.default_options.distance_cutoff.reset();
  scene.thresholds[0].object_b = "c";
  refused = service.create_scene(scene);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().field, "thresholds[0].object_b");
  scene.thresholds[0].object_b = "b";
  Expected<SceneInfo> info = service.create_scene(scene);
  ASSERT_TRUE(info.ok()) << info.error().describe();

  // b at x = 5 (gap 4), 1.3 (gap 0.3: enter), 1.65 (gap 0.65: exit).
  auto run = [&](std::vector<ThresholdInput> own) {
    std::unique_ptr<PoseStream> stream = std::move(service.open_stream().value());
    std::vector<std::pair<std::uint64_t, Crossing>> events;
    std::uint64_t sequence = 0;
    for (const double x : {5.0, 1.3, 1.65}) {
      PoseUpdateInput update;
      update.scene_id = info->scene_id;
      update.sequence = ++sequence;
      if (sequence == 1) update.thresholds = own;
      PoseInput pose;
      pose.translation = Vec3d(x, 0, 0);
      update.poses.push_back({"b", pose});
      Expected<PreparedUpdate> prepared = stream->prepare(update, Clock::now());
      EXPECT_TRUE(prepared.ok()) << prepared.error().describe();
      const Report report = run_prepared(*stream, std::move(prepared.value()));
      for (const ThresholdEvent& e : report.events) events.emplace_back(e.sequence, e.crossing);
    }
    return events;
  };
  using Events = std::vector<std::pair<std::uint64_t, Crossing>>;
  EXPECT_EQ(run({}), (Events{{2, Crossing::enter}, {3, Crossing::exit}}));
  // Its own, tighter threshold: 0.3 is not below 0.2, so nothing fires.
  EXPECT_EQ(run({{"tight", 0.2, 0, "a", "", 0}}), Events{});
}

// ---- padding (issue 22 item 3) ----

// Padding against a brute-force reference: the same objects in an unpadded scene, every pair
// through the engine without a cutoff (cold), and the rule "the padded distance is d − p, the pair
// intersects when d <= p", with p the sum of the two objects' paddings, or of their self
// paddings when they share a body. A padded stream with a cutoff must agree pair by pair, never
// prune a pair whose padded distance is within the cutoff (the boxes widen by the padding), and
// put its near points on the padded surfaces. Without the widened boxes, pairs the padding
// brings within the cutoff were pruned; without the pair padding, every distance is off by p.
TEST(Padding, PaddedReportsMatchTheUnpaddedEngineLessThePadding) {
  std::size_t separated = 0, padded_only = 0, beyond = 0, self_pairs = 0;
  for (std::uint64_t seed = 0; seed < 4; ++seed) {
    Rng rng(3300 + seed);
    SceneService service(ServiceLimits{}, 2);
    const Vec3d center = Vec3d::Constant(seed % 2 ? 1e6 : 0);
    const std::size_t n = 16;
    const double cutoff = 0.6;
    RandomScene plain = make_scene(service, rng, n, center, 7);
    SceneInput padded = plain.input;
    for (std::size_t i = 0; i < n; ++i) {
      padded.objects[i].padding = uniform(rng, 0, 0.3);
      padded.objects[i].self_padding = i % 3 == 0 ? 0.0 : uniform(rng, 0, 0.1);
      padded.objects[i].body = i < 6 ? "robot" : "";  // o0..o5 are one body
    }
    padded.requested_id = "padded";
    Expected<SceneInfo> padded_info = service.create_scene(padded);
    ASSERT_TRUE(padded_info.ok()) << padded_info.error().describe();
    Expected<SceneInfo> plain_info = service.create_scene(plain.input);
    ASSERT_TRUE(plain_info.ok());
    std::unique_ptr<PoseStream> stream = std::move(service.open_stream().value());
    std::vector<PoseInput> poses = plain.poses;
    for (int update = 0; update < 12; ++update) {
      const std::string where =
          "seed " + std::to_string(seed) + " update " + std::to_string(update);
      PoseUpdateInput input;
      input.scene_id = "padded";
      input.sequence = std::uint64_t(update) + 1;
      input.options.distance_cutoff = cutoff;
      input.options.near_points = true;
      input.options.penetration = PenetrationMode::bound;
      for (int m = 0; m < 3; ++m) {
        const std::size_t i = rng() % n;
        poses[i] = random_pose(rng, center, 3.5);
        bool listed = false;
        for (ObjectPoseInput& pose : input.poses)
          if (pose.object_id == plain.input.objects[i].id) pose.pose = poses[i], listed = true;
        if (!listed) input.poses.push_back({plain.input.objects[i].id, poses[i]});
      }
      Expected<PreparedUpdate> prepared = stream->prepare(input, Clock::now());
      ASSERT_TRUE(prepared.ok()) << where;
      const Report got = run_prepared(*stream, std::move(prepared.value()));
      const Report ref = recompute_all(service, plain_info->scene_id, poses, plain.input,
                                       std::numeric_limits<double>::infinity());
      ASSERT_EQ(got.pairs.size(), ref.pairs.size()) << where;
      for (std::size_t p = 0; p < ref.pairs.size(); ++p) {
        const PairReport& want = ref.pairs[p];
        const PairReport& pair = got.pairs[p];
        const ObjectInput& a = padded.objects[want.object_a];
        const ObjectInput& b = padded.objects[want.object_b];
        const bool self = !a.body.empty() && a.body == b.body;
        self_pairs += self;
        const double pad = self ? a.self_padding + b.self_padding : a.padding + b.padding;
        const double d = model::in_contact(want.status) ? 0.0 : want.distance;
        const std::string at = where + " pair " + std::to_string(p);
        if (std::abs(d - pad) < 1e-9 || std::abs(d - pad - cutoff) < 1e-9) continue;  // ties
        if (d - pad > cutoff) {
          ++beyond;
          if (pair.status == PairStatus::beyond_cutoff) {
            // Proven beyond the cutoff, and a true lower bound (compounds: the cutoff itself).
            EXPECT_GE(pair.distance_lower_bound, cutoff - 1e-12) << at;
            EXPECT_LE(pair.distance_lower_bound, d - pad + 1e-9) << at;
          } else {
            EXPECT_EQ(pair.status, PairStatus::separated) << at;
            EXPECT_NEAR(pair.distance, d - pad, want.error_bound + 1e-9) << at;
          }
        } else if (d <= pad) {
          EXPECT_TRUE(model::in_contact(pair.status)) << at << " d " << d << " pad " << pad;
          EXPECT_EQ(pair.distance, 0.0) << at;
          if (d > 0) {
            ++padded_only;
            ASSERT_TRUE(pair.has_penetration_bound) << at;
            EXPECT_NEAR(pair.penetration_bound, pad - d, want.error_bound + 1e-9) << at;
          }
        } else {
          ++separated;
          ASSERT_EQ(pair.status, PairStatus::separated) << at << " d " << d << " pad " << pad;
          EXPECT_NEAR(pair.distance, d - pad, want.error_bound + 1e-9) << at;
          ASSERT_TRUE(pair.has_near_points) << at;
          EXPECT_NEAR((pair.point_b - pair.point_a).norm(), pair.distance, 1e-9) << at;
        }
      }
    }
  }
  // The sample holds every case, self-pairs included.
  EXPECT_GT(separated, 20u);
  EXPECT_GT(padded_only, 10u);
  EXPECT_GT(beyond, 100u);
  EXPECT_GT(self_pairs, 100u);
}

// Bad paddings and body ids are refused at creation, naming the field.
TEST(Padding, BadPaddingsAreRefusedNamingTheField) {
  Rng rng(91);
  SceneService service(ServiceLimits{}, 1);
  RandomScene scene = make_scene(service, rng, 2, Vec3d::Zero(), 3);
  SceneInput bad = scene.input;
  bad.objects[1].padding = -0.1;
  Expected<SceneInfo> refused = service.create_scene(bad);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().field, "objects[1].padding");
  bad = scene.input;
  bad.objects[0].self_padding = std::numeric_limits<double>::infinity();
  refused = service.create_scene(bad);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().field, "objects[0].self_padding");
  bad = scene.input;
  bad.objects[0].body = "has space";
  refused = service.create_scene(bad);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().field, "objects[0].body");
}

}  // namespace
}  // namespace nearpoint::server
