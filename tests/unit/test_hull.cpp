// SPDX-License-Identifier: Apache-2.0
// nearpoint::convex_hull and hull_polytope at the boundary (issue 21, item 1): the hull is
// canonical (the same input gives the same vertices, order and faces in any process state), hulls
// we build are always accepted as polytopes with faces (also far from the origin), and nearly flat
// sets keep their extreme points. Distances are checked against CGAL's exact distance.
#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <memory>
#include <random>

#include "common/exact_distance.hpp"
#include "common/paper_family.hpp"
#include "nearpoint/distance.hpp"
#include "nearpoint/hull.hpp"

namespace nearpoint {
namespace {

using V = Vec3<double>;

std::vector<V> sphere_points(int n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<V> points;
  for (int i = 0; i < n; ++i) points.push_back(testkit::random_unit_vector(rng));
  return points;
}

// A cube with a 5 × 5 grid on each face: many coplanar points, so which triangles CGAL emits for
// a face depends on its internal order.
std::vector<V> gridded_cube() {
  std::vector<V> points;
  for (int i = 0; i <= 4; ++i)
    for (int j = 0; j <= 4; ++j)
      for (int k = 0; k <= 4; ++k)
        if (i % 4 == 0 || j % 4 == 0 || k % 4 == 0) points.emplace_back(i - 2.0, j - 2.0, k - 2.0);
  return points;
}

// The paper's polytope `number` (M = 100 for 11 and 12) placed in world coordinates by `pose`.
std::vector<V> posed_paper_polytope(int number, const Pose<double>& pose) {
  static const auto polytopes = testkit::paper_polytopes();
  std::vector<V> world;
  for (const V& v : *polytopes[std::size_t(number - 1)].vertices) world.push_back(pose.apply(v));
  return world;
}

Pose<double> far_pose(std::mt19937_64& rng, double distance) {
  std::normal_distribution<double> normal;
  const Eigen::Quaterniond q(normal(rng), normal(rng), normal(rng), normal(rng));
  return Pose<double>::from_quaternion(q, distance * testkit::random_unit_vector(rng));
}

bool same_bits(const Hull& x, const Hull& y) {
  if (x.dimension != y.dimension || x.vertices.size() != y.vertices.size() ||
      x.input_index != y.input_index || x.faces != y.faces)
    return false;
  return std::memcmp(x.vertices.data(), y.vertices.data(), x.vertices.size() * sizeof(V)) == 0;
}

// Guards the canonical order: CGAL's convex_hull_3 emits vertices and faces in an order that
// follows the addresses of its internal nodes, i.e. the heap's state, so without relabelling the
// same input gave a different vertex order (and answers differing in the last bit) once other
// hulls had been built in the process.
TEST(ConvexHull, IsCanonicalInAnyHeapState) {
  std::mt19937_64 rng(21);
  std::vector<std::vector<V>> inputs = {sphere_points(500, 1), gridded_cube(),
                                        posed_paper_polytope(11, far_pose(rng, 3000)),
                                        posed_paper_polytope(12, far_pose(rng, 50))};
  std::vector<Hull> first;
  for (const auto& input : inputs) first.push_back(convex_hull(input));

  // Stir the heap: hulls of other sets kept alive and freed in between, blocks of odd sizes.
  std::vector<std::unique_ptr<char[]>> blocks;
  std::vector<Hull> others;
  for (int round = 0; round < 6; ++round) {
    for (int i = 0; i < 200; ++i) blocks.emplace_back(new char[std::size_t(16 + 40 * (i % 13))]);
    others.push_back(convex_hull(sphere_points(300 + 50 * round, 100 + std::uint64_t(round))));
    for (std::size_t i = std::size_t(round % 2); i < blocks.size(); i += 2) blocks[i].reset();
    for (std::size_t k = 0; k < inputs.size(); ++k) {
      const Hull again = convex_hull(inputs[k]);
      EXPECT_TRUE(same_bits(first[k], again)) << "input " << k << ", round " << round;
    }
  }

  // The canonical form itself: vertices in input order, each face starting at its smallest
  // vertex, faces in lexicographic order.
  for (const Hull& hull : first) {
    ASSERT_EQ(hull.dimension, 3);
    EXPECT_TRUE(std::is_sorted(hull.input_index.begin(), hull.input_index.end()));
    for (const auto& face : hull.faces)
      EXPECT_EQ(face.front(), *std::min_element(face.begin(), face.end()));
    EXPECT_TRUE(std::is_sorted(hull.faces.begin(), hull.faces.end()));
  }
}

// Guards the polytope-faces check on hulls we build: the paper's M = 100 polytopes placed far from
// the origin have coplanar caps, whose triangles' convexity test was refused by rounding of the
// centred vertices. Every such hull must be accepted, climb, and give the exact distance.
TEST(HullPolytope, AcceptsThePaperPolytopesInWorldCoordinates) {
  std::mt19937_64 rng(1988);
  const std::vector<V> probe = sphere_points(40, 7);
  int checked = 0;
  for (const double reach : {10.0, 1e3, 1e5, 1e7}) {
    for (const int number : {11, 12}) {
      for (int draw = 0; draw < 3; ++draw) {
        const std::vector<V> world = posed_paper_polytope(number, far_pose(rng, reach));
        const Polytope<double> polytope = hull_polytope(world);
        ASSERT_EQ(polytope.invalid_reason(), nullptr)
            << "polytope " << number << " at " << reach << ": " << polytope.invalid_reason();
        EXPECT_TRUE(polytope.climbs());
        // A probe near the polytope (its first vertex plus a unit-ball offset).
        Pose<double> probe_pose;
        probe_pose.translation = world[0] + V(2.5, -1.0, 0.5);
        const auto result = distance(Shape<double>(polytope), Pose<double>::identity(),
                                     Shape<double>(Polytope<double>(probe)), probe_pose);
        const testkit::ExactDistance exact =
            testkit::exact_distance<double>(world, Pose<double>::identity(), probe, probe_pose);
        ASSERT_TRUE(result.converged());
        EXPECT_EQ(result.status == Status::intersecting, exact.intersecting);
        // Within error_bound alone: the engine forms the offset of a shape modelled far from its
        // local origin with compensated arithmetic (issue 21 item 10), so no slack for the world
        // coordinates' rounding is needed.
        EXPECT_LE(std::abs(result.distance - exact.distance), result.error_bound)
            << "polytope " << number << " at " << reach;
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked, 24);
}

// Guards the convexity check's rounding allowance: the paper's polytopes 7-12 with random
// rotations have nearly coplanar caps, and their exact hulls have sliver triangles next to them.
// The check recomputes each edge's convexity from the centred (rounded) vertices, and its
// allowance ignored that rounding, which does not shrink with the triangle: about 1 in 100 such
// hulls was refused as "not convex", near the origin as well as far from it. Every one must be
// accepted, by hull_polytope and when a caller passes the hull's faces itself (full check); a
// dented surface is still refused (PolytopeFaces.RejectsBadFacesWithTheReason, test_hill_climb).
TEST(HullPolytope, ExactHullsOfRotatedPaperPolytopesAreAlwaysAccepted) {
  std::mt19937_64 rng(5);
  int hulls = 0;
  for (const double reach : {0.0, 1.0, 3.0})
    for (int number = 7; number <= 12; ++number)
      for (int draw = 0; draw < 80; ++draw) {
        const std::vector<V> world = posed_paper_polytope(number, far_pose(rng, reach));
        const Hull hull = convex_hull(world);
        ASSERT_EQ(hull.dimension, 3);
        const Polytope<double> given(hull.vertices, hull.faces);
        ASSERT_EQ(given.invalid_reason(), nullptr)
            << "polytope " << number << " at " << reach << ", draw " << draw << ": "
            << given.invalid_reason();
        if (draw % 8 == 0) {
          ASSERT_EQ(hull_polytope(world).invalid_reason(), nullptr);
        }
        ++hulls;
      }
  EXPECT_EQ(hulls, 3 * 6 * 80);
}

// Guards the choice of the projection axis of a flat set: it came from a double cross product
// that underflows for sub-normal offsets (here the normal is along y, yet the product is zero), so
// the set was projected onto a line and its extreme points along x were dropped. The four
// points plus 60 copies (the server builds hulls from 64 vertices up).
TEST(ConvexHull, FlatSetsWithTinyOffsetsKeepTheirExtremePoints) {
  const std::vector<V> corners = {V(-8, 1.5, 0), V(-8.000002, 1.5, 1e-319),
                                  V(-8.000001, 1.5, -1e-319), V(-7.999997, 1.5, 0)};
  std::vector<V> points;
  for (int copy = 0; copy < 16; ++copy) points.insert(points.end(), corners.begin(), corners.end());
  ASSERT_EQ(points.size(), 64u);
  const Hull hull = convex_hull(points);
  EXPECT_EQ(hull.dimension, 2);
  const Polytope<double> polytope = hull_polytope(points);
  ASSERT_EQ(polytope.invalid_reason(), nullptr);
  const std::vector<V> probe = {V(0, 0, 0)};
  for (const V& at : {V(0, 0, 0), V(5, 1.5, 0), V(-20, 1.5, 0), V(-8, 3, 0)}) {
    Pose<double> pose;
    pose.translation = at;
    const auto result = distance(Shape<double>(polytope), Pose<double>::identity(),
                                 Shape<double>(Polytope<double>(probe)), pose);
    const auto exact =
        testkit::exact_distance<double>(points, Pose<double>::identity(), probe, pose);
    EXPECT_LE(std::abs(result.distance - exact.distance), result.error_bound + 1e-13)
        << "probe at " << at.transpose() << ": " << result.distance << " vs " << exact.distance;
  }
}

}  // namespace
}  // namespace nearpoint
