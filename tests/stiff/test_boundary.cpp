// SPDX-License-Identifier: Apache-2.0
// Reliability at the boundary (issue 21, items 8–12): the certified error bound must hold for every
// input the engine accepts, in double and in float, and what it cannot handle must be refused with
// a message. Each test names the mechanism it guards. Truths come from CGAL's exact distance on the
// very inputs the engine sees (tests/common/exact_distance.hpp), minus the radii (eq. 8), or from
// long-double arithmetic where the geometry is a plane and a sphere.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "common/checks.hpp"
#include "common/exact_distance.hpp"
#include "nearpoint/compound.hpp"
#include "nearpoint/distance.hpp"

namespace nearpoint {
namespace {

template <class S>
std::vector<Vec3<S>> box_vertices(const Vec3<S>& h, const Vec3<S>& center = Vec3<S>::Zero()) {
  std::vector<Vec3<S>> v;
  for (int i = 0; i < 8; ++i)
    v.emplace_back(center.x() + (i & 1 ? h.x() : -h.x()), center.y() + (i & 2 ? h.y() : -h.y()),
                   center.z() + (i & 4 ? h.z() : -h.z()));
  return v;
}

template <class S>
Pose<S> placed(const Vec3<S>& t, const Mat3<S>& r = Mat3<S>::Identity()) {
  Pose<S> p;
  p.rotation = r;
  p.translation = t;
  return p;
}

template <class S>
Mat3<S> random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  Eigen::Quaterniond q(g(rng), g(rng), g(rng), g(rng));
  return q.normalized().toRotationMatrix().cast<S>();
}

/// The contract for one query against its truth: a refusal carries a message (and is allowed only
/// when `may_refuse`); an answer is finite everywhere and within its own error bound of the truth,
/// and with near points, their distance agrees with the answer to within the bound too.
template <class S>
void expect_certified(const DistanceResult<S>& r, double truth, const std::string& what,
                      bool may_refuse = false) {
  if (r.status == Status::invalid_input) {
    ASSERT_NE(r.message, nullptr) << what;
    EXPECT_TRUE(may_refuse) << what << ": refused: " << r.message;
    return;
  }
  EXPECT_TRUE(testkit::all_finite(r))
      << what << ": non-finite output (distance " << r.distance << ", weights " << r.weights[0]
      << " " << r.weights[1] << ", point_a " << r.point_a.transpose() << ")";
  const double error = std::abs(double(r.distance) - truth);
  EXPECT_LE(error, double(r.error_bound))
      << what << ": distance " << r.distance << " truth " << truth << " bound " << r.error_bound;
  if (r.has_near_points && r.status == Status::separated) {
    const double gap =
        (r.point_b.template cast<double>() - r.point_a.template cast<double>()).stableNorm();
    // Plus the rounding of the world coordinates the points are reported in.
    const double rounding = 4 * std::numeric_limits<S>::epsilon() *
                            (r.point_a.template cast<double>().stableNorm() +
                             r.point_b.template cast<double>().stableNorm());
    EXPECT_LE(std::abs(gap - truth), 2 * double(r.error_bound) + rounding)
        << what << ": near points " << gap << " apart, truth " << truth;
  }
}

template <class S>
double exact(const std::vector<Vec3<S>>& a, const Pose<S>& pa, const std::vector<Vec3<S>>& b,
             const Pose<S>& pb, double radii = 0) {
  const testkit::ExactDistance e = testkit::exact_distance<S>(a, pa, b, pb);
  return std::max(0.0, e.distance - radii);
}

// --- Item 8: scales far from 1. Guards the rescale of K by a power of two (exact) chosen from
// D(K) before the loop, and the scale-safe extents that choose it.

TEST(Boundary, TinyBoxesAreSeparatedWithAMeaningfulBound) {
  // The reproduction: two 1e-170 boxes 1e-170 apart came back "intersecting", bound 0.
  const double h = 0.5e-170;
  const Vec3<double> half(h, h, h);
  const Pose<double> pa = placed<double>({0, 0, 0}), pb = placed<double>({3 * h, 0, 0});
  const double truth = exact(box_vertices(half), pa, box_vertices(half), pb);
  for (const bool as_polytope : {false, true}) {
    const Shape<double> a = as_polytope ? Shape<double>(Polytope<double>(box_vertices(half)))
                                        : Shape<double>(Box<double>{half});
    DistanceOptions<double> options;
    options.near_points = true;
    const DistanceResult<double> r = distance(a, pa, a, pb, options);
    expect_certified(r, truth, as_polytope ? "polytopes" : "boxes");
    EXPECT_EQ(r.status, Status::separated);
    EXPECT_LE(double(r.error_bound), 1e-14 * 2 * h) << "the bound is relative to the size";
  }
}

TEST(Boundary, TinyPointsKeepFullRelativeAccuracy) {
  // The reproduction: two points 1e-160 apart, 5e-6 relative error against a 1.8e-175
  // bound (their squared distance was subnormal).
  const std::vector<Vec3<double>> origin{Vec3<double>::Zero()};
  const Pose<double> pa = placed<double>({0, 0, 0}), pb = placed<double>({0.6e-160, 0.8e-160, 0});
  const DistanceResult<double> r = distance(Shape<double>(Point{}), pa, Shape<double>(Point{}), pb);
  expect_certified(r, exact(origin, pa, origin, pb), "points 1e-160 apart");
  EXPECT_EQ(r.status, Status::separated);
}

TEST(Boundary, FloatPointAgainstLargeFlatBoxIsFinite) {
  // After the report: a point against a 5.4e9 × 5.4e9 × 0 box in float gave NaN weights
  // and near points (Johnson's subalgorithm from ~7.6e6 on). The placements below (box and
  // polytope, both subalgorithms) did not reproduce the NaN before the rescale, so this case only
  // guards that it stays certified; the float scale sweep below is what failed before (errors
  // beyond the bound below ~1e-13 and from ~1e11 on, refusals from ~1e17) and guards the
  // mechanism.
  for (const Subalgorithm method : {Subalgorithm::signed_volumes, Subalgorithm::johnson}) {
    for (const float size : {7.6e6f, 5.4e9f})
      for (const Vec3<float>& where :
           {Vec3<float>(0.1f, -0.2f, 0.3f), Vec3<float>(0.7f, 0.2f, 0.1f),
            Vec3<float>(0.2f, 0.1f, 1e-3f), Vec3<float>(0.9f, 0.9f, 0.5f),
            Vec3<float>(-0.6f, 0.55f, 0.01f)}) {
        const Vec3<float> half(size / 2, size / 2, 0);
        const Pose<float> pa = placed<float>({0, 0, 0});
        const Pose<float> pb = placed<float>(Vec3<float>(size * where));
        DistanceOptions<float> options;
        options.subalgorithm = method;
        options.near_points = true;
        const std::vector<Vec3<float>> point{Vec3<float>::Zero()};
        const double truth = exact(box_vertices(half), pa, point, pb);
        for (const bool as_polytope : {false, true}) {
          const Shape<float> box = as_polytope ? Shape<float>(Polytope<float>(box_vertices(half)))
                                               : Shape<float>(Box<float>{half});
          const DistanceResult<float> r = distance(box, pa, Shape<float>(Point{}), pb, options);
          expect_certified(r, truth,
                           std::string(method == Subalgorithm::johnson ? "johnson " : "sv ") +
                               (as_polytope ? "polytope " : "box ") + std::to_string(size));
          EXPECT_LE(double(r.error_bound), 1e-5 * size);
        }
      }
  }
}

TEST(Boundary, HugeDoubleBoundStaysRelative) {
  // In double from ~1e77 on the bound grew as large as the distance (signed volumes' D⁴ overflow).
  for (const double size : {1e60, 1e77, 1e100, 1e200}) {
    const Vec3<double> half(size, 0.7 * size, 0.3 * size);
    std::mt19937_64 rng(7);
    const Pose<double> pa = placed<double>({0, 0, 0}, random_rotation<double>(rng));
    const Pose<double> pb =
        placed<double>({2.5 * size, 1.1 * size, 0.4 * size}, random_rotation<double>(rng));
    DistanceOptions<double> options;
    options.near_points = true;
    const DistanceResult<double> r = distance(Shape<double>(Box<double>{half}), pa,
                                              Shape<double>(Box<double>{half}), pb, options);
    expect_certified(r, exact(box_vertices(half), pa, box_vertices(half), pb),
                     "boxes of size " + std::to_string(size), size > 1e300);
    if (r.status != Status::invalid_input) {
      EXPECT_LE(double(r.error_bound), 1e-13 * size);
    }
  }
}

/// A sweep over scales: random polytope pairs (and boxes, points, rounded shapes) at scale 10^e,
/// random poses, against CGAL. Every accepted query must be certified and its bound meaningful;
/// refusals are allowed only at the very ends of the range and must carry a message.
template <class S>
void scale_sweep(int lowest, int highest, int step, double meaningful) {
  std::mt19937_64 rng(2026);
  std::uniform_real_distribution<double> unit(-1, 1);
  int accepted = 0, refused = 0;
  for (int e = lowest; e <= highest; e += step) {
    const double scale = std::pow(10.0, e);
    for (int trial = 0; trial < 6; ++trial) {
      std::vector<Vec3<S>> va, vb;
      const int na = 1 + int(rng() % 8), nb = 1 + int(rng() % 8);
      for (int i = 0; i < na; ++i)
        va.emplace_back(S(scale * unit(rng)), S(scale * unit(rng)), S(scale * unit(rng)));
      for (int i = 0; i < nb; ++i)
        vb.emplace_back(S(scale * unit(rng)), S(scale * unit(rng)), S(scale * unit(rng)));
      const Pose<S> pa = placed<S>(Vec3<S>(S(scale * unit(rng)), S(scale * unit(rng)), 0),
                                   random_rotation<S>(rng));
      const Pose<S> pb = placed<S>(
          Vec3<S>(S(3 * scale * unit(rng)), S(3 * scale * unit(rng)), S(3 * scale * unit(rng))),
          random_rotation<S>(rng));
      const S ra = trial % 3 == 0 ? S(0.2 * scale) : S(0);
      const double truth = exact(va, pa, vb, pb, double(ra));
      for (const Subalgorithm method : {Subalgorithm::signed_volumes, Subalgorithm::johnson}) {
        DistanceOptions<S> options;
        options.subalgorithm = method;
        options.near_points = trial % 2 == 0;
        const DistanceResult<S> r =
            distance(Shape<S>(Polytope<S>(va), ra), pa, Shape<S>(Polytope<S>(vb)), pb, options);
        const bool at_the_ends = e <= lowest + 2 * step || e >= highest - 2 * step;
        char what[96];
        std::snprintf(what, sizeof what, "scale 1e%d trial %d %s", e, trial,
                      method == Subalgorithm::johnson ? "johnson" : "sv");
        expect_certified(r, truth, what, at_the_ends);
        if (r.status == Status::invalid_input) {
          ++refused;
          continue;
        }
        ++accepted;
        // Meaningful when separated (an intersecting verdict may stop as soon as it is settled:
        // its bound then says how far from touching the pair could be).
        if (r.status == Status::separated) {
          EXPECT_LE(double(r.error_bound), meaningful * std::max(scale, double(r.diameter_bound)))
              << what << ": " << to_string(r.status) << " " << to_string(r.termination)
              << " distance " << r.distance << " truth " << truth << " D " << r.diameter_bound;
        }
      }
    }
  }
  std::printf("scale sweep 1e%d..1e%d: %d accepted, %d refused\n", lowest, highest, accepted,
              refused);
  EXPECT_GT(accepted, 0);
}

TEST(Boundary, ScaleSweepDouble) {
  scale_sweep<double>(-300, 300, 10, 1e-12);
}
TEST(Boundary, ScaleSweepFloat) {
  scale_sweep<float>(-35, 35, 2, 1e-3);
}

// The rescale's choice of scale: any K whose working magnitude M and D(K) fit the loop's range
// together (M/D(K) up to 2^31 in float) is measured, not refused. Scaling M to 1 alone refused
// pairs 2^17 apart in size (fuzz_engine: a compound's piece posed 3e4 from its object's origin,
// 1.5e-5 from the other piece). Without the origin shift M holds the centroids (|z̄| = 3 here),
// so two points s apart at x = 3 have M ≈ 12 and D(K) = s.
TEST(Boundary, FloatRescaleMeasuresWhateverTheRangeHolds) {
  DistanceOptions<float> options;
  options.origin_shift = false;
  options.near_points = true;
  for (int e = 4; e <= 40; ++e) {
    const float s = std::ldexp(1.0f, -e);
    const std::vector<Vec3<float>> a{{3, 0, 0}}, b{{3, s, 0}};
    const Pose<float> pose = placed<float>({0, 0, 0});
    const DistanceResult<float> r = distance(Shape<float>(Polytope<float>(a)), pose,
                                             Shape<float>(Polytope<float>(b)), pose, options);
    const bool in_range = 12.0 / s < std::ldexp(1.0, 31);
    expect_certified(r, exact(a, pose, b, pose), "points 2^-" + std::to_string(e) + " apart",
                     /*may_refuse=*/!in_range);
  }
}

// --- Item 9: huge radii. Guards the radii limit (refused with a message, never a non-finite
// number).

TEST(Boundary, HugeRadiiAreRefusedOrFinite) {
  for (const double r : {1e300, 1e307, 1e308, std::numeric_limits<double>::max()}) {
    const Shape<double> a = Shape<double>::sphere(r), b = Shape<double>::sphere(r);
    DistanceOptions<double> options;
    options.near_points = true;
    options.penetration_bound = true;
    const DistanceResult<double> res =
        distance(a, placed<double>({0, 0, 0}), b, placed<double>({1, 2, 3}), options);
    if (res.status == Status::invalid_input) {
      EXPECT_NE(res.message, nullptr);
      continue;
    }
    EXPECT_TRUE(testkit::all_finite(res)) << "radius " << r;
    EXPECT_EQ(res.status, Status::intersecting);
  }
  for (const float r : {1e37f, 3e38f}) {
    const DistanceResult<float> res = distance(Shape<float>::sphere(r), placed<float>({0, 0, 0}),
                                               Shape<float>::sphere(r), placed<float>({1, 2, 3}));
    if (res.status == Status::invalid_input) continue;
    EXPECT_TRUE(testkit::all_finite(res)) << "radius " << r;
  }
}

// --- Item 10: shapes modelled far from their local origin and placed back by their pose. Guards
// the centroid offset δ formed from the world-frame centroids with compensated arithmetic.

TEST(Boundary, FarLocalCoordinatesAreCovered) {
  std::mt19937_64 rng(10);
  for (const double far : {1e4, 1e8, 1e12, 1e15}) {
    for (int trial = 0; trial < 8; ++trial) {
      // A unit cube modelled at local x = far, placed back beside a unit box at the origin.
      const std::vector<Vec3<double>> cube = box_vertices<double>({0.5, 0.5, 0.5}, {far, 0, 0});
      const Mat3<double> r = random_rotation<double>(rng);
      const Vec3<double> beside(1.7, 0.3, -0.2);
      const Pose<double> pa = placed<double>(Vec3<double>(beside - r * Vec3<double>(far, 0, 0)), r);
      const Pose<double> pb = placed<double>({0, 0, 0});
      const std::vector<Vec3<double>> unit = box_vertices<double>({0.5, 0.5, 0.5});
      const double truth = exact(cube, pa, unit, pb);
      for (const bool swap : {false, true}) {
        DistanceOptions<double> options;
        options.near_points = true;
        const Shape<double> sa(Polytope<double>(swap ? unit : cube));
        const Shape<double> sb(Polytope<double>(swap ? cube : unit));
        const DistanceResult<double> res =
            distance(sa, swap ? pb : pa, sb, swap ? pa : pb, options);
        expect_certified(res, truth, "local offset " + std::to_string(far));
        EXPECT_LE(double(res.error_bound), 1e-13 * res.diameter_bound) << "relative to the size";
      }
    }
  }
}

// --- Item 11: compounds far from the origin. Guards piece poses composed relative to A's
// position, and pruning with a margin for rounding.

TEST(Boundary, FarCompoundKeepsTheNearerPiece) {
  // Two unit spheres in A, the second 5e-8 nearer a plate B; both objects at x ≈ 1e9.
  for (const double at : {0.0, 1e9, 1e12}) {
    std::vector<Piece<double>> pieces;
    pieces.push_back({Shape<double>::sphere(1), placed<double>({0, 0, 0})});
    pieces.push_back({Shape<double>::sphere(1), placed<double>({5e-8, 4, 0})});
    const Compound<double> a(std::move(pieces));
    const Vec3<double> half(0.5, 10, 10);
    std::vector<Piece<double>> plate;
    plate.push_back({Shape<double>(Box<double>{half}), placed<double>({0, 0, 0})});
    const Compound<double> b(std::move(plate));
    const Pose<double> pa = placed<double>({at, 0, 0}), pb = placed<double>({at + 3.5, 0, 0});
    const long double truth = (3.5L - 0.5L) - 5e-8L - 1.0L;  // face at +3, sphere reaches 1 + 5e-8
    DistanceOptions<double> options;
    options.near_points = true;
    const CompoundResult<double> r = distance(a, pa, b, pb, options);
    expect_certified(r.nearest, double(truth), "compound at " + std::to_string(at));
    EXPECT_EQ(r.piece_a, 1) << "the nearer piece must win at x = " << at;
  }
}

TEST(Boundary, FarCompoundSweep) {
  // Translated pieces (dyadic offsets, so that a piece's vertices v + offset are exact and the
  // oracle sees the same sets) of random polytopes, objects far from the origin.
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(-1, 1);
  for (const double at : {1e3, 1e6, 1e9, 1e12, 1e14}) {
    for (int trial = 0; trial < 6; ++trial) {
      std::vector<std::vector<Vec3<double>>> world_a, world_b;
      auto make = [&](std::vector<std::vector<Vec3<double>>>& local) {
        std::vector<Piece<double>> pieces;
        for (int p = 0; p < 3; ++p) {
          std::vector<Vec3<double>> v;
          // 20-bit dyadic coordinates: v + offset is then exact.
          auto dyadic = [&] { return std::ldexp(std::round(unit(rng) * 0x1p20), -20); };
          for (int i = 0; i < 6; ++i) v.emplace_back(dyadic(), dyadic(), dyadic());
          const Vec3<double> offset(std::ldexp(std::round(unit(rng) * 64), -4),
                                    std::ldexp(std::round(unit(rng) * 64), -4), 0);
          std::vector<Vec3<double>> moved;
          for (const auto& x : v) moved.push_back(x + offset);  // exact: dyadic, same binade
          pieces.push_back({Shape<double>(Polytope<double>(v)), placed<double>(offset)});
          local.push_back(moved);
        }
        return Compound<double>(std::move(pieces));
      };
      const Compound<double> a = make(world_a), b = make(world_b);
      const Pose<double> pa = placed<double>({at, -at, 0.5 * at}, random_rotation<double>(rng));
      const Pose<double> pb = placed<double>(
          Vec3<double>(at + 6 * unit(rng), -at + 6 * unit(rng), 0.5 * at + 6 * unit(rng)),
          random_rotation<double>(rng));
      double truth = std::numeric_limits<double>::infinity();
      // The oracle's pieces: v + offset exactly, under the object's pose.
      for (const auto& x : world_a)
        for (const auto& y : world_b) truth = std::min(truth, exact(x, pa, y, pb));
      DistanceOptions<double> options;
      options.near_points = true;
      const CompoundResult<double> r = distance(a, pa, b, pb, options);
      expect_certified(r.nearest, truth, "compound sweep at " + std::to_string(at));
    }
  }
}

// --- Item 12: rotations that are not quite rotations. Guards the defect term ‖RᵀR − I‖·size in
// the bound (A's frame is entered through R_Aᵀ, which is its inverse only when R_A is orthonormal).

TEST(Boundary, FloatQuaternionRotationInDouble) {
  // The reproduction: a rotation from a normalised float quaternion used in double
  // (defect ~4e-8) erred by 4.1e-7 against a bound of 2.4e-14.
  const Eigen::Quaternionf qf = Eigen::Quaternionf(0.9f, 0.3f, -0.2f, 0.1f).normalized();
  const Mat3<double> r = qf.cast<double>().toRotationMatrix();
  const Vec3<double> half(0.5, 0.5, 0.5);
  for (const bool rotate_a : {true, false}) {
    const Pose<double> pa = placed<double>({0, 0, 0}, rotate_a ? r : Mat3<double>::Identity());
    const Pose<double> pb = placed<double>({10, 3, -2}, rotate_a ? Mat3<double>::Identity() : r);
    DistanceOptions<double> options;
    options.near_points = true;
    const DistanceResult<double> res = distance(Shape<double>(Box<double>{half}), pa,
                                                Shape<double>(Box<double>{half}), pb, options);
    expect_certified(res, exact(box_vertices(half), pa, box_vertices(half), pb),
                     rotate_a ? "defective A" : "defective B");
  }
}

template <class S>
void defect_sweep(double largest_defect) {
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> unit(-1, 1);
  int accepted = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const double defect = largest_defect * std::pow(10.0, -3 * (trial % 5) / 4.0);
    Mat3<double> e;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) e(i, j) = defect * unit(rng) / 2;
    const Mat3<S> ra = (random_rotation<double>(rng) * (Mat3<double>::Identity() + e)).cast<S>();
    const Mat3<S> rb = random_rotation<S>(rng);
    const double size = std::pow(10.0, trial % 7 - 3);
    std::vector<Vec3<S>> va, vb;
    for (int i = 0; i < 8; ++i) {
      va.emplace_back(S(size * unit(rng)), S(size * unit(rng)), S(size * unit(rng)));
      vb.emplace_back(S(size * unit(rng)), S(size * unit(rng)), S(size * unit(rng)));
    }
    const Pose<S> pa = placed<S>(Vec3<S>(S(size * unit(rng)), 0, 0), ra);
    const Pose<S> pb = placed<S>(Vec3<S>(S(4 * size * unit(rng)), S(4 * size * unit(rng)), 0), rb);
    DistanceOptions<S> options;
    options.near_points = true;
    const DistanceResult<S> r =
        distance(Shape<S>(Polytope<S>(va)), pa, Shape<S>(Polytope<S>(vb)), pb, options);
    if (r.status == Status::invalid_input) continue;  // not accepted as a rotation
    ++accepted;
    expect_certified(r, exact(va, pa, vb, pb), "defect " + std::to_string(defect));
  }
  EXPECT_GT(accepted, 20);
}

TEST(Boundary, DefectSweepDouble) {
  defect_sweep<double>(1e-6);
}
TEST(Boundary, DefectSweepFloat) {
  defect_sweep<float>(1e-4);
}

}  // namespace
}  // namespace nearpoint
