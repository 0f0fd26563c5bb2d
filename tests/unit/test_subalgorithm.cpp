// SPDX-License-Identifier: Apache-2.0
// Unit tests of Johnson's distance subalgorithm and the Backup Procedure (paper Section V–VI),
// checked against a brute-force nearest point of co Y computed independently.
#include <gtest/gtest.h>

#include <Eigen/QR>
#include <bit>
#include <random>

#include "common/checks.hpp"
#include "johnson.hpp"
#include "signed_volumes.hpp"

namespace nearpoint::detail {
namespace {

using V = Vec3<double>;

// Nearest point of the convex hull of up to 4 points, by enumerating every face: project the
// origin onto the face's affine hull with a QR least-squares solve (long double), keep projections
// whose barycentric weights are all non-negative, and take the shortest. Independent of the Δ
// recursion under test.
V brute_force_nearest(const std::vector<V>& pts) {
  using L = long double;
  const int n = int(pts.size());
  V best = pts[0];
  for (unsigned s = 1; s < (1u << n); ++s) {
    std::vector<int> idx;
    for (int i = 0; i < n; ++i)
      if (s & (1u << i)) idx.push_back(i);
    const int r = int(idx.size());
    Eigen::Matrix<L, 3, 1> x0 = pts[idx[0]].cast<L>();
    Eigen::Matrix<L, 3, Eigen::Dynamic> q(3, r - 1);
    for (int c = 1; c < r; ++c) q.col(c - 1) = pts[idx[c]].cast<L>() - x0;
    Eigen::Matrix<L, Eigen::Dynamic, 1> mu(r - 1);
    if (r > 1) {
      Eigen::ColPivHouseholderQR<Eigen::Matrix<L, 3, Eigen::Dynamic>> qr(q);
      if (qr.rank() < r - 1) continue;  // affinely dependent face: its hull is covered by others
      mu = qr.solve(Eigen::Matrix<L, 3, 1>(-x0));
    }
    L first = 1;
    bool inside = true;
    for (int c = 0; c < r - 1; ++c) {
      inside &= mu[c] >= 0;
      first -= mu[c];
    }
    if (!inside || first < 0) continue;
    Eigen::Matrix<L, 3, 1> p = x0;
    for (int c = 0; c < r - 1; ++c) p += mu[c] * q.col(c);
    if (p.squaredNorm() < best.cast<L>().squaredNorm()) best = p.cast<double>();
  }
  return best;
}

Simplex<double> make_simplex(const std::vector<V>& pts) {
  Simplex<double> s;
  for (const V& p : pts) s.add(p, p, V::Zero(), 0, 0);
  s.newest = -1;
  return s;
}

Nearest<double> solve(Simplex<double> s, bool* used_backup = nullptr) {
  Nearest<double> out;
  const bool ok = distance_subalgorithm(s, subset_order(s, V(V::Zero())), out);
  if (!ok) backup_procedure(s, out);
  if (used_backup) *used_backup = !ok;
  return out;
}

// Guards the Δ recursion (eq. 30) and the subset test of step 2: the nearest point of random
// simplices of every size agrees with an independent minimiser.
TEST(Subalgorithm, RandomSimplicesMatchBruteForce) {
  std::mt19937_64 rng(12345);
  std::normal_distribution<double> normal(0.0, 1.0);
  int interior = 0, boundary = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const int n = 1 + trial % 4;
    std::vector<V> pts;
    const V shift = 0.3 * V(normal(rng), normal(rng), normal(rng));
    for (int i = 0; i < n; ++i) pts.emplace_back(V(normal(rng), normal(rng), normal(rng)) + shift);
    const Nearest<double> got = solve(make_simplex(pts));
    const V expected = brute_force_nearest(pts);
    if (std::popcount(got.subset) == 4) {
      ++interior;
    } else {
      ++boundary;
    }
    ASSERT_NEAR((got.nu - expected).norm(), 0.0, 1e-12) << "trial " << trial;
    double sum = 0;
    for (double l : got.lambda) {
      EXPECT_GE(l, 0.0);
      sum += l;
    }
    EXPECT_NEAR(sum, 1.0, 1e-12);
  }
  // The sample must exercise both exits: origin enclosed and nearest point on a proper face.
  EXPECT_GT(interior, 50);
  EXPECT_GT(boundary, 2000);
}

// Guards the Δ cache: replacing one slot and recomputing only the subsets that contain it must
// give the same Δ's as building the simplex from scratch.
TEST(Subalgorithm, IncrementalDeltasEqualFreshOnes) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int trial = 0; trial < 500; ++trial) {
    std::vector<V> pts;
    for (int i = 0; i < 4; ++i) pts.emplace_back(normal(rng), normal(rng), normal(rng));
    Simplex<double> inc = make_simplex({pts[0], pts[1], pts[2]});
    inc.keep(0b011);  // drop slot 2, then add the fourth point into it
    inc.add(pts[3], pts[3], V::Zero(), 0, 0);
    const Simplex<double> fresh = make_simplex({pts[0], pts[1], pts[3]});
    for (unsigned s = 1; s < 8; ++s)
      for (int i = 0; i < 3; ++i) {
        if (s & (1u << i)) {
          EXPECT_NEAR(inc.delta[s][i], fresh.delta[s][i], 1e-12);
        }
      }
  }
}

// eq. (30) as the paper states it, over every subset of `used`, smallest first, with inner
// products taken afresh: the reference for the engine's compiled updates.
void reference_deltas(const V (&y)[4], unsigned used, double delta[16][4]) {
  for (int size = 1; size <= 4; ++size)
    for (unsigned s = 1; s < 16; ++s) {
      if ((s & ~used) || std::popcount(s) != size) continue;
      for (int m = 0; m < 4; ++m) {
        if (!(s & (1u << m))) continue;
        const unsigned rest = s & ~(1u << m);
        if (!rest) {
          delta[s][m] = 1;
          continue;
        }
        const int k = std::countr_zero(rest);
        double sum = 0;
        for (int i = 0; i < 4; ++i)
          if (rest & (1u << i)) sum += delta[rest][i] * (y[i].dot(y[k]) - y[i].dot(y[m]));
        delta[s][m] = sum;
      }
    }
}

// Guards the Δ updates, compiled once per (occupancy, slot): for every combination, a point
// written into the slot and updated incrementally, and a rebuild of the whole table (which runs
// the updates slot by slot), must give the reference's Δ's and fresh inner products to the last
// bit.
TEST(Subalgorithm, DeltaUpdatesMatchTheRecursionForEveryOccupancyAndSlot) {
  std::mt19937_64 rng(99);
  std::normal_distribution<double> normal(0.0, 1.0);
  int combinations = 0;
  for (unsigned used = 1; used < 16; ++used) {
    for (int slot = 0; slot < 4; ++slot) {
      if (!(used & (1u << slot))) continue;
      ++combinations;
      for (int trial = 0; trial < 20; ++trial) {
        Simplex<double> inc;
        for (int i = 0; i < 4; ++i) inc.y[i] = V(normal(rng), normal(rng), normal(rng));
        inc.used = used;
        inc.tables_valid = false;
        inc.rebuild_tables();
        inc.y[slot] = V(normal(rng), normal(rng), normal(rng));  // the slot takes a new point
        inc.update_tables_for(slot);
        Simplex<double> fresh;
        for (int i = 0; i < 4; ++i) fresh.y[i] = inc.y[i];
        fresh.used = used;
        fresh.tables_valid = false;
        fresh.rebuild_tables();
        double expected[16][4];
        reference_deltas(inc.y, used, expected);
        for (unsigned s = 1; s < 16; ++s) {
          if (s & ~used) continue;
          for (int i = 0; i < 4; ++i) {
            if (!(s & (1u << i))) continue;
            // Bit for bit, unless the build fuses multiply-adds (testkit::kFusedMultiplyAdd):
            // then within a rounding of the terms, which are O(1) here.
            const double slack = testkit::fused_rounding_slack(expected[s][i], 1e-13);
            EXPECT_NEAR(inc.delta[s][i], expected[s][i], slack)
                << "update: occupancy " << used << ", slot " << slot << ", subset " << s << ", i "
                << i;
            EXPECT_NEAR(fresh.delta[s][i], expected[s][i], slack)
                << "rebuild: occupancy " << used << ", subset " << s << ", i " << i;
            const double dot = inc.y[slot].dot(inc.y[i]);
            const double dot_slack = testkit::fused_rounding_slack(dot, 1e-14);
            EXPECT_NEAR(inc.dot[slot][i], dot, dot_slack);
            EXPECT_NEAR(inc.dot[i][slot], dot, dot_slack);
          }
        }
      }
    }
  }
  EXPECT_EQ(combinations, 32);
}

// The paper: "Δ(Y_s) > 0 if and only if Y_s is affinely independent" (Lemma 1). Duplicate and
// collinear points must not produce a NaN or a wrong nearest point.
TEST(Subalgorithm, AffinelyDependentSetsAreHandled) {
  const std::vector<std::vector<V>> cases = {
      {V(1, 1, 0), V(1, 1, 0)},                          // duplicate
      {V(1, -1, 1), V(1, 0, 1), V(1, 1, 1)},             // collinear, nearest in the middle
      {V(2, 0, 0), V(2, 1, 0), V(2, 0, 1), V(2, 1, 1)},  // coplanar quadrilateral
      {V(1, 0, 0), V(1, 0, 0), V(1, 0, 0), V(1, 0, 0)},  // four copies
      {V(-1, 0, 0), V(1, 0, 0), V(3, 0, 0)},             // collinear through the origin
  };
  for (const auto& pts : cases) {
    const Nearest<double> got = solve(make_simplex(pts));
    const V expected = brute_force_nearest(pts);
    EXPECT_TRUE(got.nu.allFinite());
    EXPECT_NEAR((got.nu - expected).norm(), 0.0, 1e-9);
  }
}

// Guards eq. (38): the Backup Procedure alone (no Distance Subalgorithm) still finds the nearest
// point whenever the nearest face is affinely independent.
TEST(Subalgorithm, BackupProcedureFindsNearestPoint) {
  std::mt19937_64 rng(99);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int trial = 0; trial < 1000; ++trial) {
    std::vector<V> pts;
    for (int i = 0; i < 1 + trial % 4; ++i) pts.emplace_back(normal(rng), normal(rng), normal(rng));
    Simplex<double> s = make_simplex(pts);
    Nearest<double> got;
    backup_procedure(s, got);
    EXPECT_NEAR((got.nu - brute_force_nearest(pts)).norm(), 0.0, 1e-12) << trial;
  }
}

// Guards eq. (32)–(33): d⁻ of a tetrahedron around the origin is its inradius about the origin,
// the distance to the nearest face plane.
TEST(Subalgorithm, PenetrationBoundIsNearestFacePlane) {
  // Regular-ish tetrahedron with the origin inside; face planes computed directly.
  const std::vector<V> pts = {V(1, 1, 1), V(-1, -1, 1), V(-1, 1, -1), V(1, -1, -1)};
  const Simplex<double> s = make_simplex(pts);
  Nearest<double> got = solve(s);
  ASSERT_EQ(std::popcount(got.subset), 4);
  EXPECT_EQ(got.nu_norm2, 0.0);
  double nearest_plane = 1e300;
  for (int drop = 0; drop < 4; ++drop) {
    std::vector<V> f;
    for (int i = 0; i < 4; ++i)
      if (i != drop) f.push_back(pts[i]);
    const V n = (f[1] - f[0]).cross(f[2] - f[0]).normalized();
    nearest_plane = std::min(nearest_plane, std::abs(n.dot(f[0])));
  }
  EXPECT_NEAR(penetration_lower_bound(s, got.subset), nearest_plane, 1e-14);
  EXPECT_NEAR(nearest_plane, 1.0 / std::sqrt(3.0), 1e-15);
}

// The paper's ordering rule puts the face V_k \ {y} first, y maximising y·w. When it holds the
// answer, the subalgorithm must return it (and the order must list every subset once).
TEST(Subalgorithm, OrderingListsEverySubsetOnce) {
  Simplex<double> s = make_simplex({V(1, 0, 0), V(0, 1, 0), V(0, 0, 1)});
  s.add(V(1, 1, 1), V(1, 1, 1), V::Zero(), 0, 0);  // newest in slot 3
  const SubsetOrder& order = subset_order(s, V(1, 1, 1));
  EXPECT_EQ(order.count, 15);
  unsigned seen = 0;
  for (int i = 0; i < order.count; ++i) {
    EXPECT_EQ(seen & (1u << order.subsets[i]), 0u);
    seen |= 1u << order.subsets[i];
  }
  EXPECT_TRUE(order.subsets[0] & (1u << 3)) << "the first candidate contains the newest point";
  EXPECT_EQ(std::popcount(order.subsets[0]), 3);
}

// Guards the signed-volumes subalgorithm (Montanari et al. 2017) on the same random simplices,
// including initial simplices where the nearest face does not contain the last slot.
TEST(SignedVolumes, RandomSimplicesMatchBruteForce) {
  std::mt19937_64 rng(2024);
  std::normal_distribution<double> normal(0.0, 1.0);
  int interior = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const int n = 1 + trial % 4;
    std::vector<V> pts;
    const V shift = 0.3 * V(normal(rng), normal(rng), normal(rng));
    for (int i = 0; i < n; ++i) pts.emplace_back(V(normal(rng), normal(rng), normal(rng)) + shift);
    Nearest<double> got;
    signed_volumes(make_simplex(pts), got);
    interior += std::popcount(got.subset) == 4;
    ASSERT_NEAR((got.nu - brute_force_nearest(pts)).norm(), 0.0, 1e-12) << "trial " << trial;
    double sum = 0;
    for (double l : got.lambda) {
      EXPECT_GE(l, 0.0);
      sum += l;
    }
    EXPECT_NEAR(sum, 1.0, 1e-12);
  }
  EXPECT_GT(interior, 50);
}

// The shortcuts of signed volumes: a tetrahedron whose origin sees exactly one face answers with
// that face, and a triangle whose origin's projection lies beyond exactly one edge answers with
// that edge, without comparing candidates. Both must agree with the brute-force minimiser, and
// the random set must exercise them and the multi-candidate cases alike (classified here from
// long-double plane sides, independently of the code under test).
TEST(SignedVolumes, SingleFaceAndSingleEdgeShortcutsMatchBruteForce) {
  using L = long double;
  std::mt19937_64 rng(4711);
  std::normal_distribution<double> normal(0.0, 1.0);
  auto side = [](const V& a, const V& b, const V& c, const V& p) {
    const Eigen::Matrix<L, 3, 1> u = (b - a).cast<L>(), v = (c - a).cast<L>(),
                                 w = (p - a).cast<L>();
    return u.cross(v).dot(w);
  };
  int tetra_by_faces[5] = {0, 0, 0, 0, 0};
  int triangle_by_edges[4] = {0, 0, 0, 0};
  for (int trial = 0; trial < 6000; ++trial) {
    const int n = 3 + trial % 2;
    const V shift = 1.2 * V(normal(rng), normal(rng), normal(rng));
    std::vector<V> pts;
    for (int i = 0; i < n; ++i) pts.emplace_back(V(normal(rng), normal(rng), normal(rng)) + shift);
    const V origin = V::Zero();
    if (n == 4) {
      int visible = 0;
      for (int m = 0; m < 4; ++m) {
        const V& a = pts[(m + 1) % 4];
        const V& b = pts[(m + 2) % 4];
        const V& c = pts[(m + 3) % 4];
        visible += (side(a, b, c, origin) > 0) != (side(a, b, c, pts[m]) > 0);
      }
      ++tetra_by_faces[visible];
    } else {
      // The origin's projection beyond edge m: it and vertex m on different sides of the edge,
      // within the triangle's plane (sides measured with the plane normal).
      const Eigen::Matrix<L, 3, 1> normal_l =
          (pts[1] - pts[0]).cast<L>().cross((pts[2] - pts[0]).cast<L>());
      int beyond = 0;
      for (int m = 0; m < 3; ++m) {
        const Eigen::Matrix<L, 3, 1> a = pts[(m + 1) % 3].cast<L>(), b = pts[(m + 2) % 3].cast<L>();
        const Eigen::Matrix<L, 3, 1> edge_normal = (b - a).cross(normal_l);
        beyond += ((-a).dot(edge_normal) > 0) != ((pts[m].cast<L>() - a).dot(edge_normal) > 0);
      }
      ++triangle_by_edges[beyond];
    }
    Nearest<double> got;
    signed_volumes(make_simplex(pts), got);
    ASSERT_NEAR((got.nu - brute_force_nearest(pts)).norm(), 0.0, 1e-12) << "trial " << trial;
  }
  std::printf(
      "tetrahedra seeing 0/1/2/3 faces: %d/%d/%d/%d; triangles beyond 0/1/2 edges: %d/%d/%d\n",
      tetra_by_faces[0], tetra_by_faces[1], tetra_by_faces[2], tetra_by_faces[3],
      triangle_by_edges[0], triangle_by_edges[1], triangle_by_edges[2]);
  EXPECT_GT(tetra_by_faces[0], 20);                       // encloses the origin
  EXPECT_GT(tetra_by_faces[1], 300);                      // the single-face shortcut
  EXPECT_GT(tetra_by_faces[2] + tetra_by_faces[3], 300);  // the minimum over several faces
  EXPECT_GT(triangle_by_edges[1], 300);                   // the single-edge shortcut
  EXPECT_GT(triangle_by_edges[2], 100);                   // the minimum over two edges
}

// Small simplices far from the origin are where the Δ recursion (differences of inner products of
// large vectors) loses digits and signed volumes should not. Both must stay within a tolerance
// scaled to the simplex's distance; signed volumes must be at least as accurate overall.
TEST(SignedVolumes, SmallSimplexFarFromOriginStaysAccurate) {
  std::mt19937_64 rng(77);
  std::normal_distribution<double> normal(0.0, 1.0);
  double worst_johnson = 0, worst_sv = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const int n = 2 + trial % 3;
    const V far = 1e3 * V(normal(rng), normal(rng), normal(rng)).normalized();
    std::vector<V> pts;
    // Points spread across the plane through `far` perpendicular to it (with a little depth), so
    // that the origin projects inside the simplex: the hard case, an interior answer.
    for (int i = 0; i < n; ++i) {
      V offset = V(normal(rng), normal(rng), normal(rng));
      offset -= (offset.dot(far) / far.squaredNorm()) * far * 0.99;
      pts.emplace_back(far + 1e-3 * offset);
    }
    const V expected = brute_force_nearest(pts);
    const Simplex<double> s = make_simplex(pts);
    Nearest<double> sv;
    signed_volumes(s, sv);
    const Nearest<double> jo = solve(s);
    worst_sv = std::max(worst_sv, (sv.nu - expected).norm());
    worst_johnson = std::max(worst_johnson, (jo.nu - expected).norm());
  }
  std::printf(
      "simplex of size 1e-3 at distance 1e3: worst |nu - exact|: johnson %.3g, "
      "signed volumes %.3g\n",
      worst_johnson, worst_sv);
  EXPECT_LT(worst_sv, 1e-11);
  EXPECT_LT(worst_johnson, 1e-6);
}

// A segment's weights come from the inner products s₂·t and −s₁·t (each endpoint's own), with no
// projection of the origin formed first. Short segments far from the origin whose interior holds
// the answer: ν must stay within a few ulps of the distance of the exact nearest point (long
// double), and the weights must be positive and sum to 1. (Measured worst: 2.5e-16 of |y|; the
// published routine's projecting version 2.8e-16. Over all sizes in the test above, 5.7e-14
// against its 1.3e-13.)
TEST(SignedVolumes, ShortSegmentFarFromOriginKeepsItsWeightsAccurate) {
  using L = long double;
  std::mt19937_64 rng(1988);
  std::normal_distribution<double> normal(0.0, 1.0);
  double worst = 0;
  int interior = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const double distance = std::pow(10.0, -2.0 + 5.0 * (trial % 100) / 99.0);  // 1e-2 … 1e3
    const V far = distance * V(normal(rng), normal(rng), normal(rng)).normalized();
    V along = V(normal(rng), normal(rng), normal(rng));
    along -= (along.dot(far) / far.squaredNorm()) * far;
    along.normalize();
    const double length =
        distance * std::pow(10.0, -6.0 * (trial % 7) / 6.0);  // down to 1e-6 of it
    const double at = std::uniform_real_distribution<double>(0.05, 0.95)(rng);
    const std::vector<V> pts = {far - at * length * along, far + (1 - at) * length * along};
    // The exact nearest point of the segment in long double.
    const Eigen::Matrix<L, 3, 1> a = pts[0].cast<L>(), b = pts[1].cast<L>();
    const Eigen::Matrix<L, 3, 1> t = b - a;
    const L mu = std::clamp(-a.dot(t) / t.squaredNorm(), L(0), L(1));
    const Eigen::Matrix<L, 3, 1> exact = a + mu * t;
    Nearest<double> got;
    signed_volumes(make_simplex(pts), got);
    interior += got.subset == 3u;
    ASSERT_GE(got.lambda[0], 0.0);
    ASSERT_GE(got.lambda[1], 0.0);
    EXPECT_NEAR(got.lambda[0] + got.lambda[1], 1.0, 4e-16);
    const double scale = std::max(pts[0].norm(), pts[1].norm());
    worst = std::max(worst, double((got.nu.cast<L>() - exact).norm() / L(scale)));
  }
  std::printf("short segments far from the origin: worst |nu - exact| / |y| = %.3g\n", worst);
  EXPECT_GT(interior, 3800);
  EXPECT_LT(worst, 4 * std::numeric_limits<double>::epsilon());
}

// A tetrahedron of size s at distance R from the origin never encloses it, however large R/s: the
// verdict "intersecting" rests on the signs of its four volumes with the origin. The one formed
// from the points alone, det(p1, p2, p3), once cancelled terms of |p|² and took its sign from
// roundoff from R/s ≈ 4·10³ in float (≈ 7·10⁷ in double): a warm start that moved a tetrahedron
// from around the origin to 1.2·10⁷ away answered "intersecting" (fuzz_engine, regressions/
// engine/float-perturbed-warm-start-intersecting-7e6-apart). The nearest point found instead must
// be the exact one (long double) to within the roundoff of the points' size.
template <class S>
void check_far_tetrahedra(int trials) {
  using L = long double;
  using VS = Vec3<S>;
  std::mt19937_64 rng(2026);
  std::normal_distribution<double> normal(0.0, 1.0);
  int enclosed_sv = 0, enclosed_johnson = 0;
  double worst = 0;
  for (int trial = 0; trial < trials; ++trial) {
    const double ratio = std::pow(10.0, 1.0 + 9.0 * (trial % 100) / 99.0);  // R/s: 10 … 10¹⁰
    const V far = ratio * V(normal(rng), normal(rng), normal(rng)).normalized();
    std::vector<V> pts;
    for (int i = 0; i < 4; ++i)
      pts.emplace_back((far + V(normal(rng), normal(rng), normal(rng)))
                           .template cast<S>()
                           .template cast<double>());
    Simplex<S> simplex;
    for (const V& p : pts)
      simplex.add(p.template cast<S>(), p.template cast<S>(), VS::Zero(), 0, 0);
    simplex.newest = -1;
    enclosed_johnson += simplex.encloses_origin();
    Nearest<S> sv;
    signed_volumes(simplex, sv);
    enclosed_sv += sv.subset == 15u;
    const V exact = brute_force_nearest(pts);
    double size = 0;
    for (const V& p : pts) size = std::max(size, p.norm());
    worst = std::max(
        worst, double((sv.nu.template cast<L>() - exact.template cast<L>()).norm() / L(size)));
  }
  std::printf(
      "tetrahedra 10 to 1e10 of their sizes from the origin (%s): enclosed: signed volumes %d, "
      "johnson %d; worst |nu - exact| / |y| = %.3g\n",
      sizeof(S) == 4 ? "float" : "double", enclosed_sv, enclosed_johnson, worst);
  EXPECT_EQ(enclosed_sv, 0);
  EXPECT_EQ(enclosed_johnson, 0);
  // The faces' accuracy far away is SmallSimplexFarFromOriginStaysAccurate's subject; here the
  // nearest point found instead of "enclosed" must only be the right one (g++ float: 2.4e-5 at
  // 1e10, where one ulp of the points is 1e3 times the tetrahedron).
  EXPECT_LT(worst, 1024 * std::numeric_limits<S>::epsilon());
}

TEST(SignedVolumes, FarTetrahedronNeverEnclosesTheOriginInFloat) {
  check_far_tetrahedra<float>(2000);
}
TEST(SignedVolumes, FarTetrahedronNeverEnclosesTheOriginInDouble) {
  check_far_tetrahedra<double>(2000);
}

}  // namespace
}  // namespace nearpoint::detail
