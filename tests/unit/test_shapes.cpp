// SPDX-License-Identifier: Apache-2.0
// Unit tests of the support functions (eq. 15–17), centres and extents (eq. 34, 37), input
// validation, and poses.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "nearpoint/distance.hpp"
#include "support.hpp"

namespace nearpoint {
namespace {

using V = Vec3<double>;

// Dense samples of each shape's boundary, from its own definition (not from the support code).
std::vector<V> boundary_samples(const Shape<double>& shape, int n) {
  std::vector<V> out;
  const double pi = std::acos(-1.0);
  struct Sampler {
    int n;
    double pi;
    std::vector<V>& out;
    void operator()(const Point&) { out.push_back(V::Zero()); }
    void operator()(const Segment<double>& s) {
      out.push_back(s.a);
      out.push_back(s.b);
    }
    void operator()(const Box<double>& b) {
      for (int i = 0; i < 8; ++i)
        out.emplace_back(i & 1 ? b.half_extents.x() : -b.half_extents.x(),
                         i & 2 ? b.half_extents.y() : -b.half_extents.y(),
                         i & 4 ? b.half_extents.z() : -b.half_extents.z());
    }
    void operator()(const Polytope<double>& p) {
      for (std::size_t i = 0; i < p.size(); ++i) out.push_back(p.vertex(i));
    }
    void operator()(const Cylinder<double>& c) {
      for (int i = 0; i < n; ++i) {
        const double t = 2 * pi * i / n;
        out.emplace_back(c.radius * std::cos(t), c.radius * std::sin(t), c.half_height);
        out.emplace_back(c.radius * std::cos(t), c.radius * std::sin(t), -c.half_height);
      }
    }
    void operator()(const Cone<double>& c) {
      out.emplace_back(0, 0, c.half_height);
      for (int i = 0; i < n; ++i) {
        const double t = 2 * pi * i / n;
        out.emplace_back(c.radius * std::cos(t), c.radius * std::sin(t), -c.half_height);
      }
    }
    void operator()(const Ellipsoid<double>& e) {
      for (int i = 0; i <= n / 4; ++i)
        for (int j = 0; j < n; ++j) {
          const double th = pi * i / (n / 4), ph = 2 * pi * j / n;
          out.emplace_back(e.radii.x() * std::sin(th) * std::cos(ph),
                           e.radii.y() * std::sin(th) * std::sin(ph), e.radii.z() * std::cos(th));
        }
    }
  } sampler{n, pi, out};
  std::visit(sampler, shape.geometry);
  return out;
}

std::vector<Shape<double>> all_shapes() {
  std::vector<V> verts = {V(0.3, 0.1, 2), V(-1, 0, 0.5), V(1, -1, 0.2), V(0, 2, -1),
                          V(0.1, 0.1, 0.1)};
  return {Shape<double>(Point{}),
          Shape<double>(Segment<double>{V(-1, 2, 0), V(3, 0.5, 1)}),
          Shape<double>(Box<double>{V(1, 2, 0.5)}),
          Shape<double>(Polytope<double>(verts)),
          Shape<double>(Cylinder<double>{0.7, 1.3}),
          Shape<double>(Cone<double>{1.1, 0.9}),
          Shape<double>(Ellipsoid<double>{V(0.5, 1.5, 2.5)})};
}

// Guards eq. (16): s(η)·η = h(η) ≥ x·η for every point x of the shape; and the returned point
// lies in the shape (checked through the extent bound about the centre).
TEST(Support, MaximisesOverTheShape) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (const Shape<double>& shape : all_shapes()) {
    const std::vector<V> samples = boundary_samples(shape, 720);
    const V center = core_center(shape);
    const double extent = core_extent(shape);
    for (const V& x : samples) EXPECT_LE((x - center).norm(), extent * (1 + 1e-12) + 1e-15);
    for (int trial = 0; trial < 300; ++trial) {
      const V d(normal(rng), normal(rng), normal(rng));
      int index = -2;
      const V s = support(shape, d, index);
      double sampled_max = -1e300;
      for (const V& x : samples) sampled_max = std::max(sampled_max, x.dot(d));
      // Sampled boundaries of curved shapes fall short of the true maximum by O(1/n²).
      EXPECT_GE(s.dot(d), sampled_max - 1e-4 * d.norm()) << "shape " << shape.geometry.index();
      EXPECT_LE((s - center).norm(), extent * (1 + 1e-12) + 1e-15);
      EXPECT_NE(index, -2);
    }
  }
}

// Vertex indices must name the returned vertex: the warm-start cache relies on it.
TEST(Support, IndicesNameTheVertex) {
  std::mt19937_64 rng(4);
  std::normal_distribution<double> normal(0.0, 1.0);
  const Box<double> box{V(1, 2, 3)};
  const detail::Support<Box<double>, double> s{box};
  for (int trial = 0; trial < 100; ++trial) {
    const V d(normal(rng), normal(rng), normal(rng));
    std::int32_t index = -1;
    const V p = s.support(d, index);
    V q;
    ASSERT_TRUE(s.vertex(index, q));
    EXPECT_EQ(p, q);
  }
}

// The paired scan (two polytopes in one interleaved pass) returns for each polytope the first
// vertex of largest x·dx + y·dy + z·dz, as a plain loop over the vertices finds it: for sizes on
// both sides of the scan's blocks and of each other, with exact ties (repeated vertices, axis
// directions) and a NaN direction (vertex 0), in both precisions.
template <class S>
std::size_t first_maximiser(const Polytope<S>& p, const Vec3<S>& d) {
  std::size_t best = 0;
  S best_value = -std::numeric_limits<S>::infinity();
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Vec3<S> v = p.centered_vertex(i);
    const S value = v.x() * d.x() + v.y() * d.y() + v.z() * d.z();
    if (value > best_value) {
      best_value = value;
      best = i;
    }
  }
  return best;
}

template <class S>
void check_pair_scan() {
  std::mt19937_64 rng(17);
  std::uniform_int_distribution<int> coordinate(-3, 3);  // small integers: many exact ties
  std::normal_distribution<double> normal(0.0, 1.0);
  auto random_polytope = [&](int n) {
    std::vector<Vec3<S>> vertices;
    for (int i = 0; i < n; ++i)
      vertices.emplace_back(S(coordinate(rng)), S(coordinate(rng)), S(coordinate(rng)));
    if (n > 2) vertices[std::size_t(n - 1)] = vertices[0];  // a repeated vertex
    return Polytope<S>(vertices);
  };
  const S nan = std::numeric_limits<S>::quiet_NaN();
  int compared = 0;
  for (const int na : {1, 3, 8, 9, 16, 17, 40}) {
    for (const int nb : {1, 5, 8, 24, 33}) {
      const Polytope<S> a = random_polytope(na), b = random_polytope(nb);
      for (int trial = 0; trial < 40; ++trial) {
        Vec3<S> da(S(normal(rng)), S(normal(rng)), S(normal(rng)));
        Vec3<S> db(S(normal(rng)), S(normal(rng)), S(normal(rng)));
        if (trial % 4 == 1) da = Vec3<S>::Unit(trial % 3);
        if (trial % 4 == 2) db = -Vec3<S>::Unit(trial % 3);
        if (trial == 39) da = Vec3<S>(nan, 0, 0);
        const detail::IndexPair index = detail::PairScan::support_indices(
            a, da.x(), da.y(), da.z(), -1, b, db.x(), db.y(), db.z(), -1);
        const std::size_t expect_a = trial == 39 ? 0 : first_maximiser(a, da);
        EXPECT_EQ(index.a, expect_a) << "A: " << na << " vertices, trial " << trial;
        EXPECT_EQ(index.b, first_maximiser(b, db)) << "B: " << nb << " vertices, trial " << trial;
        EXPECT_EQ(index.a, a.support_index(da)) << "same as the single scan";
        EXPECT_EQ(index.b, b.support_index(db)) << "same as the single scan";
        ++compared;
      }
    }
  }
  EXPECT_EQ(compared, 7 * 5 * 40);
}

TEST(Support, PairedScanFindsEachPolytopesFirstMaximiser) {
  check_pair_scan<double>();
  check_pair_scan<float>();
}

// Zero and tiny directions must still give a point of the shape (never NaN).
TEST(Support, DegenerateDirectionsGiveFinitePoints) {
  for (const Shape<double>& shape : all_shapes()) {
    for (const V& d : {V(0, 0, 0), V(1e-300, 0, 0), V(0, 0, 1e-200), V(1e300, -1e300, 0)}) {
      int index = 0;
      const V p = support(shape, d, index);
      EXPECT_TRUE(p.allFinite()) << shape.geometry.index();
    }
  }
}

TEST(Polytope, CentroidAndExtentFollowEq34And37) {
  std::vector<V> verts = {V(1e6 + 1, 0, 0), V(1e6 - 1, 0, 0), V(1e6, 2, 0), V(1e6, -2, 0)};
  const Polytope<double> p(verts);
  ASSERT_EQ(p.invalid_reason(), nullptr);
  EXPECT_EQ(p.centroid(), V(1e6, 0, 0));
  EXPECT_DOUBLE_EQ(p.extent(), 2.0);
  EXPECT_EQ(p.vertex(2), verts[2]);
}

// Bad input gets a reason, never a crash or a NaN result.
TEST(Validation, BadShapesAndPosesAreRejectedWithAReason) {
  const double nan = std::nan("");
  const std::vector<V> empty;
  const std::vector<Shape<double>> bad = {
      Shape<double>(Polytope<double>(empty)),
      Shape<double>(Polytope<double>(std::vector<V>{V(0, nan, 0)})),
      Shape<double>(Box<double>{V(1, -1, 1)}),
      Shape<double>(Point{}, -1.0),
      Shape<double>(Point{}, nan),
      Shape<double>(Ellipsoid<double>{V(1, INFINITY, 1)}),
      Shape<double>(Segment<double>{V(0, 0, 0), V(nan, 0, 0)}),
      Shape<double>(Cylinder<double>{-1, 1}),
      Shape<double>(Cone<double>{1, nan}),
  };
  const Shape<double> good = Shape<double>::sphere(1);
  for (const Shape<double>& s : bad) {
    for (int side = 0; side < 2; ++side) {
      const auto r = side ? distance(s, Pose<double>{}, good, Pose<double>{})
                          : distance(good, Pose<double>{}, s, Pose<double>{});
      EXPECT_EQ(r.status, Status::invalid_input);
      ASSERT_NE(r.message, nullptr);
      EXPECT_GT(std::string(r.message).size(), 10u);
    }
  }
  Pose<double> nan_pose;
  nan_pose.translation.x() = nan;
  EXPECT_EQ(distance(good, nan_pose, good, Pose<double>{}).status, Status::invalid_input);
  Pose<double> skew;
  skew.rotation(0, 1) = 0.5;
  EXPECT_EQ(distance(good, Pose<double>{}, good, skew).status, Status::invalid_input);
  Pose<double> mirror;
  mirror.rotation(2, 2) = -1;
  EXPECT_EQ(distance(good, Pose<double>{}, good, mirror).status, Status::invalid_input);
}

TEST(Pose, QuaternionCheckAcceptsNearUnitAndRejectsTheRest) {
  Pose<double> p;
  EXPECT_EQ(pose_from_quaternion_checked(1.0, 0.0, 0.0, 0.0, V(1, 2, 3), p), nullptr);
  EXPECT_EQ(p.translation, V(1, 2, 3));
  const double h = std::sqrt(0.5);
  EXPECT_EQ(pose_from_quaternion_checked(h * (1 + 5e-5), h, 0.0, 0.0, V::Zero(), p), nullptr);
  EXPECT_NEAR((p.rotation.transpose() * p.rotation - Mat3<double>::Identity()).norm(), 0, 1e-15);
  EXPECT_NE(pose_from_quaternion_checked(2.0, 0.0, 0.0, 0.0, V::Zero(), p), nullptr);
  EXPECT_NE(pose_from_quaternion_checked(0.0, 0.0, 0.0, 0.0, V::Zero(), p), nullptr);
  EXPECT_NE(pose_from_quaternion_checked(std::nan(""), 0.0, 0.0, 1.0, V::Zero(), p), nullptr);
  EXPECT_NE(pose_from_quaternion_checked(1.0, 0.0, 0.0, 0.0, V(0, INFINITY, 0), p), nullptr);
  // compose/inverse round trip
  Pose<double> a =
      Pose<double>::from_quaternion(Eigen::Quaterniond(0.9, 0.1, -0.3, 0.2), V(1, 2, 3));
  const Pose<double> id = a.compose(a.inverse());
  EXPECT_NEAR((id.rotation - Mat3<double>::Identity()).norm(), 0, 1e-15);
  EXPECT_NEAR(id.translation.norm(), 0, 1e-15);
}

// Two points (spheres' cores) are answered without the GJK loop (detail::point_pair_outcome):
// K is one point, so g = 0 and Theorem 1 certifies ν exactly. Guards that closed form against
// the loop itself, which runs for a one-vertex polytope with the same radius: same verdict,
// distances and near points within the bounds, a bound no weaker, the loop's exits (cutoff,
// contact, coincident centres) and its warm-start reading of the cache, far from the origin and
// at tiny and huge scales (the rescaled path) too.
TEST(PointPair, ClosedFormAgreesWithTheLoop) {
  std::mt19937_64 rng(25);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> unit(0, 1);
  const std::vector<V> origin = {V::Zero()};
  int separated = 0, total = 0;
  for (const double scale : {1e-200, 1e-6, 1.0, 1e5, 1e200}) {
    for (const double far : {0.0, 1e6}) {
      for (int k = 0; k < 200; ++k) {
        const double ra = scale * unit(rng), rb = scale * unit(rng);
        const Shape<double> sa = Shape<double>::sphere(ra), sb = Shape<double>::sphere(rb);
        const Shape<double> pa(Polytope<double>(origin), ra), pb(Polytope<double>(origin), rb);
        const V u = V(normal(rng), normal(rng), normal(rng)).normalized();
        const Pose<double> a = Pose<double>::from_quaternion(
            Eigen::Quaterniond(normal(rng), normal(rng), normal(rng), normal(rng)),
            V(far, -far, 0.5 * far));
        const Pose<double> b = Pose<double>::from_quaternion(
            Eigen::Quaterniond(normal(rng), normal(rng), normal(rng), normal(rng)),
            a.translation + (k == 0 ? 0.0 : 2.5 * scale * unit(rng)) * u);
        for (const bool near_points : {true, false}) {
          for (const double cutoff : {std::numeric_limits<double>::infinity(), 0.0}) {
            DistanceOptions<double> options;
            options.near_points = near_points;
            options.distance_cutoff = cutoff;
            const DistanceResult<double> closed = distance(sa, a, sb, b, options);
            const DistanceResult<double> loop = distance(pa, a, pb, b, options);
            ASSERT_NE(closed.status, Status::invalid_input) << closed.message;
            ASSERT_EQ(closed.status, loop.status) << "scale " << scale << " k " << k;
            EXPECT_EQ(closed.beyond_cutoff(), loop.beyond_cutoff());
            // No weaker, up to the rounding of L itself: beyond the cutoff the answer is the
            // lower end L of [L, |ν|], and the loop's L = ν·w/|ν| may round an ulp above the
            // closed form's L = |ν|.
            const double ulps_of_distance =
                closed.beyond_cutoff()
                    ? 4 * std::numeric_limits<double>::epsilon() * closed.distance
                    : 0.0;
            EXPECT_LE(closed.error_bound,
                      loop.error_bound * (1 + 1e-12) + ulps_of_distance + 1e-300);
            EXPECT_LE(std::abs(closed.distance - loop.distance),
                      closed.error_bound + loop.error_bound);
            EXPECT_EQ(closed.support_calls, loop.support_calls);
            EXPECT_EQ(closed.subalgorithm_runs, loop.subalgorithm_runs);
            EXPECT_EQ(closed.simplex_size, 1);
            if (near_points) {
              const double tolerance = closed.error_bound + loop.error_bound + 1e-15 * far;
              EXPECT_LE((closed.point_a - loop.point_a).norm(), tolerance);
              EXPECT_LE((closed.point_b - loop.point_b).norm(), tolerance);
            }
            // A warm start from the query's own cache: read as the loop reads it.
            SimplexCache cache_closed, cache_loop;
            distance(sa, a, sb, b, options, &cache_closed);
            distance(pa, a, pb, b, options, &cache_loop);
            const DistanceResult<double> warm_closed =
                distance(sa, a, sb, b, options, &cache_closed);
            const DistanceResult<double> warm_loop = distance(pa, a, pb, b, options, &cache_loop);
            EXPECT_EQ(warm_closed.warm_started, warm_loop.warm_started);
            EXPECT_EQ(warm_closed.status, warm_loop.status);
            EXPECT_EQ(warm_closed.support_calls, warm_loop.support_calls);
            separated += closed.status == Status::separated;
            ++total;
          }
        }
      }
    }
  }
  // A representative sample: both verdicts well represented.
  EXPECT_GT(separated, total / 5);
  EXPECT_LT(separated, 4 * total / 5);
}

// Two segments (capsules' cores) are answered from the closed form of their nearest points,
// certified by one support call (detail::segment_pair_outcome), or by the loop when that
// certificate fails. Guards it against the loop itself, which runs for two-vertex polytopes with
// the same end points and radii: same verdict, distances and near points within the bounds,
// bounds that hold against the other answer; random, parallel, crossing and zero-length segments,
// at tiny and huge scales and 1e6 from the origin.
TEST(SegmentPair, ClosedFormAgreesWithTheLoop) {
  std::mt19937_64 rng(26);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> unit(0, 1);
  int separated = 0, total = 0;
  for (const double scale : {1e-200, 1e-6, 1.0, 1e5, 1e200}) {
    for (const double far : {0.0, 1e6}) {
      for (int k = 0; k < 300; ++k) {
        const auto point = [&]() -> V { return scale * V(normal(rng), normal(rng), normal(rng)); };
        V a0 = point(), a1 = point(), b0 = point(), b1 = point();
        if (k % 5 == 1) b1 = b0 + (a1 - a0) * (0.3 + unit(rng));  // parallel
        if (k % 5 == 2) a1 = a0;                                  // a point
        if (k % 5 == 3) {                                         // crossing
          const V m = 0.5 * (a0 + a1);
          b1 = m + (m - b0);
        }
        const double ra = (k % 3 == 0 ? 0.0 : 0.3) * scale * unit(rng);
        const double rb = (k % 4 == 0 ? 0.0 : 0.3) * scale * unit(rng);
        const Shape<double> sa = Shape<double>::capsule(a0, a1, ra);
        const Shape<double> sb = Shape<double>::capsule(b0, b1, rb);
        const std::vector<V> va = {a0, a1}, vb = {b0, b1};
        const Shape<double> pa(Polytope<double>(va), ra), pb(Polytope<double>(vb), rb);
        const Pose<double> a = Pose<double>::from_quaternion(
            Eigen::Quaterniond(normal(rng), normal(rng), normal(rng), normal(rng)),
            V(far, -far, 0.5 * far));
        const Pose<double> b = Pose<double>::from_quaternion(
            Eigen::Quaterniond(normal(rng), normal(rng), normal(rng), normal(rng)),
            k % 5 == 3 ? a.translation : V(a.translation + 2.0 * point()));
        const Pose<double> b_pose = k % 5 == 3 ? a : b;  // crossing: same frame
        for (const bool near_points : {true, false}) {
          for (const double cutoff : {std::numeric_limits<double>::infinity(), 0.0}) {
            DistanceOptions<double> options;
            options.near_points = near_points;
            options.distance_cutoff = cutoff;
            SimplexCache cache;
            const DistanceResult<double> closed = distance(sa, a, sb, b_pose, options, &cache);
            const DistanceResult<double> loop = distance(pa, a, pb, b_pose, options);
            ASSERT_NE(closed.status, Status::invalid_input) << closed.message;
            ASSERT_NE(loop.status, Status::invalid_input) << loop.message;
            const double both = closed.error_bound + loop.error_bound;
            EXPECT_LE(std::abs(closed.distance - loop.distance), both) << "scale " << scale;
            // A verdict may differ only where the distance is within the bounds of 0.
            if (closed.status != loop.status) {
              EXPECT_LE(std::max(closed.distance, loop.distance), both) << "scale " << scale;
            }
            // The certificate is Theorem 1's at the roundoff level: no weaker than the loop's.
            EXPECT_LE(closed.error_bound,
                      4 * loop.error_bound +
                          64 * std::numeric_limits<double>::epsilon() * closed.diameter_bound);
            EXPECT_GE(closed.simplex_size, 1);
            EXPECT_GE(closed.subalgorithm_runs, 1);
            if (near_points && closed.status == Status::separated) {
              const double tolerance = 4 * both + 1e-15 * far;
              EXPECT_LE(std::abs((closed.point_b - closed.point_a).stableNorm() - closed.distance),
                        tolerance);
            }
            // The cache it writes is a valid warm start for the next query.
            const DistanceResult<double> again = distance(sa, a, sb, b_pose, options, &cache);
            EXPECT_EQ(again.status, closed.status);
            EXPECT_LE(std::abs(again.distance - closed.distance),
                      again.error_bound + closed.error_bound);
            separated += closed.status == Status::separated;
            ++total;
          }
        }
      }
    }
  }
  EXPECT_GT(separated, total / 5);
  EXPECT_LT(separated, 4 * total / 5);
}

}  // namespace
}  // namespace nearpoint
