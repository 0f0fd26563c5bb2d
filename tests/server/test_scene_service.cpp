// SPDX-License-Identifier: Apache-2.0
// The scene API without any transport: what the gRPC service (and later the DDS bridge) adapts.
#include <gtest/gtest.h>

#include <cstdio>
#include <future>
#include <random>
#include <set>

#include "content_hash.hpp"
#include "nearpoint/distance.hpp"
#include "nearpoint/server/scene_service.hpp"
#include "validation.hpp"

namespace nearpoint::server {
namespace {

using namespace ::nearpoint::model;  // the scene model's types, unqualified in the tests

GeometryInput box_input(double half = 0.5) {
  GeometryInput geometry;
  geometry.name = "box";
  PieceInput& piece = geometry.pieces.emplace_back();
  PolytopeInput polytope;
  for (int i = 0; i < 8; ++i)
    polytope.vertices.emplace_back(i & 1 ? half : -half, i & 2 ? half : -half,
                                   i & 4 ? half : -half);
  piece.shape = std::move(polytope);
  return geometry;
}

ObjectInput object(const std::string& id, const std::string& geometry,
                   std::optional<std::uint32_t> group = {},
                   std::optional<std::uint32_t> mask = {}) {
  ObjectInput out;
  out.id = id;
  out.geometry_id = geometry;
  out.group = group;
  out.mask = mask;
  return out;
}

/// Runs a query and waits for its report (the callback runs on a pool thread).
Report run_query(SceneService& service, const QueryInput& query) {
  std::promise<Report> done;
  const Outcome started =
      service.query(query, Clock::now(), [&](Report report) { done.set_value(std::move(report)); });
  EXPECT_TRUE(started.ok()) << (started.ok() ? "" : started.error().describe());
  return done.get_future().get();
}

/// Prepares and evaluates one update on `stream` and waits for its report; an update the stream
/// refuses fails the test and yields an empty report.
Report run_update(PoseStream& stream, const PoseUpdateInput& update) {
  Expected<PreparedUpdate> prepared = stream.prepare(update, Clock::now());
  EXPECT_TRUE(prepared.ok()) << (prepared.ok() ? "" : prepared.error().describe());
  if (!prepared.ok()) return Report{};
  std::promise<Report> done;
  stream.evaluate(std::move(prepared.value()),
                  [&](Report report) { done.set_value(std::move(report)); });
  return done.get_future().get();
}

std::vector<std::pair<std::string, std::string>> pair_ids(const Report& report) {
  std::vector<std::pair<std::string, std::string>> out;
  for (const PairReport& pair : report.pairs)
    out.emplace_back(report.scene->objects[pair.object_a].id,
                     report.scene->objects[pair.object_b].id);
  return out;
}

using Pairs = std::vector<std::pair<std::string, std::string>>;

// Group/mask filtering (Bullet's rule), listed pairs (exactly these, in this order) and
// excluded pairs (all others).
TEST(SceneService, PairSelectionFollowsGroupsMasksAndLists) {
  SceneService service(ServiceLimits{}, 1);
  const std::string box = service.register_geometry(box_input()).value().geometry_id;

  SceneInput filtered;
  filtered.objects = {object("a", box, 1u), object("b", box, 2u, 2u), object("c", box),
                      object("d", box, 2u)};
  const SceneInfo filtered_scene = service.create_scene(filtered).value();
  // b (group 2) only checks group 2: a and c (group 1) are out, d (group 2) is in.
  EXPECT_EQ(pair_ids(run_query(service, {filtered_scene.scene_id, {}, {}, 0, {}})),
            (Pairs{{"a", "c"}, {"a", "d"}, {"b", "d"}, {"c", "d"}}));

  SceneInput listed;
  listed.objects = {object("a", box), object("b", box), object("c", box)};
  listed.pair_selection.mode = PairSelectionInput::Mode::listed_pairs;
  listed.pair_selection.pairs = {{"c", "a"}, {"b", "c"}};
  const SceneInfo listed_scene = service.create_scene(listed).value();
  EXPECT_EQ(pair_ids(run_query(service, {listed_scene.scene_id, {}, {}, 0, {}})),
            (Pairs{{"c", "a"}, {"b", "c"}}));

  SceneInput excluded = listed;
  excluded.pair_selection.mode = PairSelectionInput::Mode::excluded_pairs;
  excluded.pair_selection.pairs = {{"c", "a"}};  // order within an excluded pair is ignored
  const SceneInfo excluded_scene = service.create_scene(excluded).value();
  EXPECT_EQ(pair_ids(run_query(service, {excluded_scene.scene_id, {}, {}, 0, {}})),
            (Pairs{{"a", "b"}, {"b", "c"}}));
}

// Content ids (issue 24): a client re-registering its geometries after a failover, on another
// replica or the same one, must get the ids it already holds; any difference must give another.
TEST(SceneService, GeometryIdsAreContentHashesAndRegisteringTwiceIsIdempotent) {
  Sha256 hash;
  hash.update("abc");  // FIPS 180-2, appendix B.1
  EXPECT_EQ(hex_prefix(hash.finish(), 32),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  Sha256 long_message;  // more than one block, fed in pieces
  for (int i = 0; i < 1000; ++i) long_message.update("aaaaaaaaaa");  // 10,000 × 'a'
  EXPECT_EQ(hex_prefix(long_message.finish(), 8), "27dd1f61b867b6a0");

  SceneService service(ServiceLimits{}, 1);
  const GeometryInfo first = service.register_geometry(box_input()).value();
  EXPECT_EQ(first.geometry_id.rfind("geom-", 0), 0u);
  EXPECT_EQ(first.geometry_id.size(), 5u + 32u);
  const GeometryInfo again = service.register_geometry(box_input()).value();
  EXPECT_EQ(again.geometry_id, first.geometry_id);
  EXPECT_EQ(again.name, first.name);
  EXPECT_EQ(service.geometry_count(), 1u);
  // Another service (a replica) gives the same id to the same geometry.
  SceneService other(ServiceLimits{}, 1);
  EXPECT_EQ(other.register_geometry(box_input()).value().geometry_id, first.geometry_id);
  // Any difference: another id.
  GeometryInput renamed = box_input();
  renamed.name = "crate";
  GeometryInput moved = box_input();
  moved.pieces[0].offset.translation.x() = 1e-12;
  GeometryInput rounded = box_input();
  rounded.pieces[0].radius = 0.01;
  std::set<std::string> ids = {first.geometry_id};
  for (const GeometryInput& changed : {renamed, moved, rounded, box_input(0.25)})
    ids.insert(service.register_geometry(changed).value().geometry_id);
  EXPECT_EQ(ids.size(), 5u);
  // Listed in order of first registration.
  const std::vector<GeometryInfo> listed = service.list_geometries();
  ASSERT_EQ(listed.size(), 5u);
  EXPECT_EQ(listed[0].geometry_id, first.geometry_id);
  EXPECT_EQ(listed[1].name, "crate");
  // Removed, then registered again: the same id.
  ASSERT_TRUE(service.remove_geometry(first.geometry_id).ok());
  EXPECT_EQ(service.register_geometry(box_input()).value().geometry_id, first.geometry_id);
}

// The ids a deployment already holds must survive a change of SHA-256 implementation: these were
// computed by the hand-written SHA-256 that content_hash.cpp carried before it used OpenSSL's EVP.
// One geometry per shape kind, a compound, an offset and a rounded piece.
TEST(SceneService, GeometryIdsAreThoseOfEarlierReleases) {
  std::vector<std::pair<GeometryInput, std::string>> known;
  known.emplace_back(box_input(), "geom-3154ff650986d7795458a153e7043ce3");
  known.emplace_back(box_input(0.25), "geom-f1063c417b29750100d0833187550e6c");
  GeometryInput kinds;
  kinds.name = "every kind";
  kinds.pieces.resize(6);
  kinds.pieces[0].shape = Point{};
  kinds.pieces[0].radius = 0.5;
  kinds.pieces[1].shape = Segment<double>{Vec3d(0, 0, -1), Vec3d(0, 0, 1)};
  kinds.pieces[1].radius = 0.2;
  kinds.pieces[2].shape = Box<double>{Vec3d(1, 0.5, 0.25)};
  kinds.pieces[2].offset.translation = Vec3d(1, 2, 3);
  kinds.pieces[2].offset.rotation_wxyz = {0.7071067811865476, 0, 0.7071067811865476, 0};
  kinds.pieces[3].shape = Cylinder<double>{0.3, 0.6};
  kinds.pieces[4].shape = Cone<double>{0.5, 0.5};
  kinds.pieces[5].shape = Ellipsoid<double>{Vec3d(1, 0.5, 0.5)};
  known.emplace_back(kinds, "geom-9b5860bb8f28de72f13e15707f52da70");
  GeometryInput unnamed;  // empty name, one tiny-number piece
  unnamed.pieces.emplace_back().shape = Box<double>{Vec3d(1e-300, 5e-324, 1)};
  known.emplace_back(unnamed, "geom-1b42b12bb38ba01d311c5f48ffd1ebdb");
  for (const auto& [geometry, id] : known)
    EXPECT_EQ(geometry_content_id(geometry), id) << "geometry '" << geometry.name << "'";
}

// SHA-256 against a peer implementation: coreutils' sha256sum over the same bytes (every byte
// value, more than one block, an odd length).
TEST(SceneService, Sha256AgreesWithSha256sum) {
  std::string bytes;
  for (int i = 0; i < 3001; ++i) bytes.push_back(char((i * 7 + i / 256) & 0xff));
  const std::string path = ::testing::TempDir() + "nearpoint_sha256_bytes";
  {
    std::FILE* file = std::fopen(path.c_str(), "wb");
    ASSERT_NE(file, nullptr);
    ASSERT_EQ(std::fwrite(bytes.data(), 1, bytes.size(), file), bytes.size());
    std::fclose(file);
  }
  std::FILE* pipe = ::popen(("sha256sum '" + path + "'").c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  char line[128] = {};
  const bool read = std::fgets(line, sizeof line, pipe) != nullptr;
  const int status = ::pclose(pipe);
  std::remove(path.c_str());
  if (!read || status != 0) GTEST_SKIP() << "sha256sum (coreutils) did not run";
  Sha256 hash;
  hash.update(bytes.substr(0, 1000));  // in pieces, across block boundaries
  hash.update(bytes.substr(1000));
  EXPECT_EQ(hex_prefix(hash.finish(), 32), std::string(line, 64));
}

// Inline geometries (issue 24): one call makes a scene whole, on whichever replica receives it.
TEST(SceneService, AScenesGeometriesMayComeWithItAndErrorsNameTheEntry) {
  SceneService service(ServiceLimits{}, 1);
  SceneInput scene;
  scene.requested_id = "cell";
  scene.geometries["crate"] = box_input();
  scene.geometries["small"] = box_input(0.25);
  scene.objects = {object("a", "crate"), object("b", "small")};
  scene.objects[1].pose.translation = Vec3d(3, 0, 0);
  const SceneInfo info = service.create_scene(scene).value();
  ASSERT_EQ(info.geometry_ids.size(), 2u);
  const std::string crate_id = service.register_geometry(box_input()).value().geometry_id;
  EXPECT_EQ(info.geometry_ids.at("crate"), crate_id);  // stored, under its content id
  EXPECT_EQ(service.geometry_count(), 2u);
  const Report report = run_query(service, {"cell", {}, {}, 0, {}});
  ASSERT_EQ(report.pairs.size(), 1u);
  EXPECT_NEAR(report.pairs[0].distance, 3 - 0.5 - 0.25, 1e-12);

  SceneInput bad;
  bad.geometries["bent"] = box_input();
  bad.geometries["bent"].pieces[0].radius = -1;
  bad.objects = {object("a", "bent"), object("b", crate_id)};  // a stored id still works
  const Error error = service.create_scene(bad).error();
  EXPECT_EQ(error.code, ErrorCode::invalid_argument);
  EXPECT_EQ(error.field, "geometries['bent'].pieces[0].radius") << error.describe();
}

// Idempotent re-creation (issue 24): a client that does not know whether its CreateScene
// arrived (a lost connection, a failover) sends it again and gets the first answer; a different
// request for a taken id is still refused.
TEST(SceneService, TheSameCreationTwiceIsAnsweredAsTheFirst) {
  SceneService service(ServiceLimits{}, 1);
  const std::string box = service.register_geometry(box_input()).value().geometry_id;
  SceneInput scene;
  scene.requested_id = "cell";
  scene.fingerprint = "request-1";
  scene.objects = {object("a", box), object("b", box)};
  const SceneInfo first = service.create_scene(scene).value();
  const SceneInfo again = service.create_scene(scene).value();
  EXPECT_EQ(again.scene_id, first.scene_id);
  EXPECT_EQ(again.pair_count, first.pair_count);
  EXPECT_EQ(service.scene_count(), 1u);
  SceneInput other = scene;
  other.fingerprint = "request-2";
  EXPECT_EQ(service.create_scene(other).error().code, ErrorCode::already_exists);
  SceneInput unfingerprinted = scene;  // a scene file's: never taken for the same request
  unfingerprinted.fingerprint.clear();
  EXPECT_EQ(service.create_scene(unfingerprinted).error().code, ErrorCode::already_exists);
}

// Options inherit field by field: update overrides → scene defaults → engine defaults.
TEST(SceneService, OptionsInheritFieldByField) {
  ResolvedOptions engine_defaults;
  QueryOptionsInput scene_defaults;
  scene_defaults.near_points = true;
  scene_defaults.distance_cutoff = 2.0;
  const ResolvedOptions scene =
      resolve_options(engine_defaults, scene_defaults, "default_options").value();
  QueryOptionsInput update;
  update.distance_cutoff = 0.5;
  update.penetration = PenetrationMode::bound;
  const ResolvedOptions resolved = resolve_options(scene, update, "options").value();
  EXPECT_TRUE(resolved.engine.near_points);                     // from the scene
  EXPECT_EQ(resolved.engine.distance_cutoff, 0.5);              // from the update
  EXPECT_TRUE(resolved.engine.penetration_bound);               // from the update
  EXPECT_EQ(resolved.engine.epsilon, kDefaultEpsilon<double>);  // the engine's
  EXPECT_TRUE(resolved.warm_start);
  EXPECT_EQ(resolved.engine.cold_start, ColdStart::with_centroids);  // first query of a pair
  // Without warm starts, queries start as the paper's Section VI does (Table I's comparison).
  QueryOptionsInput cold;
  cold.warm_start = false;
  EXPECT_EQ(resolve_options(scene, cold, "options").value().engine.cold_start,
            ColdStart::single_point);

  QueryOptionsInput bad;
  bad.epsilon = -1;
  EXPECT_EQ(resolve_options(scene, bad, "options").error().field, "options.epsilon");
}

// A quaternion within 1e-4 of unit length is accepted and normalised; beyond, it is refused.
TEST(SceneService, QuaternionsAreNormalisedWithinTheToleranceAndRefusedBeyond) {
  PoseInput pose;
  pose.rotation_wxyz = {1.00005, 0, 0, 0};
  const Expected<Pose<double>> accepted = check_pose(pose, "pose");
  ASSERT_TRUE(accepted.ok());
  EXPECT_NEAR((accepted.value().rotation - Mat3<double>::Identity()).norm(), 0.0, 1e-15);
  pose.rotation_wxyz = {1.001, 0, 0, 0};
  EXPECT_EQ(check_pose(pose, "pose").error().field, "pose.rotation");
  pose.rotation_wxyz = {1, 0, 0, 0};
  pose.translation.y() = 1e13;  // beyond any real site: refused before it can overflow
  EXPECT_EQ(check_pose(pose, "pose").error().field, "pose.translation.y");
}

// The broad phase relies on the bounding sphere enclosing every piece, offsets and radii included.
TEST(SceneService, BoundingSphereEnclosesEveryPiece) {
  GeometryInput geometry = box_input(0.3);
  PieceInput& capsule = geometry.pieces.emplace_back();
  capsule.shape = Segment<double>{Vec3d(2, 0, 0), Vec3d(3, 1, 0)};
  capsule.radius = 0.25;
  capsule.offset.rotation_wxyz = {std::cos(0.3), 0, std::sin(0.3), 0};
  capsule.offset.translation = Vec3d(0, 1, -1);
  const auto stored = build_geometry(geometry, ServiceLimits{});
  ASSERT_TRUE(stored.ok());
  const GeometryInfo& info = stored.value()->info;
  EXPECT_EQ(info.piece_count, 2u);
  EXPECT_EQ(info.vertex_count, 8u);
  // Sample the support of every piece in many directions: all within the sphere.
  const Compound<double>& compound = stored.value()->compound;
  for (std::size_t i = 0; i < compound.size(); ++i) {
    const Piece<double>& piece = compound.piece(i);
    for (int k = 0; k < 200; ++k) {
      const Vec3d direction(std::cos(k * 0.7) * std::sin(k * 0.3),
                            std::sin(k * 0.7) * std::sin(k * 0.3), std::cos(k * 0.3));
      int index = 0;
      const Vec3d local_direction = piece.offset.rotation.transpose() * direction;
      const Vec3d local = support(piece.shape, local_direction, index);
      const Vec3d point = piece.offset.apply(local) + piece.shape.radius * direction.normalized();
      EXPECT_LE((point - info.bounding_center).norm(), info.bounding_radius);
    }
  }
}

// A stream through the plain API: binding, sequence order, and warm caches — no transport.
TEST(SceneService, PoseStreamWorksWithoutATransport) {
  SceneService service(ServiceLimits{}, 2);
  const std::string box = service.register_geometry(box_input()).value().geometry_id;
  SceneInput scene;
  scene.objects = {object("a", box), object("b", box)};
  const SceneInfo info = service.create_scene(scene).value();
  auto stream = service.open_stream();
  ASSERT_TRUE(stream.ok());
  EXPECT_EQ(service.open_streams(), 1u);
  for (std::uint64_t sequence = 1; sequence <= 3; ++sequence) {
    PoseUpdateInput update;
    update.scene_id = info.scene_id;
    update.sequence = sequence;
    ObjectPoseInput moved;
    moved.object_id = "b";
    moved.pose.translation = Vec3d(1.5 + 0.1 * double(sequence), 0, 0);
    update.poses.push_back(moved);
    const Report report = run_update(*stream.value(), update);
    ASSERT_EQ(report.pairs.size(), 1u);
    EXPECT_EQ(report.sequence, sequence);
    EXPECT_NEAR(report.pairs[0].distance, 0.5 + 0.1 * double(sequence), 1e-12);
    EXPECT_EQ(report.pairs[0].warm_started, sequence > 1);
  }
  PoseUpdateInput stale;
  stale.scene_id = info.scene_id;
  stale.sequence = 3;
  EXPECT_EQ(stream.value()->prepare(stale, Clock::now()).error().field, "sequence");
  stream.value().reset();
  EXPECT_EQ(service.open_streams(), 0u);
}

// Scenes heavy enough to outweigh a worker's wake-up are split across the pool: every pair is
// still evaluated exactly once, into its own slot, with the right answer.
TEST(SceneService, LargeScenesAreSplitAcrossWorkersAndStillExact) {
  SceneService service(ServiceLimits{}, 2);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1, 1);
  SceneInput scene;
  std::vector<Compound<double>> local;
  for (int i = 0; i < 6; ++i) {
    GeometryInput geometry;
    PolytopeInput polytope;
    for (int k = 0; k < 3000; ++k) polytope.vertices.emplace_back(unit(rng), unit(rng), unit(rng));
    std::vector<Piece<double>> pieces;
    pieces.push_back({Shape<double>(Polytope<double>(polytope.vertices)), Pose<double>{}});
    local.emplace_back(std::move(pieces));
    geometry.pieces.emplace_back().shape = std::move(polytope);
    const std::string id = service.register_geometry(geometry).value().geometry_id;
    scene.objects.push_back(object("o" + std::to_string(i), id));
    scene.objects.back().pose.translation = Vec3d(2.5 * i, 0.3 * (i % 2), 0);
  }
  const SceneInfo info = service.create_scene(scene).value();
  EXPECT_EQ(service.find_scene(info.scene_id)->definition()->tasks_per_evaluation, 2u);
  const Report report = run_query(service, {info.scene_id, {}, {}, 0, {}});
  ASSERT_EQ(report.pairs.size(), 15u);
  for (const PairReport& pair : report.pairs) {
    Pose<double> pose_a, pose_b;
    pose_a.translation = scene.objects[pair.object_a].pose.translation;
    pose_b.translation = scene.objects[pair.object_b].pose.translation;
    const double truth =
        distance(local[pair.object_a], pose_a, local[pair.object_b], pose_b).nearest.distance;
    EXPECT_NEAR(pair.distance, truth, pair.error_bound + 1e-12);
  }
}

// A large polytope is stored as its hull with faces, so its supports climb the hull's edges; the
// answers equal the engine's on the plain vertex list, along a path streamed with warm starts.
TEST(SceneService, LargePolytopesAreStoredAsClimbingHulls) {
  SceneService service(ServiceLimits{}, 2);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> normal;
  PolytopeInput sphere;
  for (int k = 0; k < 800; ++k)
    sphere.vertices.push_back(Vec3d(normal(rng), normal(rng), normal(rng)).normalized());
  const Compound<double> plain_sphere(std::vector<Piece<double>>{
      {Shape<double>(Polytope<double>(sphere.vertices)), Pose<double>{}}});
  GeometryInput geometry;
  geometry.pieces.emplace_back().shape = sphere;
  const std::string ball = service.register_geometry(geometry).value().geometry_id;
  const std::string box = service.register_geometry(box_input()).value().geometry_id;
  SceneInput scene;
  scene.objects = {object("ball", ball), object("box", box)};
  const SceneInfo info = service.create_scene(scene).value();
  const auto definition = service.find_scene(info.scene_id)->definition();
  EXPECT_TRUE(
      std::get<Polytope<double>>(definition->objects[0].geometry->compound.piece(0).shape.geometry)
          .climbs());
  const Compound<double> plain_box(std::vector<Piece<double>>{
      {Shape<double>(
           Polytope<double>(std::get<PolytopeInput>(box_input().pieces[0].shape).vertices)),
       Pose<double>{}}});
  auto stream = service.open_stream();
  ASSERT_TRUE(stream.ok());
  for (std::uint64_t sequence = 1; sequence <= 40; ++sequence) {
    PoseUpdateInput update;
    update.scene_id = info.scene_id;
    update.sequence = sequence;
    ObjectPoseInput moved;
    moved.object_id = "box";
    const double s = double(sequence) / 40;
    moved.pose.translation = Vec3d(2.5 - 2.5 * s, 0.3 * s, 0.1);
    const Eigen::Quaterniond turn(Eigen::AngleAxisd(2 * s, Vec3d(1, 2, 3).normalized()));
    moved.pose.rotation_wxyz = {turn.w(), turn.x(), turn.y(), turn.z()};
    update.poses.push_back(moved);
    const Report report = run_update(*stream.value(), update);
    ASSERT_EQ(report.pairs.size(), 1u);
    Pose<double> pose_b;
    pose_b.rotation = turn.toRotationMatrix();
    pose_b.translation = moved.pose.translation;
    const auto truth = distance(plain_sphere, Pose<double>{}, plain_box, pose_b).nearest;
    EXPECT_NEAR(report.pairs[0].distance, truth.distance,
                report.pairs[0].error_bound + truth.error_bound)
        << sequence;
  }
}

// Coalescing keeps the newest update and counts everything it absorbed.
TEST(SceneService, CoalescingCountsTheMergedUpdates) {
  PreparedUpdate first, second, third;
  first.sequence = 4;
  second.sequence = 5;
  third.sequence = 9;
  PoseStream::coalesce(second, first);
  EXPECT_EQ(second.coalesced_updates, 1u);
  EXPECT_EQ(second.coalesced_from_sequence, 4u);
  PoseStream::coalesce(third, second);
  EXPECT_EQ(third.sequence, 9u);
  EXPECT_EQ(third.coalesced_updates, 2u);
  EXPECT_EQ(third.coalesced_from_sequence, 4u);
}

}  // namespace
}  // namespace nearpoint::server
