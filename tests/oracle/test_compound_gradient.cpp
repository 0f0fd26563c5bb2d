// SPDX-License-Identifier: Apache-2.0
// Compound objects (paper eq. 2–4: distance = minimum over piece pairs, with bounding-sphere
// pruning and per-piece-pair warm-start caches), the gradient of the distance with respect to the
// poses (Section II) against central finite differences, and the rejection of invalid input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "common/checks.hpp"
#include "common/paper_family.hpp"
#include "nearpoint/compound.hpp"
#include "nearpoint/distance.hpp"

namespace {

using nearpoint::Box;
using nearpoint::Compound;
using nearpoint::CompoundResult;
using nearpoint::Cone;
using nearpoint::Cylinder;
using nearpoint::DistanceOptions;
using nearpoint::DistanceResult;
using nearpoint::Ellipsoid;
using nearpoint::Piece;
using nearpoint::Point;
using nearpoint::Polytope;
using nearpoint::Pose;
using nearpoint::Segment;
using nearpoint::Shape;
using nearpoint::SimplexCache;
using nearpoint::Status;
using nearpoint::Vec3;
using nearpoint::testkit::FailureLog;
using nearpoint::testkit::format;
using nearpoint::testkit::random_rotation;
using nearpoint::testkit::random_unit_vector;
using nearpoint::testkit::uniform;
using Vector6 = Eigen::Matrix<double, 6, 1>;

Pose<double> random_pose(std::mt19937_64& rng, double spread) {
  Pose<double> p;
  p.rotation = random_rotation(rng);
  p.translation = Vec3<double>(uniform(rng, -spread, spread), uniform(rng, -spread, spread),
                               uniform(rng, -spread, spread));
  return p;
}

// Two compound objects built from every kind of piece, placed off their objects' origins.
struct Objects {
  Compound<double> a;
  Compound<double> b;
};

Objects make_objects(std::mt19937_64& rng) {
  const auto polytopes = nearpoint::testkit::paper_polytopes();
  std::vector<Piece<double>> pa = {
      {Shape<double>(Polytope<double>(*polytopes[3].vertices)), random_pose(rng, 2)},
      {Shape<double>::sphere(0.6), random_pose(rng, 2)},
      {Shape<double>::capsule(Vec3<double>(-1, 0, 0), Vec3<double>(1, 0.2, 0), 0.3),
       random_pose(rng, 2)},
  };
  std::vector<Piece<double>> pb = {
      {Shape<double>(Box<double>{Vec3<double>(0.8, 0.5, 0.3)}, 0.05), random_pose(rng, 2)},
      {Shape<double>(Ellipsoid<double>{Vec3<double>(1.0, 0.4, 0.7)}), random_pose(rng, 2)},
      {Shape<double>(Polytope<double>(*polytopes[8].vertices)), random_pose(rng, 2)},
      {Shape<double>(Cylinder<double>{0.5, 0.9}), random_pose(rng, 2)},
  };
  return {Compound<double>(std::move(pa)), Compound<double>(std::move(pb))};
}

struct Brute {
  std::vector<DistanceResult<double>> results;  // [i * nb + j]
  double min_distance = std::numeric_limits<double>::infinity();
  double max_penetration = 0;
  bool any_intersecting = false;
};

Brute brute_force(const Compound<double>& a, const Pose<double>& pose_a, const Compound<double>& b,
                  const Pose<double>& pose_b, const DistanceOptions<double>& options) {
  Brute out;
  // Piece poses composed as the compound query composes them: relative to A's position (the
  // scene translated by −p_A, which changes no distance), so that each pair sees the very same
  // inputs and its d⁻ can be compared to the last bits.
  Pose<double> frame_a = pose_a, frame_b = pose_b;
  frame_a.translation.setZero();
  frame_b.translation = pose_b.translation - pose_a.translation;
  for (std::size_t i = 0; i < a.size(); ++i)
    for (std::size_t j = 0; j < b.size(); ++j) {
      const auto r =
          nearpoint::distance(a.piece(i).shape, frame_a.compose(a.piece(i).offset),
                              b.piece(j).shape, frame_b.compose(b.piece(j).offset), options);
      out.min_distance = std::min(out.min_distance, r.distance);
      if (r.status == Status::intersecting) {
        out.any_intersecting = true;
        out.max_penetration = std::max(out.max_penetration, r.penetration_bound);
      }
      out.results.push_back(r);
    }
  return out;
}

// The compound distance is the minimum over piece pairs (eq. 2–4) despite pruning and despite
// pairs stopping once proven farther than the best; the pruning counters account for every pair;
// the penetration bound is the largest over intersecting pairs; warm starts from per-pair caches
// agree with cold starts after a small motion.
TEST(Compound, EqualsBruteForceMinimumOverPiecePairs) {
  std::mt19937_64 rng(1001);
  FailureLog log;
  DistanceOptions<double> options;
  options.near_points = true;
  options.penetration_bound = true;
  int queries = 0, pruned_queries = 0, intersecting = 0, separated = 0, warm_used = 0;
  int stopped_at_best = 0, single_pair_queries = 0;
  for (int object_set = 0; object_set < 10; ++object_set) {
    const Objects objects = make_objects(rng);
    const std::size_t pairs = objects.a.size() * objects.b.size();
    ASSERT_EQ(objects.a.invalid_reason(), nullptr);
    ASSERT_EQ(objects.b.invalid_reason(), nullptr);
    for (int k = 0; k < 60; ++k) {
      const Pose<double> pose_a = random_pose(rng, 3), pose_b = random_pose(rng, 3);
      const Brute brute = brute_force(objects.a, pose_a, objects.b, pose_b, options);
      const CompoundResult<double> c =
          nearpoint::distance(objects.a, pose_a, objects.b, pose_b, options);
      const std::string where = format("set %d query %d", object_set, k);
      ++queries;
      if (!nearpoint::testkit::all_finite(c.nearest)) log.add("NaN", where);
      if (c.pairs_evaluated + c.pairs_pruned != int(pairs))
        log.add(
            "pairs_evaluated + pairs_pruned != pieces_a * pieces_b",
            format("%s %d + %d != %zu", where.c_str(), c.pairs_evaluated, c.pairs_pruned, pairs));
      if (c.pairs_evaluated < 1) log.add("no pair evaluated", where);
      // The query's cost counters sum its evaluated pairs: at least the nearest pair's, at least
      // one run of step 2 per evaluated pair, and exactly the nearest pair's when it ran alone.
      if (c.support_calls < c.nearest.support_calls ||
          c.subalgorithm_runs < c.nearest.subalgorithm_runs ||
          c.subalgorithm_runs < c.pairs_evaluated ||
          (c.pairs_evaluated == 1 && (c.support_calls != c.nearest.support_calls ||
                                      c.subalgorithm_runs != c.nearest.subalgorithm_runs)))
        log.add("cost counters do not sum the evaluated pairs",
                format("%s: %d pairs, %d/%d calls, %d/%d runs", where.c_str(), c.pairs_evaluated,
                       c.support_calls, c.nearest.support_calls, c.subalgorithm_runs,
                       c.nearest.subalgorithm_runs));
      single_pair_queries += c.pairs_evaluated == 1;
      pruned_queries += c.pairs_pruned > 0;
      stopped_at_best += c.pairs_stopped_at_best;
      if (c.pairs_stopped_at_best > c.pairs_evaluated - 1)
        log.add("more pairs stopped at the best than evaluated after the first", where);
      if (c.piece_a < 0 || c.piece_b < 0 || c.piece_a >= int(objects.a.size()) ||
          c.piece_b >= int(objects.b.size())) {
        log.add("nearest piece indices out of range", where);
        continue;
      }
      const auto& chosen =
          brute.results[std::size_t(c.piece_a) * objects.b.size() + std::size_t(c.piece_b)];
      // Same pair, same poses: the two evaluations agree to their error bounds; and no other
      // pair beats it by more than that (pruning never drops the answer). 1e-12·10: rounding of
      // composed poses at |t| ≲ 10.
      const double allowed = c.nearest.error_bound + chosen.error_bound + 1e-11;
      if (!(std::abs(c.nearest.distance - chosen.distance) <= allowed))
        log.add("compound distance differs from its own piece pair",
                format("%s %.17g vs %.17g", where.c_str(), c.nearest.distance, chosen.distance));
      if (!(c.nearest.distance <= brute.min_distance + allowed))
        log.add("compound distance above the brute-force minimum (pruned the answer?)",
                format("%s %.17g vs %.17g", where.c_str(), c.nearest.distance, brute.min_distance));
      if ((c.nearest.status == Status::intersecting) != brute.any_intersecting)
        log.add("compound verdict differs from brute force", where);
      if (brute.any_intersecting) {
        ++intersecting;
        if (!(std::abs(c.nearest.penetration_bound - brute.max_penetration) <= 1e-11))
          log.add("penetration bound is not the largest over intersecting pairs",
                  format("%s %.17g vs %.17g", where.c_str(), c.nearest.penetration_bound,
                         brute.max_penetration));
      } else {
        ++separated;
        if (!(std::abs((c.nearest.point_b - c.nearest.point_a).norm() - c.nearest.distance) <=
              1e-11))
          log.add("|point_b - point_a| != distance", where);
      }

      // Warm start: caches filled at these poses, then a small motion of B.
      std::vector<SimplexCache> caches(pairs);
      nearpoint::distance(objects.a, pose_a, objects.b, pose_b, options,
                          std::span<SimplexCache>(caches));
      Pose<double> moved = pose_b;
      moved.translation += 0.01 * random_unit_vector(rng);
      moved.rotation =
          Eigen::AngleAxisd(0.01, random_unit_vector(rng)).toRotationMatrix() * moved.rotation;
      const auto warm = nearpoint::distance(objects.a, pose_a, objects.b, moved, options,
                                            std::span<SimplexCache>(caches));
      const auto cold = nearpoint::distance(objects.a, pose_a, objects.b, moved, options);
      warm_used += warm.nearest.warm_started;
      if (!(std::abs(warm.nearest.distance - cold.nearest.distance) <=
            warm.nearest.error_bound + cold.nearest.error_bound + 1e-11))
        log.add("warm and cold compound distances differ",
                format("%s warm %.17g cold %.17g", where.c_str(), warm.nearest.distance,
                       cold.nearest.distance));
      if (warm.pairs_evaluated + warm.pairs_pruned != int(pairs))
        log.add("warm: pairs_evaluated + pairs_pruned != pieces_a * pieces_b", where);
      if (cold.nearest.distance > 1e-6 && warm.nearest.status != cold.nearest.status)
        log.add("warm and cold compound verdicts differ", where);
    }
  }
  std::printf(
      "\nCompound: %d queries, %d separated, %d intersecting, %d with pruned pairs, %d piece "
      "pairs stopped once past the best, %d warm starts used\n",
      queries, separated, intersecting, pruned_queries, stopped_at_best, warm_used);
  // Representative: both verdicts, pruning actually happens, caches actually get used.
  EXPECT_GE(separated, queries / 5);
  EXPECT_GE(intersecting, queries / 10);
  EXPECT_GE(pruned_queries, queries / 5);
  // Pairs that survive the sphere test but are farther than the best stop early (their GJK runs
  // with the best as its cutoff), and the minimum above is still exact.
  EXPECT_GE(stopped_at_best, queries / 5);
  EXPECT_GE(warm_used, queries / 2);
  EXPECT_GE(single_pair_queries, queries / 10);
  EXPECT_EQ(log.total(), 0) << log.report();
}

// ---- gradient ----

// d with B's (or A's) pose perturbed: translation by s·e_k (k < 3), or rotation exp(s·[e_k]×)
// applied on the left about the body's origin (k ≥ 3), as result.hpp defines the layout.
Pose<double> perturbed(const Pose<double>& pose, int k, double s) {
  Pose<double> out = pose;
  if (k < 3) {
    out.translation[k] += s;
  } else {
    out.rotation =
        Eigen::AngleAxisd(s, Vec3<double>::Unit(k - 3)).toRotationMatrix() * pose.rotation;
  }
  return out;
}

// Central differences with step h: the error is (e₊ + e₋)/(2h) from the distances' own errors
// (bounded by their error bounds plus rounding) plus h²/6·|d'''|; for the separated, gently
// curved configurations below (d ≥ 0.2, curvature radii ≥ 0.3) |d'''| ≲ 100, so h = 1e-5 leaves a
// truncation error ≲ 2e-9.
constexpr double kStep = 1e-5;

template <class DistanceFn>
void check_gradient(FailureLog& log, const std::string& where, const Pose<double>& pose_a,
                    const Pose<double>& pose_b, const Vector6& gradient_a,
                    const Vector6& gradient_b, DistanceFn distance_of, double& max_deviation) {
  for (int body = 0; body < 2; ++body) {
    for (int k = 0; k < 6; ++k) {
      double d_plus, d_minus, e_plus, e_minus;
      if (body == 0) {
        distance_of(perturbed(pose_a, k, kStep), pose_b, d_plus, e_plus);
        distance_of(perturbed(pose_a, k, -kStep), pose_b, d_minus, e_minus);
      } else {
        distance_of(pose_a, perturbed(pose_b, k, kStep), d_plus, e_plus);
        distance_of(pose_a, perturbed(pose_b, k, -kStep), d_minus, e_minus);
      }
      const double fd = (d_plus - d_minus) / (2 * kStep);
      const double analytic = body == 0 ? gradient_a[k] : gradient_b[k];
      const double tolerance = (e_plus + e_minus + 2e-14) / (2 * kStep) + 1e-7;
      max_deviation = std::max(max_deviation, std::abs(fd - analytic));
      if (!(std::abs(fd - analytic) <= tolerance))
        log.add(
            "gradient differs from central differences",
            format("%s body %c component %d: analytic %.12g, finite difference %.12g (tol %.2g)",
                   where.c_str(), body == 0 ? 'A' : 'B', k, analytic, fd, tolerance));
    }
  }
}

// The gradient (options.gradient) of separated pairs with unique near points — a polytope vs a
// sphere (the distance from a point to a polytope is C¹ outside it) and smooth shapes — matches
// central finite differences in all 12 pose coordinates.
// A piece whose offset is exactly the identity is queried at the object's pose as it is; any
// other piece at the object's pose composed with its offset (Pose::compose). Either way a
// single-piece compound answers exactly as the plain query on the piece's pose does.
TEST(Compound, PiecePoseIsTheObjectPoseOrItsComposition) {
  std::mt19937_64 rng(20261201);
  const auto polytopes = nearpoint::testkit::paper_polytopes();
  const Shape<double> shape_a(Polytope<double>(*polytopes[5].vertices));
  const Shape<double> shape_b =
      Shape<double>::capsule(Vec3<double>(-1, 0, 0), Vec3<double>(1, 0.3, 0), 0.2);
  const Pose<double> offset_a = random_pose(rng, 1.5), offset_b = random_pose(rng, 1.5);
  const Compound<double> at_origin_a({{shape_a, Pose<double>::identity()}});
  const Compound<double> at_origin_b({{shape_b, Pose<double>::identity()}});
  const Compound<double> placed_a({{shape_a, offset_a}});
  const Compound<double> placed_b({{shape_b, offset_b}});
  Pose<double> shifted = Pose<double>::identity();  // a translation alone is not the origin
  shifted.translation = Vec3<double>(0.5, -0.3, 0.2);
  const Compound<double> shifted_b({{shape_b, shifted}});
  ASSERT_TRUE(at_origin_a.at_origin(0));
  ASSERT_TRUE(at_origin_b.at_origin(0));
  ASSERT_FALSE(placed_a.at_origin(0));
  ASSERT_FALSE(placed_b.at_origin(0));
  ASSERT_FALSE(shifted_b.at_origin(0));

  DistanceOptions<double> options;
  options.near_points = true;
  FailureLog log;
  int separated = 0;
  for (int q = 0; q < 400; ++q) {
    const Pose<double> pose_a = random_pose(rng, 3), pose_b = random_pose(rng, 3);
    // A composed piece's query also covers the rounding of composing its pose (its working
    // magnitude includes the translations; the plain query below is on the poses as rounded and
    // certifies only those): the same verdict, a bound no tighter, and answers within the bounds
    // rather than to the bit (the loop's roundoff floors differ with the magnitude).
    const auto check = [&](const char* what, const CompoundResult<double>& got,
                           const DistanceResult<double>& want, bool to_the_bit = true) {
      const double e = got.nearest.error_bound + want.error_bound;
      const double ulps = 1e-15 * (got.nearest.point_a.norm() + want.point_a.norm());
      const bool same = to_the_bit ? got.nearest.status == want.status &&
                                         got.nearest.distance == want.distance &&
                                         got.nearest.error_bound == want.error_bound &&
                                         got.nearest.iterations == want.iterations &&
                                         got.nearest.point_a == want.point_a &&
                                         got.nearest.point_b == want.point_b
                                   : got.nearest.status == want.status &&
                                         std::abs(got.nearest.distance - want.distance) <= e &&
                                         got.nearest.error_bound >= want.error_bound &&
                                         (got.nearest.point_a - want.point_a).norm() <= e + ulps &&
                                         (got.nearest.point_b - want.point_b).norm() <= e + ulps;
      if (!same)
        log.add(
            std::string("compound differs from the plain query on the piece's pose (") + what + ")",
            format("query %d: %.17g vs %.17g", q, got.nearest.distance, want.distance));
    };
    const DistanceResult<double> plain =
        nearpoint::distance(shape_a, pose_a, shape_b, pose_b, options);
    separated += plain.status == Status::separated;
    check("at origin", nearpoint::distance(at_origin_a, pose_a, at_origin_b, pose_b, options),
          plain);
    // A placed piece is queried as a caller would query it with the poses composed relative to
    // A's position (frame_a, frame_b: the scene translated by −p_A), near points moved back.
    Pose<double> frame_a = pose_a, frame_b = pose_b;
    frame_a.translation.setZero();
    frame_b.translation = pose_b.translation - pose_a.translation;
    DistanceResult<double> composed = nearpoint::distance(
        shape_a, frame_a.compose(offset_a), shape_b, frame_b.compose(offset_b), options);
    composed.point_a += pose_a.translation;
    composed.point_b += pose_a.translation;
    check("placed", nearpoint::distance(placed_a, pose_a, placed_b, pose_b, options), composed,
          false);
  }
  EXPECT_GT(separated, 100);  // both verdicts occur
  EXPECT_LT(separated, 400);
  EXPECT_EQ(log.total(), 0) << log.report();
}

TEST(Gradient, MatchesCentralDifferences) {
  std::mt19937_64 rng(2002);
  const auto polytopes = nearpoint::testkit::paper_polytopes();
  const std::vector<std::pair<Shape<double>, Shape<double>>> pairs = {
      {Shape<double>(Polytope<double>(*polytopes[8].vertices)), Shape<double>::sphere(0.5)},
      {Shape<double>::sphere(0.4), Shape<double>(Polytope<double>(*polytopes[3].vertices))},
      {Shape<double>(Ellipsoid<double>{Vec3<double>(1.2, 0.5, 0.8)}),
       Shape<double>(Ellipsoid<double>{Vec3<double>(0.6, 0.9, 0.7)})},
      {Shape<double>(Ellipsoid<double>{Vec3<double>(0.9, 0.6, 1.3)}), Shape<double>::sphere(0.3)},
      {Shape<double>::capsule(Vec3<double>(-1, 0, 0), Vec3<double>(1, 0.3, 0.2), 0.3),
       Shape<double>::sphere(0.5)},
  };
  DistanceOptions<double> options;
  options.gradient = true;
  FailureLog log;
  double max_deviation = 0;
  int checked = 0;
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    const auto& [a, b] = pairs[p];
    for (int k = 0; k < 40; ++k) {
      const Pose<double> pose_a = random_pose(rng, 1);
      Pose<double> pose_b = random_pose(rng, 1);
      pose_b.translation = pose_a.translation + uniform(rng, 3.5, 6) * random_unit_vector(rng);
      const auto r = nearpoint::distance(a, pose_a, b, pose_b, options);
      const std::string where = format("pair %zu sample %d", p, k);
      if (r.status != Status::separated || !(r.distance >= 0.2)) continue;  // want clear separation
      ++checked;
      if (!r.has_gradient) {
        log.add("no gradient although asked for", where);
        continue;
      }
      if (!r.gradient_a.allFinite() || !r.gradient_b.allFinite()) log.add("NaN gradient", where);
      auto distance_of = [&a = a, &b = b](const Pose<double>& qa, const Pose<double>& qb, double& d,
                                          double& e) {
        const auto rr = nearpoint::distance(a, qa, b, qb, DistanceOptions<double>{});
        d = rr.distance;
        e = rr.error_bound;
      };
      check_gradient(log, where, pose_a, pose_b, r.gradient_a, r.gradient_b, distance_of,
                     max_deviation);
    }
  }
  std::printf("\nGradient: %d separated configurations, max |analytic - finite difference| %.3g\n",
              checked, max_deviation);
  EXPECT_GE(checked, 150);  // most samples are separated by construction
  EXPECT_EQ(log.total(), 0) << log.report();
}

// The compound gradient refers to the whole objects' poses: finite differences of the compound
// distance with respect to each object's pose (pieces: a sphere and a polytope vs an ellipsoid
// and a capsule, all smooth or polytope-vs-sphere-like at their nearest pair).
TEST(Gradient, CompoundMatchesCentralDifferences) {
  std::mt19937_64 rng(3003);
  const auto polytopes = nearpoint::testkit::paper_polytopes();
  const Compound<double> a({{Shape<double>::sphere(0.5), random_pose(rng, 1)},
                            {Shape<double>::sphere(0.3), random_pose(rng, 1)}});
  const Compound<double> b(
      {{Shape<double>(Ellipsoid<double>{Vec3<double>(0.9, 0.5, 0.7)}), random_pose(rng, 1)},
       {Shape<double>::capsule(Vec3<double>(0, 0, -0.5), Vec3<double>(0, 0, 0.5), 0.2),
        random_pose(rng, 1)},
       {Shape<double>(Polytope<double>(*polytopes[6].vertices)), random_pose(rng, 1)}});
  ASSERT_EQ(a.invalid_reason(), nullptr);
  ASSERT_EQ(b.invalid_reason(), nullptr);
  DistanceOptions<double> options;
  options.gradient = true;
  FailureLog log;
  double max_deviation = 0;
  int checked = 0;
  for (int k = 0; k < 60; ++k) {
    const Pose<double> pose_a = random_pose(rng, 1);
    Pose<double> pose_b = random_pose(rng, 1);
    pose_b.translation = pose_a.translation + uniform(rng, 4, 7) * random_unit_vector(rng);
    const auto c = nearpoint::distance(a, pose_a, b, pose_b, options);
    if (c.nearest.status != Status::separated || !(c.nearest.distance >= 0.2)) continue;
    // Skip configurations where a second piece pair is nearly as close: the distance has a kink
    // there (a minimum of smooth functions) and finite differences straddle it.
    const Brute brute = brute_force(a, pose_a, b, pose_b, DistanceOptions<double>{});
    int close_pairs = 0;
    for (const auto& r : brute.results) close_pairs += r.distance < brute.min_distance + 1e-3;
    if (close_pairs > 1) continue;
    ++checked;
    const std::string where = format("sample %d", k);
    if (!c.nearest.has_gradient) {
      log.add("no gradient although asked for", where);
      continue;
    }
    auto distance_of = [&](const Pose<double>& qa, const Pose<double>& qb, double& d, double& e) {
      const auto rr = nearpoint::distance(a, qa, b, qb, DistanceOptions<double>{});
      d = rr.nearest.distance;
      e = rr.nearest.error_bound;
    };
    check_gradient(log, where, pose_a, pose_b, c.nearest.gradient_a, c.nearest.gradient_b,
                   distance_of, max_deviation);
  }
  std::printf("\nCompound gradient: %d configurations, max |analytic - finite difference| %.3g\n",
              checked, max_deviation);
  EXPECT_GE(checked, 30);
  EXPECT_EQ(log.total(), 0) << log.report();
}

// ---- invalid input ----

// Every kind of unusable input gives Status::invalid_input with a message, in either argument
// position, and no NaN anywhere in the result even with every output requested.
TEST(InvalidInput, RejectedWithMessageAndNoNaN) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const Shape<double> good = Shape<double>(Box<double>{Vec3<double>(1, 1, 1)});
  const Pose<double> good_pose = Pose<double>::identity();

  struct BadShape {
    const char* what;
    Shape<double> shape;
  };
  const std::vector<BadShape> bad_shapes = {
      {"empty polytope", Shape<double>(Polytope<double>(std::vector<Vec3<double>>{}))},
      {"default polytope", Shape<double>(Polytope<double>())},
      {"NaN vertex",
       Shape<double>(Polytope<double>(std::vector<Vec3<double>>{{0, 0, 0}, {1, nan, 0}}))},
      {"infinite vertex", Shape<double>(Polytope<double>(std::vector<Vec3<double>>{{inf, 0, 0}}))},
      {"negative radius", Shape<double>::sphere(-1)},
      {"NaN radius", Shape<double>::sphere(nan)},
      {"NaN segment end",
       Shape<double>::capsule(Vec3<double>(0, 0, 0), Vec3<double>(nan, 0, 0), 0.1)},
      {"negative box half extent", Shape<double>(Box<double>{Vec3<double>(1, -1, 1)})},
      {"NaN ellipsoid radius", Shape<double>(Ellipsoid<double>{Vec3<double>(1, nan, 1)})},
      {"negative cylinder radius", Shape<double>(Cylinder<double>{-1, 1})},
      {"infinite cone height", Shape<double>(Cone<double>{1, inf})},
  };
  struct BadPose {
    const char* what;
    Pose<double> pose;
    const char* reason;  // what the message must say
  };
  std::vector<BadPose> bad_poses;
  {
    Pose<double> p;
    p.translation[1] = nan;
    bad_poses.push_back({"NaN translation", p, "translation has a non-finite component"});
    p = Pose<double>();
    p.translation[2] = inf;
    bad_poses.push_back({"infinite translation", p, "translation has a non-finite component"});
    p = Pose<double>();
    p.rotation(1, 2) = nan;
    bad_poses.push_back({"NaN rotation entry", p, "rotation has a non-finite entry"});
    p = Pose<double>();
    p.rotation *= 2;
    bad_poses.push_back({"scaled rotation (not orthonormal)", p, "not orthonormal"});
    p = Pose<double>();
    p.rotation(0, 0) = -1;
    bad_poses.push_back({"reflection (determinant -1)", p, "reflection"});
  }

  DistanceOptions<double> options;
  options.near_points = true;
  options.penetration_bound = true;
  options.gradient = true;
  FailureLog log;
  auto expect_invalid = [&](const std::string& what, const DistanceResult<double>& r) {
    if (r.status != Status::invalid_input) log.add("not rejected", what);
    if (r.message == nullptr) log.add("no message", what);
    if (!nearpoint::testkit::all_finite(r)) log.add("NaN in the result", what);
  };
  for (const BadShape& s : bad_shapes) {
    if (nearpoint::invalid_reason(s.shape) == nullptr) log.add("invalid_reason() is null", s.what);
    expect_invalid(std::string(s.what) + " as A",
                   nearpoint::distance(s.shape, good_pose, good, good_pose, options));
    expect_invalid(std::string(s.what) + " as B",
                   nearpoint::distance(good, good_pose, s.shape, good_pose, options));
    const Compound<double> compound({{good, good_pose}, {s.shape, good_pose}});
    if (compound.invalid_reason() == nullptr)
      log.add("compound with an invalid piece accepted", s.what);
    const Compound<double> fine({{good, good_pose}});
    expect_invalid(std::string(s.what) + " in a compound",
                   nearpoint::distance(compound, good_pose, fine, good_pose, options).nearest);
  }
  for (const BadPose& p : bad_poses) {
    for (bool as_a : {true, false}) {
      const std::string what = std::string(p.what) + (as_a ? " as pose A" : " as pose B");
      const DistanceResult<double> r =
          as_a ? nearpoint::distance(good, p.pose, good, good_pose, options)
               : nearpoint::distance(good, good_pose, good, p.pose, options);
      expect_invalid(what, r);
      if (r.message && std::string(r.message).find(p.reason) == std::string::npos)
        log.add(std::string("message does not say \"") + p.reason + "\": " + r.message, what);
    }
    const Compound<double> fine({{good, good_pose}});
    expect_invalid(std::string(p.what) + " as a compound's pose",
                   nearpoint::distance(fine, p.pose, fine, good_pose, options).nearest);
  }
  // An empty compound, and caches of the wrong size.
  const Compound<double> empty;
  const Compound<double> fine({{good, good_pose}, {good, good_pose}});
  expect_invalid("empty compound",
                 nearpoint::distance(empty, good_pose, fine, good_pose, options).nearest);
  std::vector<SimplexCache> caches(3);  // needs 2 × 2
  expect_invalid("caches of the wrong size",
                 nearpoint::distance(fine, good_pose, fine, good_pose, options,
                                     std::span<SimplexCache>(caches))
                     .nearest);
  // And the valid inputs next to them are accepted (the checks above are not vacuous).
  EXPECT_EQ(nearpoint::distance(good, good_pose, good, good_pose, options).status,
            Status::intersecting);
  EXPECT_EQ(nearpoint::distance(fine, good_pose, fine, good_pose, options).nearest.status,
            Status::intersecting);
  EXPECT_EQ(log.total(), 0) << log.report();
}

}  // namespace
