// SPDX-License-Identifier: Apache-2.0
// Polytopes built with their hull's faces: the checks on the faces, and support by climbing the
// hull's edges against the linear scan; distances on climbing polytopes against CGAL's exact
// distance, cold and warm.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>

#include "common/checks.hpp"
#include "common/exact_distance.hpp"
#include "common/paper_family.hpp"
#include "nearpoint/distance.hpp"
#include "nearpoint/hull.hpp"
#include "support.hpp"

namespace nearpoint {
namespace {

using V = Vec3<double>;

std::vector<V> sphere_points(int n, const V& radii, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<V> points;
  for (int i = 0; i < n; ++i)
    points.push_back(radii.cwiseProduct(testkit::random_unit_vector(rng)));
  return points;
}

// The octahedron ±e_k: 6 vertices, 8 triangles counter-clockwise from outside.
std::vector<V> octahedron() {
  return {V(1, 0, 0), V(-1, 0, 0), V(0, 1, 0), V(0, -1, 0), V(0, 0, 1), V(0, 0, -1)};
}
std::vector<std::vector<int>> octahedron_faces() {
  return {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
}

TEST(PolytopeFaces, AcceptsAClosedConvexSurface) {
  const Polytope<double> p(octahedron(), octahedron_faces());
  EXPECT_EQ(p.invalid_reason(), nullptr);
  EXPECT_FALSE(p.climbs()) << "below the threshold the scan is used";
}

TEST(PolytopeFaces, RejectsBadFacesWithTheReason) {
  auto reason = [](std::vector<V> vertices, std::vector<std::vector<int>> faces) {
    const Polytope<double> p(vertices, faces);
    return std::string(p.invalid_reason() ? p.invalid_reason() : "valid");
  };
  auto faces = octahedron_faces();
  faces[0][1] = 6;
  EXPECT_NE(reason(octahedron(), faces).find("out of range"), std::string::npos);

  faces = octahedron_faces();
  faces.pop_back();
  EXPECT_NE(reason(octahedron(), faces).find("not closed"), std::string::npos);

  faces = octahedron_faces();
  std::reverse(faces[3].begin(), faces[3].end());
  EXPECT_NE(reason(octahedron(), faces).find("same direction"), std::string::npos);

  faces = octahedron_faces();
  for (auto& f : faces) std::reverse(f.begin(), f.end());
  EXPECT_NE(reason(octahedron(), faces).find("inwards"), std::string::npos);

  // The apex pushed below the equator: a closed, oriented surface that is not convex.
  auto sunk = octahedron();
  sunk[4] = V(0.05, 0.02, -0.3);  // the upper apex now inside: the upper faces fold in
  EXPECT_NE(reason(sunk, octahedron_faces()).find("not convex"), std::string::npos)
      << reason(sunk, octahedron_faces());

  auto extra = octahedron();
  extra.push_back(V(0, 0, 0));  // on no face
  EXPECT_NE(reason(extra, octahedron_faces()).find("on no face"), std::string::npos);

  // A quad face whose fourth vertex is off the plane of the other three.
  std::vector<V> box = {V(-1, -1, -1), V(1, -1, -1), V(1, 1, -1), V(-1, 1, -1),
                        V(-1, -1, 1),  V(1, -1, 1),  V(1, 1, 1),  V(-1, 1, 1)};
  const std::vector<std::vector<int>> box_faces = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                                   {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
  EXPECT_EQ(reason(box, box_faces), "valid");
  box[6] = V(1, 1, 1.3);
  EXPECT_NE(reason(box, box_faces).find("not planar"), std::string::npos);
}

TEST(PolytopeFaces, HullPolytopeOfDegenerateSetsScans) {
  const std::vector<V> flat = {V(0, 0, 0), V(1, 0, 0), V(0, 1, 0), V(1, 1, 0), V(0.5, 0.5, 0)};
  const Polytope<double> p = hull_polytope(flat);
  EXPECT_EQ(p.invalid_reason(), nullptr);
  EXPECT_FALSE(p.climbs());
  EXPECT_EQ(p.size(), 4u) << "the interior point is dropped";
  const std::vector<V> bad = {V(0, 0, 0), V(NAN, 0, 0)};
  EXPECT_NE(hull_polytope(bad).invalid_reason(), nullptr);
}

// The climb must reach the scan's maximum value (not necessarily the same index on ties), from
// any hint, in any direction, including directions along the axes and exactly normal to faces.
TEST(HillClimb, ReachesTheScanMaximumFromAnyStart) {
  for (const int n : {64, 200, 3000}) {
    const std::vector<V> points = sphere_points(n, V(1, 0.6, 0.35), 7 + n);
    const Polytope<double> climbing = hull_polytope(points);
    ASSERT_EQ(climbing.invalid_reason(), nullptr);
    ASSERT_TRUE(climbing.climbs()) << n;
    std::vector<V> hull_vertices;
    for (std::size_t i = 0; i < climbing.size(); ++i) hull_vertices.push_back(climbing.vertex(i));
    const Polytope<double> scanning(hull_vertices);
    std::mt19937_64 rng(11);
    std::vector<V> directions = {V(1, 0, 0), V(0, -1, 0), V(0, 0, 1), V(1, 1, 1)};
    for (int k = 0; k < 2000; ++k) directions.push_back(testkit::random_unit_vector(rng));
    std::uniform_int_distribution<int> any(-1, int(climbing.size()) - 1);
    for (const V& d : directions) {
      const std::size_t s = scanning.support_index(d);
      const std::size_t c = climbing.support_index(d, any(rng));
      // The same maximum, within the rounding that separates the two polytopes' coordinates:
      // `scanning` re-centres the vertices `climbing` had centred (v + c₁ − c₂, rounded), so
      // two vertices whose values differ by an ulp may swap places. g++ builds happened to
      // agree to the bit; the clang tree (fuzz and ASan stages) found a pair that does not.
      const double scan_max = scanning.centered_vertex(s).dot(d);
      const double recentring =
          4 * std::numeric_limits<double>::epsilon() *
          (1 + climbing.extent() + climbing.centroid().norm() + scanning.centroid().norm());
      EXPECT_NEAR(climbing.centered_vertex(c).dot(d), scan_max,
                  std::max(recentring, testkit::fused_rounding_slack(scan_max, 1e-15)))
          << "n=" << n << " d=" << d.transpose();
    }
  }
}

// A climb starts from the seed along the grid direction nearest d, found by scaling d to the grid
// and rounding. Directions of any scale (subnormal to 1e300), on the grid's own lines or between
// them must still reach the maximum, and zero, infinite and NaN directions must give a valid
// vertex.
TEST(HillClimb, DirectionsOfAnyScaleOrNoneGiveAValidVertex) {
  const Polytope<double> climbing = hull_polytope(sphere_points(2000, V(1, 0.6, 0.35), 31));
  ASSERT_TRUE(climbing.climbs());
  std::vector<V> hull_vertices;
  for (std::size_t i = 0; i < climbing.size(); ++i) hull_vertices.push_back(climbing.vertex(i));
  const Polytope<double> scanning(hull_vertices);
  const double tiny = std::numeric_limits<double>::denorm_min();
  const std::vector<V> directions = {V(tiny, 0, 0),
                                     V(tiny, -tiny, 3 * tiny),
                                     V(1e-300, 2e-300, -3e-300),
                                     V(1e300, -2e300, 5e299),
                                     V(4, 2, -0.5),
                                     V(-1, 0.125, 0.875),
                                     V(0.5, 0.5, 0.5),
                                     V(1, 0.375, 0.625),
                                     V(-1e-5, 1, 1e-5),
                                     V(3, -3, 3)};
  for (const V& d : directions) {
    for (const std::int32_t hint : {-1, 0, int(climbing.size()) - 1}) {
      const std::size_t c = climbing.support_index(d, hint);
      ASSERT_LT(c, climbing.size());
      EXPECT_EQ(climbing.centered_vertex(c).dot(d),
                scanning.centered_vertex(scanning.support_index(d)).dot(d))
          << "d=" << d.transpose() << " hint " << hint;
    }
  }
  const double inf = std::numeric_limits<double>::infinity();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const V& d : {V(0, 0, 0), V(inf, 1, 0), V(-inf, inf, 0), V(nan, 1, 1), V(nan, nan, nan)})
    for (const std::int32_t hint : {-1, 5})
      EXPECT_LT(climbing.support_index(d, hint), climbing.size()) << d.transpose();
}

// Two climbing polytopes searched in one call (PairScan: the climbs step in turn) give exactly
// what each polytope's own climb gives from the same hint, and so the scan's maximum value.
TEST(HillClimb, PairedClimbsEqualSeparateClimbs) {
  const Polytope<double> a = hull_polytope(sphere_points(500, V(1, 1, 1), 21));
  const Polytope<double> b = hull_polytope(sphere_points(3000, V(1, 0.6, 0.35), 22));
  ASSERT_TRUE(a.climbs() && b.climbs());
  std::vector<V> vertices_b;
  for (std::size_t i = 0; i < b.size(); ++i) vertices_b.push_back(b.vertex(i));
  const Polytope<double> b_scanning(vertices_b);
  std::mt19937_64 rng(23);
  std::uniform_int_distribution<int> hint_a(-1, int(a.size()) - 1), hint_b(-1, int(b.size()) - 1);
  for (int k = 0; k < 2000; ++k) {
    const V da = testkit::random_unit_vector(rng), db = testkit::random_unit_vector(rng);
    const std::int32_t ha = hint_a(rng), hb = hint_b(rng);
    const detail::IndexPair index = detail::PairScan::support_indices(
        a, da.x(), da.y(), da.z(), ha, b, db.x(), db.y(), db.z(), hb);
    EXPECT_EQ(index.a, a.support_index(da, ha)) << k;
    EXPECT_EQ(index.b, b.support_index(db, hb)) << k;
    double top = -1e300;  // the maximum over every vertex, by brute force
    for (std::size_t i = 0; i < b.size(); ++i) top = std::max(top, b.centered_vertex(i).dot(db));
    EXPECT_EQ(b.centered_vertex(index.b).dot(db), top) << k;
  }
  // One climbing and one scanning polytope: each searched its own way.
  const V d(0.3, -0.2, 0.9);
  const detail::IndexPair index = detail::PairScan::support_indices(
      a, d.x(), d.y(), d.z(), -1, b_scanning, d.x(), d.y(), d.z(), -1);
  EXPECT_EQ(index.a, a.support_index(d));
  EXPECT_EQ(index.b, b_scanning.support_index(d));
}

// Distances on climbing polytopes, cold and warm along a path, against CGAL's exact distance.
TEST(HillClimb, DistancesMatchTheExactDistanceColdAndWarm) {
  const std::vector<V> a_points = sphere_points(2000, V(1, 1, 1), 1);
  const std::vector<V> b_points = sphere_points(2000, V(1, 0.6, 0.35), 2);
  const Shape<double> a(hull_polytope(a_points)), b(hull_polytope(b_points));
  ASSERT_TRUE(std::get<Polytope<double>>(a.geometry).climbs());
  SimplexCache cache;
  DistanceOptions<double> options;
  int checked = 0, intersecting = 0;
  for (int step = 0; step < 200; ++step) {
    const double s = step / 200.0, theta = 2 * std::acos(-1.0) * s;
    Pose<double> pose;
    const double rho = 1.6 + 0.5 * std::cos(3 * theta);
    pose.translation = V(rho * std::cos(theta), rho * std::sin(theta), 0.25 * std::sin(2 * theta));
    pose.rotation = Eigen::AngleAxisd(4 * theta, V(1, 2, 3).normalized()).toRotationMatrix();
    const auto cold = distance(a, Pose<double>::identity(), b, pose, options);
    const auto warm = distance(a, Pose<double>::identity(), b, pose, options, &cache);
    ASSERT_TRUE(cold.converged()) << step;
    ASSERT_TRUE(warm.converged()) << step;
    if (step % 10 != 0) {
      EXPECT_NEAR(cold.distance, warm.distance, cold.error_bound + warm.error_bound) << step;
      continue;
    }
    const testkit::ExactDistance exact =
        testkit::exact_distance<double>(a_points, Pose<double>::identity(), b_points, pose);
    ++checked;
    intersecting += exact.intersecting;
    for (const auto* r : {&cold, &warm}) {
      EXPECT_EQ(r->status == Status::intersecting, exact.intersecting) << step;
      EXPECT_LE(std::abs(r->distance - exact.distance), r->error_bound) << step;
      EXPECT_LE(std::abs(r->distance - exact.distance), 1e-14) << step;
    }
  }
  EXPECT_EQ(checked, 20);
  EXPECT_GT(intersecting, 0);
  EXPECT_LT(intersecting, checked);
}

}  // namespace
}  // namespace nearpoint
