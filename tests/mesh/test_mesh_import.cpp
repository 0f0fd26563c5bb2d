// SPDX-License-Identifier: Apache-2.0
// nearpoint_mesh_import: mesh files to convex pieces. The shipped meshes (tests/data/, written by
// make_meshes.py) have hulls known by construction; random point clouds check the hull against
// the engine itself: the distance to the imported hull must equal the distance to every vertex
// the file holds, i.e. the hull did not change the convex set.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "nearpoint/client/mesh_import.hpp"
#include "nearpoint/distance.hpp"

namespace nearpoint::client {
namespace {

namespace fs = std::filesystem;
using Point = std::tuple<double, double, double>;

fs::path data(const std::string& name) {
  return fs::path(NEARPOINT_TEST_DATA_DIR) / name;
}

std::set<Point> as_set(const std::vector<Eigen::Vector3d>& vertices) {
  std::set<Point> out;
  for (const Eigen::Vector3d& v : vertices) out.emplace(v.x(), v.y(), v.z());
  return out;
}

/// A scratch directory for files written by a test, removed afterwards.
class MeshFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           (std::string("nearpoint_mesh_") + info->name() + "_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path write(const std::string& name, const std::string& contents) {
    const fs::path path = dir_ / name;
    std::ofstream(path, std::ios::binary) << contents;
    return path;
  }

  fs::path dir_;
};

TEST(MeshImport, CubeObjKeepsItsEightCornersAndDropsTheFaceCentres) {
  const MeshImport mesh = import_mesh(data("cube.obj"));
  ASSERT_TRUE(mesh.ok()) << mesh.error;
  ASSERT_EQ(mesh.pieces.size(), 1u);
  const ConvexPiece& cube = mesh.pieces[0];
  EXPECT_EQ(cube.name, "cube");
  EXPECT_EQ(cube.source_vertex_count, 14u);  // 8 corners + 6 face centres
  std::set<Point> corners;
  for (double x : {-1.0, 1.0})
    for (double y : {-1.0, 1.0})
      for (double z : {-1.0, 1.0}) corners.emplace(x, y, z);
  EXPECT_EQ(cube.vertices.size(), 8u);
  EXPECT_EQ(as_set(cube.vertices), corners);
}

TEST(MeshImport, NonConvexStarPrismKeepsOnlyTheTips) {
  const MeshImport mesh = import_mesh(data("star_prism.obj"));
  ASSERT_TRUE(mesh.ok()) << mesh.error;
  ASSERT_EQ(mesh.pieces.size(), 1u);
  EXPECT_EQ(mesh.pieces[0].source_vertex_count, 16u);
  std::set<Point> tips;
  for (double z : {0.0, 1.0})
    for (const auto& [x, y] : {std::pair{2.0, 0.0}, {-2.0, 0.0}, {0.0, 2.0}, {0.0, -2.0}})
      tips.emplace(x, y, z);
  EXPECT_EQ(as_set(mesh.pieces[0].vertices), tips);
}

TEST(MeshImport, BinaryStlTetrahedronCountsEachSharedCornerOnce) {
  const MeshImport mesh = import_mesh(data("tetra_binary.stl"));
  ASSERT_TRUE(mesh.ok()) << mesh.error;
  ASSERT_EQ(mesh.pieces.size(), 1u);
  EXPECT_EQ(mesh.pieces[0].source_vertex_count, 4u);
  EXPECT_EQ(as_set(mesh.pieces[0].vertices),
            (std::set<Point>{{0, 0, 0}, {2, 0, 0}, {0, 3, 0}, {0, 0, 4}}));
  EXPECT_FALSE(mesh.pieces[0].name.empty());
}

TEST(MeshImport, OffOctahedron) {
  const MeshImport mesh = import_mesh(data("octahedron.off"));
  ASSERT_TRUE(mesh.ok()) << mesh.error;
  ASSERT_EQ(mesh.pieces.size(), 1u);
  EXPECT_EQ(as_set(mesh.pieces[0].vertices),
            (std::set<Point>{
                {1.5, 0, 0}, {-1.5, 0, 0}, {0, 1.5, 0}, {0, -1.5, 0}, {0, 0, 1.5}, {0, 0, -1.5}}));
}

TEST(MeshImport, PlyWedgeDropsItsInteriorVertex) {
  const MeshImport mesh = import_mesh(data("wedge.ply"));
  ASSERT_TRUE(mesh.ok()) << mesh.error;
  ASSERT_EQ(mesh.pieces.size(), 1u);
  EXPECT_EQ(mesh.pieces[0].source_vertex_count, 7u);
  EXPECT_EQ(mesh.pieces[0].name, "wedge");  // PLY names nothing: the file's stem
  EXPECT_EQ(
      as_set(mesh.pieces[0].vertices),
      (std::set<Point>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 0.5}, {1, 0, 0.5}, {0, 1, 0.5}}));
}

TEST(MeshImport, TwoObjectsGiveTwoPiecesAndMergeGivesOneHull) {
  const MeshImport split = import_mesh(data("two_parts.obj"));
  ASSERT_TRUE(split.ok()) << split.error;
  ASSERT_EQ(split.pieces.size(), 2u);
  EXPECT_EQ(split.pieces[0].name, "left");
  EXPECT_EQ(split.pieces[1].name, "right");
  std::set<Point> box;
  for (double x : {-3.0, -1.0})
    for (double y : {-1.0, 1.0})
      for (double z : {-1.0, 1.0}) box.emplace(x, y, z);
  const std::set<Point> tetra{{1, 0, 0}, {2, 0, 0}, {1, 1, 0}, {1, 0, 1}};
  EXPECT_EQ(as_set(split.pieces[0].vertices), box);
  EXPECT_EQ(as_set(split.pieces[1].vertices), tetra);

  const MeshImport merged = import_mesh(data("two_parts.obj"), {.merge_parts = true});
  ASSERT_TRUE(merged.ok()) << merged.error;
  ASSERT_EQ(merged.pieces.size(), 1u);
  EXPECT_EQ(merged.pieces[0].name, "two_parts");
  EXPECT_EQ(merged.pieces[0].source_vertex_count, 12u);
  // All box corners and three of the tetrahedron's; (1,0,0) lies between (2,0,0) and the box.
  std::set<Point> expected = box;
  expected.insert({{2, 0, 0}, {1, 1, 0}, {1, 0, 1}});
  EXPECT_EQ(as_set(merged.pieces[0].vertices), expected);
}

TEST(MeshImport, ScaleMultipliesEveryCoordinate) {
  const MeshImport mesh = import_mesh(data("tetra_binary.stl"), {.scale = 0.25});
  ASSERT_TRUE(mesh.ok()) << mesh.error;
  ASSERT_EQ(mesh.pieces.size(), 1u);
  EXPECT_EQ(as_set(mesh.pieces[0].vertices),
            (std::set<Point>{{0, 0, 0}, {0.5, 0, 0}, {0, 0.75, 0}, {0, 0, 1}}));
}

TEST(MeshImport, ObjectSplitByMaterialsIsStillOnePart) {
  // assimp makes one aiMesh per material; the hull must be the whole object's.
  const fs::path dir =
      fs::temp_directory_path() / ("nearpoint_mesh_mtl_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "m.mtl") << "newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n";
  std::ofstream(dir / "body.obj") << "mtllib m.mtl\no body\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
                                     "usemtl red\nf 1 2 3\nusemtl blue\nf 1 2 4\n";
  const MeshImport mesh = import_mesh(dir / "body.obj");
  fs::remove_all(dir);
  ASSERT_TRUE(mesh.ok()) << mesh.error;
  ASSERT_EQ(mesh.pieces.size(), 1u);
  EXPECT_EQ(mesh.pieces[0].name, "body");
  EXPECT_EQ(mesh.pieces[0].vertices.size(), 4u);
}

TEST(MeshImport, NodeTransformsArePlacedInTheFilesFrame) {
  // Any format assimp reads works; glTF carries node transforms (OBJ/STL/OFF/PLY have none).
  const MeshImport mesh = import_mesh(data("nested_transform.gltf"), {.scale = 0.5});
  ASSERT_TRUE(mesh.ok()) << mesh.error;
  ASSERT_EQ(mesh.pieces.size(), 1u);
  EXPECT_EQ(mesh.pieces[0].name, "tetra");
  EXPECT_EQ(as_set(mesh.pieces[0].vertices),
            (std::set<Point>{{5, 0, 0}, {6, 0, 0}, {5, 1, 0}, {5, 0, 1}}));
}

TEST_F(MeshFiles, ObjGroupsAreParts) {
  const MeshImport mesh = import_mesh(write("groups.obj",
                                            "g first\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
                                            "g second\nv 0 0 5\nv 1 0 5\nv 0 1 5\nf 4 5 6\n"));
  ASSERT_TRUE(mesh.ok()) << mesh.error;
  ASSERT_EQ(mesh.pieces.size(), 2u);
  EXPECT_EQ(mesh.pieces[0].name, "first");
  EXPECT_EQ(mesh.pieces[1].name, "second");
  EXPECT_EQ(as_set(mesh.pieces[1].vertices), (std::set<Point>{{0, 0, 5}, {1, 0, 5}, {0, 1, 5}}));
}

// --- degenerate parts: valid convex sets, kept by their extreme points ---

TEST_F(MeshFiles, CoplanarPartKeepsItsPolygonCorners) {
  // A tilted square (in the plane x + y + z = 1) fanned from its centre.
  const MeshImport mesh = import_mesh(write("flat.obj",
                                            "o flat\nv 1 0 0\nv 0 1 0\nv -1 1 1\nv 0 0 1\n"
                                            "v 0 0.5 0.5\nf 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\n"));
  ASSERT_TRUE(mesh.ok()) << mesh.error;
  ASSERT_EQ(mesh.pieces.size(), 1u);
  EXPECT_EQ(as_set(mesh.pieces[0].vertices),
            (std::set<Point>{{1, 0, 0}, {0, 1, 0}, {-1, 1, 1}, {0, 0, 1}}));
}

TEST_F(MeshFiles, CollinearPartKeepsBothEndsEvenWhenTheFirstPointIsInside) {
  // The first point lies between the ends: CGAL 5.5 alone would return it as an end.
  const MeshImport mesh =
      import_mesh(write("line.obj", "o line\nv 0.5 1 1.5\nv 0 0 0\nv 2 4 6\nv 1 2 3\nl 1 2 3 4\n"));
  ASSERT_TRUE(mesh.ok()) << mesh.error;
  ASSERT_EQ(mesh.pieces.size(), 1u);
  EXPECT_EQ(mesh.pieces[0].source_vertex_count, 4u);
  EXPECT_EQ(as_set(mesh.pieces[0].vertices), (std::set<Point>{{0, 0, 0}, {2, 4, 6}}));
}

TEST_F(MeshFiles, SinglePointPartIsOnePoint) {
  const MeshImport mesh = import_mesh(write("point.obj", "o dot\nv 3 -2 1\nv 3 -2 1\np 1 2\n"));
  ASSERT_TRUE(mesh.ok()) << mesh.error;
  ASSERT_EQ(mesh.pieces.size(), 1u);
  EXPECT_EQ(mesh.pieces[0].source_vertex_count, 1u);
  EXPECT_EQ(as_set(mesh.pieces[0].vertices), (std::set<Point>{{3, -2, 1}}));
}

// --- errors: values with messages, no pieces, nothing printed ---

void expect_error(const MeshImport& mesh, const std::string& file, const std::string& words) {
  EXPECT_FALSE(mesh.ok());
  EXPECT_TRUE(mesh.pieces.empty());
  EXPECT_NE(mesh.error.find(file), std::string::npos) << mesh.error;
  EXPECT_NE(mesh.error.find(words), std::string::npos) << mesh.error;
}

TEST_F(MeshFiles, MissingFile) {
  expect_error(import_mesh(dir_ / "absent.obj"), "absent.obj", "no such file");
}

TEST_F(MeshFiles, DirectoryIsNotAMesh) {
  fs::create_directories(dir_ / "folder.obj");
  expect_error(import_mesh(dir_ / "folder.obj"), "folder.obj", "not a regular file");
}

TEST_F(MeshFiles, CorruptStlGivesTheParsersMessage) {
  const MeshImport mesh = import_mesh(write("bad.stl", std::string("garbage\0\1\2 not", 14)));
  expect_error(mesh, "bad.stl", "cannot import: ");
  EXPECT_NE(mesh.error.find("STL"), std::string::npos) << mesh.error;  // assimp's own words
}

TEST_F(MeshFiles, UnsupportedFormat) {
  expect_error(import_mesh(write("notes.txt", "this is no mesh at all\n")), "notes.txt",
               "cannot import: ");
}

TEST_F(MeshFiles, TruncatedBinaryStl) {
  std::ifstream in(data("tetra_binary.stl"), std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  bytes.resize(150);  // says 4 triangles, holds 1.3
  expect_error(import_mesh(write("cut.stl", bytes)), "cut.stl", "cannot import: ");
}

TEST_F(MeshFiles, EmptyMeshHasNoVertices) {
  expect_error(import_mesh(write("empty.stl", "solid nothing\nendsolid nothing\n")), "empty.stl",
               "no vertices");
}

TEST_F(MeshFiles, NaNCoordinateIsNamed) {
  const MeshImport mesh =
      import_mesh(write("nan.obj", "o wing\nv 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n"));
  expect_error(mesh, "nan.obj", "non-finite coordinate");
  EXPECT_NE(mesh.error.find("part 'wing', vertex 3"), std::string::npos) << mesh.error;
}

TEST_F(MeshFiles, OverflowingCoordinateIsNonFinite) {
  expect_error(import_mesh(write("huge.obj", "v 1e400 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")),
               "huge.obj", "non-finite coordinate");
}

TEST_F(MeshFiles, ScaleThatOverflowsIsReported) {
  const fs::path file = write("big.obj", "v 1e30 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  expect_error(import_mesh(file, {.scale = 1e300}), "big.obj", "not finite after");
}

TEST_F(MeshFiles, ScaleMustBeFiniteAndPositive) {
  const fs::path file = data("cube.obj");
  for (double scale : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN(),
                       std::numeric_limits<double>::infinity()})
    expect_error(import_mesh(file, {.scale = scale}), "cube.obj", "scale must be finite");
}

TEST_F(MeshFiles, NothingIsPrintedOnStdoutOrStderr) {
  const fs::path bad = write("bad.stl", std::string("garbage\0\1\2 not", 14));
  const fs::path empty = write("empty.obj", "");
  ::testing::internal::CaptureStdout();
  ::testing::internal::CaptureStderr();
  const bool all_ok = import_mesh(data("cube.obj")).ok() && import_mesh(data("wedge.ply")).ok();
  const bool any_ok = import_mesh(bad).ok() || import_mesh(empty).ok();
  const std::string out = ::testing::internal::GetCapturedStdout();
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_TRUE(all_ok);
  EXPECT_FALSE(any_ok);
  EXPECT_EQ(out, "");
  EXPECT_EQ(err, "");
}

// --- the hull is the same convex set: distances agree with the full vertex list ---

/// Distances from a box at random poses to the hull and to every source vertex agree within the
/// engine's certified error bounds; the hull's vertices are source points; every source point is
/// in the hull (distance 0 from a point at it).
void expect_same_convex_set(const std::vector<Eigen::Vector3d>& source,
                            const std::vector<Eigen::Vector3d>& hull, std::uint32_t seed) {
  const std::set<Point> source_set = as_set(source);
  for (const Eigen::Vector3d& v : hull)
    EXPECT_TRUE(source_set.count({v.x(), v.y(), v.z()})) << v.transpose();

  const Shape<double> full{Polytope<double>(source)};
  const Shape<double> reduced{Polytope<double>(hull)};
  const Shape<double> probe{Box<double>{Eigen::Vector3d(0.3, 0.2, 0.1)}};
  const Pose<double> identity = Pose<double>::identity();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> coordinate(-2, 2), unit(-1, 1);
  int separated = 0;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Quaterniond q =
        Eigen::Quaterniond(unit(rng), unit(rng), unit(rng), unit(rng)).normalized();
    const Pose<double> pose = Pose<double>::from_quaternion(
        q, Eigen::Vector3d(coordinate(rng), coordinate(rng), coordinate(rng)));
    const DistanceResult<double> a = distance(full, identity, probe, pose);
    const DistanceResult<double> b = distance(reduced, identity, probe, pose);
    ASSERT_TRUE(a.status == Status::separated || a.status == Status::intersecting);
    EXPECT_EQ(a.status, b.status) << "pose " << i;
    EXPECT_NEAR(a.distance, b.distance, a.error_bound + b.error_bound + 1e-15) << "pose " << i;
    separated += a.status == Status::separated;
  }
  // Both verdicts must be exercised for the comparison to mean anything.
  EXPECT_GT(separated, 40);
  EXPECT_LT(separated, 180);

  const Shape<double> point = Shape<double>::sphere(0);
  for (const Eigen::Vector3d& v : source) {
    const DistanceResult<double> r = distance(
        reduced, identity, point, Pose<double>::from_quaternion(Eigen::Quaterniond::Identity(), v));
    EXPECT_LE(r.distance, r.error_bound + 1e-15) << v.transpose();
  }
}

TEST(MeshImport, ShippedMeshesKeepTheirConvexSet) {
  // The source vertices as written by make_meshes.py (star prism: tips and inner corners).
  std::vector<Eigen::Vector3d> star;
  const double ring[8][2] = {{2, 0},  {0.5, 0.5},   {0, 2},  {-0.5, 0.5},
                             {-2, 0}, {-0.5, -0.5}, {0, -2}, {0.5, -0.5}};
  for (double z : {0.0, 1.0})
    for (const auto& xy : ring) star.emplace_back(xy[0], xy[1], z);
  const MeshImport mesh = import_mesh(data("star_prism.obj"));
  ASSERT_TRUE(mesh.ok()) << mesh.error;
  expect_same_convex_set(star, mesh.pieces[0].vertices, 7);
}

TEST_F(MeshFiles, RandomCloudsKeepTheirConvexSet) {
  // Point clouds (OBJ `p` elements) in a ball of radius 1.5: most points are interior.
  // Coordinates are floats printed with 9 digits, so the file holds them exactly.
  std::mt19937 rng(20261121);
  std::uniform_real_distribution<float> unit(-1.5f, 1.5f);
  for (int cloud = 0; cloud < 5; ++cloud) {
    std::vector<Eigen::Vector3d> points;
    std::string text = "o cloud\n";
    char line[128];
    while (points.size() < 300) {
      const float x = unit(rng), y = unit(rng), z = unit(rng);
      if (x * x + y * y + z * z > 2.25f) continue;
      points.emplace_back(x, y, z);
      std::snprintf(line, sizeof line, "v %.9g %.9g %.9g\n", x, y, z);
      text += line;
    }
    text += "p";
    for (std::size_t i = 1; i <= points.size(); ++i) text += " " + std::to_string(i);
    text += "\n";
    const MeshImport mesh = import_mesh(write("cloud.obj", text));
    ASSERT_TRUE(mesh.ok()) << mesh.error;
    ASSERT_EQ(mesh.pieces.size(), 1u);
    EXPECT_EQ(mesh.pieces[0].source_vertex_count, points.size());
    const std::size_t kept = mesh.pieces[0].vertices.size();
    EXPECT_GT(kept, 20u);
    EXPECT_LT(kept, points.size() / 2);  // the hull really reduced the set
    expect_same_convex_set(points, mesh.pieces[0].vertices, 100 + cloud);
  }
}

}  // namespace
}  // namespace nearpoint::client
