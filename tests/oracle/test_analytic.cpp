// SPDX-License-Identifier: Apache-2.0
// Analytic oracles: shape pairs whose distance has a closed form (or a 1-D root find), evaluated
// in long double from the very double inputs the engine sees. Each family draws many random
// configurations from a fixed seed, checks that both verdicts occur in it, and holds the engine to
// its own certified error bound.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>
#include <string>
#include <variant>
#include <vector>

#include "common/checks.hpp"
#include "common/exact_distance.hpp"
#include "common/paper_family.hpp"
#include "nearpoint/distance.hpp"

namespace {

using nearpoint::Box;
using nearpoint::Cone;
using nearpoint::Cylinder;
using nearpoint::DistanceOptions;
using nearpoint::DistanceResult;
using nearpoint::Ellipsoid;
using nearpoint::Mat3;
using nearpoint::Point;
using nearpoint::Polytope;
using nearpoint::Pose;
using nearpoint::Segment;
using nearpoint::Shape;
using nearpoint::Status;
using nearpoint::Vec3;
using nearpoint::testkit::FailureLog;
using nearpoint::testkit::format;
using nearpoint::testkit::random_rotation;
using nearpoint::testkit::random_unit_vector;
using nearpoint::testkit::uniform;
using Real = long double;
using V = Vec3<Real>;

// ---- closed-form truths (long double) ----

V to_real(const Vec3<double>& v) {
  return v.cast<Real>();
}
// A world point in a pose's local frame, assuming the rotation is orthonormal (it is to ~1e-16,
// which moves the truth by ~1e-16·scale: far below the tolerances used).
V to_local(const Pose<double>& pose, const V& world) {
  return pose.rotation.cast<Real>().transpose() * (world - to_real(pose.translation));
}
V to_world(const Pose<double>& pose, const Vec3<double>& local) {
  return pose.rotation.cast<Real>() * to_real(local) + to_real(pose.translation);
}

// Closest points between segments [p1,q1] and [p2,q2] (Ericson, "Real-Time Collision Detection",
// 5.1.9): minimise |p1 + s·d1 − p2 − t·d2| over s, t ∈ [0,1] by clamping the unconstrained
// solution, re-solving for the other parameter, clamping again. Returns the distance.
Real segment_segment(const V& p1, const V& q1, const V& p2, const V& q2) {
  const V d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const Real a = d1.dot(d1), e = d2.dot(d2), f = d2.dot(r);
  auto clamp01 = [](Real x) { return std::clamp(x, Real(0), Real(1)); };
  Real s = 0, t = 0;
  if (a == 0 && e == 0) return r.norm();
  if (a == 0) {
    t = clamp01(f / e);
  } else {
    const Real c = d1.dot(r);
    if (e == 0) {
      s = clamp01(-c / a);
    } else {
      const Real b = d1.dot(d2), denom = a * e - b * b;
      s = denom != 0 ? clamp01((b * f - c * e) / denom) : 0;  // parallel: any s, take 0
      t = (b * s + f) / e;
      if (t < 0) {
        t = 0;
        s = clamp01(-c / a);
      } else if (t > 1) {
        t = 1;
        s = clamp01((b - c) / a);
      }
    }
  }
  return (p1 + s * d1 - p2 - t * d2).norm();
}

Real point_segment(const V& x, const V& p, const V& q) {
  const V d = q - p;
  const Real dd = d.dot(d);
  const Real s = dd > 0 ? std::clamp((x - p).dot(d) / dd, Real(0), Real(1)) : 0;
  return (x - p - s * d).norm();
}

// An independent check of segment_segment: the distance from p1 + s·d1 to the other segment is
// convex in s, so a golden-section search over s with the point–segment formula converges to the
// same minimum.
Real segment_segment_by_search(const V& p1, const V& q1, const V& p2, const V& q2) {
  auto g = [&](Real s) { return point_segment(p1 + s * (q1 - p1), p2, q2); };
  Real lo = 0, hi = 1;
  const Real phi = (std::sqrt(Real(5)) - 1) / 2;
  for (int i = 0; i < 200; ++i) {
    const Real m1 = hi - phi * (hi - lo), m2 = lo + phi * (hi - lo);
    if (g(m1) < g(m2))
      hi = m2;
    else
      lo = m1;
  }
  return std::min({g(lo), g(hi), g(0), g(1)});
}

// Signed distance from a local point to the box [-h, h]: > 0 outside (Euclidean distance),
// ≤ 0 inside (minus the depth to the nearest face).
Real box_signed(const V& q, const V& h) {
  const V excess = q.cwiseAbs() - h;
  if ((excess.array() > 0).any()) return excess.cwiseMax(Real(0)).norm();
  return excess.maxCoeff();
}

// Signed distance to the cylinder about z (radius R, half height h), same convention.
Real cylinder_signed(const V& q, Real radius, Real half_height) {
  const Real rho = std::hypot(q.x(), q.y());
  const Real dr = rho - radius, dz = std::abs(q.z()) - half_height;
  if (dr > 0 || dz > 0) return std::hypot(std::max(dr, Real(0)), std::max(dz, Real(0)));
  return std::max(dr, dz);
}

Real point_segment_2d(Real x, Real y, Real ax, Real ay, Real bx, Real by) {
  return point_segment(V(x, y, 0), V(ax, ay, 0), V(bx, by, 0));
}

// Signed distance to the cone (base disc radius R at z = −h, apex at z = +h). A solid of
// revolution: the nearest point lies in the query point's meridian half-plane, where the cone is
// the triangle (0,−h), (R,−h), (0,h) in (ρ, z). Outside: distance to that triangle; inside: minus
// the distance to the base or the slanted side (the axis is not part of the 3-D boundary).
Real cone_signed(const V& q, Real radius, Real half_height) {
  const Real rho = std::hypot(q.x(), q.y()), z = q.z(), h = half_height;
  const Real base = point_segment_2d(rho, z, 0, -h, radius, -h);
  const Real slant = point_segment_2d(rho, z, radius, -h, 0, h);
  const bool inside = z >= -h && rho / radius + (z + h) / (2 * h) <= 1;
  if (inside) return -std::min(base, slant);
  const Real axis = point_segment_2d(rho, z, 0, -h, 0, h);
  return std::min({base, slant, axis});
}

// Distance from a local point to the ellipsoid Σ x²/a² ≤ 1 and the nearest point. Outside, the
// nearest point is x_i = a_i² q_i / (a_i² + μ) with μ > 0 the root of
// F(μ) = Σ (a_i q_i / (a_i² + μ))² − 1, which decreases from F(0) > 0 to F(a_max·|q|) ≤ 0:
// bisection in long double to the last bit. Returns 0 (and q) inside.
Real ellipsoid_distance(const V& q, const V& a, V* nearest = nullptr) {
  const V scaled = q.cwiseQuotient(a);
  if (scaled.squaredNorm() <= 1) {
    if (nearest) *nearest = q;
    return 0;
  }
  auto F = [&](Real mu) {
    Real sum = 0;
    for (int i = 0; i < 3; ++i) {
      const Real term = a[i] * q[i] / (a[i] * a[i] + mu);
      sum += term * term;
    }
    return sum - 1;
  };
  Real lo = 0, hi = a.maxCoeff() * q.norm();
  for (int i = 0; i < 400 && lo < hi; ++i) {
    const Real mid = (lo + hi) / 2;
    if (mid == lo || mid == hi) break;
    (F(mid) > 0 ? lo : hi) = mid;
  }
  const Real mu = (lo + hi) / 2;
  V x;
  for (int i = 0; i < 3; ++i) x[i] = a[i] * a[i] * q[i] / (a[i] * a[i] + mu);
  if (nearest) *nearest = x;
  return (q - x).norm();
}

// ---- the shared check ----

// For a convex set K, a point q outside it at distance d and its nearest point x*, every p ∈ K
// satisfies |p − q|² ≥ d² + |p − x*|² (the angle at x* is obtuse). A reported near point p with
// |p − q| ≤ d + e therefore lies within √(2·d·e + e²) of x*. Smooth shapes need this: their
// near point is a convex combination of nearby support points, slightly inside the surface.
double stationary_radius(double d, double error_bound, double floor) {
  const double e = error_bound + floor;
  return std::sqrt(2 * d * e + e * e) + floor;
}

// A near point with signed distance `off` to its (smooth) shape: inside it up to rounding, and
// no deeper than its possible distance from the true nearest point.
bool on_surface(Real off, double d, double error_bound) {
  const double floor = 1e-12 * 10;
  return off <= floor && off >= -stationary_radius(d, error_bound, floor);
}

Pose<double> random_pose(std::mt19937_64& rng, double spread) {
  Pose<double> p;
  p.rotation = random_rotation(rng);
  p.translation = Vec3<double>(uniform(rng, -spread, spread), uniform(rng, -spread, spread),
                               uniform(rng, -spread, spread));
  return p;
}

// The 24 rotations that map the axes onto the axes: exact in floating point (entries 0, ±1).
Mat3<double> axis_rotation(std::mt19937_64& rng) {
  static const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (;;) {
    const int* p = perms[rng() % 6];
    Mat3<double> r = Mat3<double>::Zero();
    for (int i = 0; i < 3; ++i) r(i, p[i]) = rng() % 2 ? 1.0 : -1.0;
    if (r.determinant() > 0) return r;
  }
}

DistanceOptions<double> near_point_options() {
  DistanceOptions<double> o;
  o.near_points = true;
  o.penetration_bound = true;
  return o;
}

// Tally of one family: how many configurations of each verdict it held, and the largest error.
struct Family {
  const char* name;
  FailureLog log;
  int separated = 0;
  int intersecting = 0;
  int total = 0;
  double max_error = 0;
  double max_bound = 0;

  explicit Family(const char* n) : name(n) {}

  // `signed_truth`: the exact signed distance of the rounded shapes (> 0 apart, ≤ 0 overlapping
  // by minus that much), `scale`: the largest coordinate involved. Checks no NaN, the verdict
  // (when the truth is decided by more than rounding), |d − d_true| ≤ max(floor, error_bound),
  // and that the bound is meaningful for well-separated shapes. Returns false if the result is
  // unusable for further checks.
  bool check(const std::string& where, const DistanceResult<double>& r, Real signed_truth,
             double scale) {
    ++total;
    if (!nearpoint::testkit::all_finite(r)) log.add("NaN or infinity", where);
    if (r.status == Status::invalid_input || r.status == Status::iteration_limit) {
      log.add("status", where + " " + nearpoint::to_string(r.status));
      return false;
    }
    // The truth is exact to ~1e-18 relative; the engine works in double on coordinates of size
    // `scale`: 1e-12·(1 + scale) is thousands of ulps of that, far below any algorithmic error.
    const double floor = 1e-12 * (1 + scale);
    const Real truth = std::max(signed_truth, Real(0));
    if (signed_truth > floor) {
      ++separated;
      if (r.status != Status::separated) log.add("verdict: separated reported intersecting", where);
    } else if (signed_truth < -floor) {
      ++intersecting;
      if (r.status != Status::intersecting)
        log.add("verdict: intersecting reported separated",
                format("%s d=%.3g", where.c_str(), r.distance));
    }
    const double error = double(std::abs(Real(r.distance) - truth));
    max_error = std::max(max_error, error);
    max_bound = std::max(max_bound, r.error_bound);
    if (!(error <= std::max(floor, r.error_bound)))
      log.add("|d - d_true| > max(floor, error_bound)",
              format("%s d=%.17g true=%.17Lg error=%.3g bound=%.3g", where.c_str(), r.distance,
                     truth, error, r.error_bound));
    // The bound is meaningful: even the paper's ε = 2.2e-14 in eq. (35) would certify shapes at
    // least 0.05 apart with D(K) ≲ 30 to g/|ν| ≤ 2.2e-14·900/0.05 ≈ 4e-10; the default ε is
    // smaller still.
    if (truth >= 0.05 && !(r.error_bound <= 1e-9))
      log.add("error bound looser than 1e-9 for separated shapes",
              format("%s bound=%.3g", where.c_str(), r.error_bound));
    if (r.status == Status::intersecting && r.distance != 0) log.add("intersecting, d != 0", where);
    return true;
  }

  void finish() {
    std::printf(
        "  %-28s n=%4d separated %4d intersecting %4d  max |d - d_true| %.3g  max bound %.3g\n",
        name, total, separated, intersecting, max_error, max_bound);
    std::fflush(stdout);
    EXPECT_EQ(log.total(), 0) << name << "\n" << log.report();
  }

  // Both verdicts are exercised: each makes up at least `min_fraction` of the sample.
  void expect_mixed(double min_fraction) {
    EXPECT_GE(separated, int(min_fraction * total)) << name;
    EXPECT_GE(intersecting, int(min_fraction * total)) << name;
  }
};

constexpr int kSamples = 2000;

// Sphere–sphere (points with radii, eq. 5–8): d = (|c_B − c_A| − r_A − r_B)⁺, near points on the
// spheres along the centre line — also when only the rounded shapes overlap, where they are each
// sphere's deepest point and the penetration depth r_A + r_B − |c_B − c_A| is known exactly.
TEST(Analytic, SphereSphere) {
  std::mt19937_64 rng(101);
  Family fam("sphere-sphere");
  const auto options = near_point_options();
  for (int k = 0; k < kSamples; ++k) {
    const double ra = uniform(rng, 0.1, 2), rb = uniform(rng, 0.1, 2);
    const Pose<double> pa = random_pose(rng, 1.5), pb = random_pose(rng, 1.5);
    const auto r =
        nearpoint::distance(Shape<double>::sphere(ra), pa, Shape<double>::sphere(rb), pb, options);
    const V ca = to_real(pa.translation), cb = to_real(pb.translation);
    const Real centre_distance = (cb - ca).norm();
    const std::string where = format("sample %d", k);
    if (!fam.check(where, r, centre_distance - ra - rb, 6)) continue;
    const double tol = 1e-12 * 10;
    const V n = (cb - ca) / centre_distance;
    if (!((to_real(r.point_a) - (ca + ra * n)).norm() <= tol &&
          (to_real(r.point_b) - (cb - rb * n)).norm() <= tol))
      fam.log.add("near points not on the centre line at the spheres' surfaces", where);
    if (r.status == Status::intersecting &&
        !(r.penetration_bound >= 0 && r.penetration_bound <= ra + rb - centre_distance + tol))
      fam.log.add("penetration bound above the exact depth", where);
  }
  fam.expect_mixed(0.2);
  fam.finish();
}

// Capsule–capsule (segments with radii): the segment distance by the clamp formula (itself
// cross-checked by a golden-section search), including near-parallel segments, the hard case of
// the segment formula and a degenerate (flat) Minkowski difference for GJK. Near points lie on the
// rounded surfaces: at distance r from their core segment.
TEST(Analytic, CapsuleCapsule) {
  std::mt19937_64 rng(202);
  Family fam("capsule-capsule");
  const auto options = near_point_options();
  int parallel = 0;
  double oracle_disagreement = 0;
  for (int k = 0; k < kSamples; ++k) {
    const Pose<double> pa = random_pose(rng, 0.8), pb = random_pose(rng, 0.8);
    const Segment<double> sa{
        Vec3<double>(uniform(rng, -1.5, 1.5), uniform(rng, -1.5, 1.5), uniform(rng, -1.5, 1.5)),
        Vec3<double>(uniform(rng, -1.5, 1.5), uniform(rng, -1.5, 1.5), uniform(rng, -1.5, 1.5))};
    Segment<double> sb{
        Vec3<double>(uniform(rng, -1.5, 1.5), uniform(rng, -1.5, 1.5), uniform(rng, -1.5, 1.5)),
        Vec3<double>(uniform(rng, -1.5, 1.5), uniform(rng, -1.5, 1.5), uniform(rng, -1.5, 1.5))};
    if (k % 5 == 0) {  // B parallel to A in the world (up to rounding)
      const Vec3<double> dir_world = pa.rotation * (sa.b - sa.a);
      sb.b = sb.a + uniform(rng, 0.3, 1.5) * (pb.rotation.transpose() * dir_world);
      ++parallel;
    }
    const double ra = uniform(rng, 0.05, 0.6), rb = uniform(rng, 0.05, 0.6);
    const auto r =
        nearpoint::distance(Shape<double>(sa, ra), pa, Shape<double>(sb, rb), pb, options);
    const V a0 = to_world(pa, sa.a), a1 = to_world(pa, sa.b), b0 = to_world(pb, sb.a),
            b1 = to_world(pb, sb.b);
    const Real d0 = segment_segment(a0, a1, b0, b1);
    oracle_disagreement = std::max(
        oracle_disagreement, double(std::abs(d0 - segment_segment_by_search(a0, a1, b0, b1))));
    const std::string where = format("sample %d%s", k, k % 5 == 0 ? " (parallel)" : "");
    if (!fam.check(where, r, d0 - ra - rb, 6)) continue;
    if (r.status == Status::separated) {
      // On the rounded surfaces: distance r from the core segment.
      const double tol = 1e-12 * 10 + r.error_bound;
      const Real on_a = point_segment(to_real(r.point_a), a0, a1) - ra;
      const Real on_b = point_segment(to_real(r.point_b), b0, b1) - rb;
      if (!(std::abs(on_a) <= tol && std::abs(on_b) <= tol))
        fam.log.add("near points off the rounded surfaces",
                    format("%s off by %.3Lg, %.3Lg", where.c_str(), on_a, on_b));
      if (!(std::abs((r.point_b - r.point_a).norm() - r.distance) <= 1e-12 * 10))
        fam.log.add("|point_b - point_a| != d", where);
    }
  }
  std::printf("  capsule oracle: clamp formula vs golden-section search, max difference %.3g\n",
              oracle_disagreement);
  EXPECT_LE(oracle_disagreement, 1e-12) << "the test's own segment oracle is inconsistent";
  EXPECT_EQ(parallel, kSamples / 5);
  fam.expect_mixed(0.2);
  fam.finish();
}

// Box–point with axis-aligned poses (the 24 exact axis rotations): d = |(|q| − h)⁺|, exact
// arithmetic in the box frame. Also the near point on the box: the clamp of q to the box.
TEST(Analytic, BoxPointAxisAligned) {
  std::mt19937_64 rng(303);
  Family fam("box-point (axis-aligned)");
  const auto options = near_point_options();
  for (int k = 0; k < kSamples; ++k) {
    const Vec3<double> h(uniform(rng, 0.2, 2), uniform(rng, 0.2, 2), uniform(rng, 0.2, 2));
    Pose<double> pa;
    pa.rotation = axis_rotation(rng);
    pa.translation = Vec3<double>(uniform(rng, -2, 2), uniform(rng, -2, 2), uniform(rng, -2, 2));
    Pose<double> pb;
    pb.translation = pa.translation + Vec3<double>(uniform(rng, -1.8, 1.8), uniform(rng, -1.8, 1.8),
                                                   uniform(rng, -1.8, 1.8));
    const auto r =
        nearpoint::distance(Shape<double>(Box<double>{h}), pa, Shape<double>(Point{}), pb, options);
    const V q = to_local(pa, to_real(pb.translation));
    const std::string where = format("sample %d", k);
    if (!fam.check(where, r, box_signed(q, to_real(h)), 6)) continue;
    if (r.status == Status::separated) {
      const V clamped = q.cwiseMax(-to_real(h)).cwiseMin(to_real(h));
      const V expected = pa.rotation.cast<Real>() * clamped + to_real(pa.translation);
      if (!((to_real(r.point_a) - expected).norm() <= 1e-12 * 10))
        fam.log.add("box near point is not the clamp of the point", where);
    }
  }
  fam.expect_mixed(0.15);
  fam.finish();
}

// Box–box with axis-aligned poses: per-axis gaps g = |c_B − c_A| − H_A − H_B (H the world half
// extents); apart: |g⁺|; overlapping: depth −max g. Faces are parallel, so near points are not
// unique: only their distance is checked.
TEST(Analytic, BoxBoxAxisAligned) {
  std::mt19937_64 rng(404);
  Family fam("box-box (axis-aligned)");
  const auto options = near_point_options();
  for (int k = 0; k < kSamples; ++k) {
    const Vec3<double> ha(uniform(rng, 0.2, 2), uniform(rng, 0.2, 2), uniform(rng, 0.2, 2));
    const Vec3<double> hb(uniform(rng, 0.2, 2), uniform(rng, 0.2, 2), uniform(rng, 0.2, 2));
    Pose<double> pa, pb;
    pa.rotation = axis_rotation(rng);
    pb.rotation = axis_rotation(rng);
    pa.translation = Vec3<double>(uniform(rng, -2, 2), uniform(rng, -2, 2), uniform(rng, -2, 2));
    pb.translation = pa.translation +
                     Vec3<double>(uniform(rng, -3, 3), uniform(rng, -3, 3), uniform(rng, -3, 3));
    const auto r = nearpoint::distance(Shape<double>(Box<double>{ha}), pa,
                                       Shape<double>(Box<double>{hb}), pb, options);
    const V world_ha = pa.rotation.cast<Real>().cwiseAbs() * to_real(ha);
    const V world_hb = pb.rotation.cast<Real>().cwiseAbs() * to_real(hb);
    const V gaps =
        (to_real(pb.translation) - to_real(pa.translation)).cwiseAbs() - world_ha - world_hb;
    const Real signed_truth =
        (gaps.array() > 0).any() ? gaps.cwiseMax(Real(0)).norm() : gaps.maxCoeff();
    const std::string where = format("sample %d", k);
    if (!fam.check(where, r, signed_truth, 8)) continue;
    if (r.status == Status::separated &&
        !(std::abs((r.point_b - r.point_a).norm() - r.distance) <= 1e-11))
      fam.log.add("|point_b - point_a| != d", where);
  }
  fam.expect_mixed(0.2);
  fam.finish();
}

// Sphere vs box in general orientation, and a rounded box: d = (dist(c, box) − r_sphere − r_box)⁺.
// Near points lie on the rounded surfaces (the box's at distance r_box from the core box).
TEST(Analytic, SphereVersusRoundedBox) {
  std::mt19937_64 rng(505);
  Family fam("sphere-box (rounded)");
  const auto options = near_point_options();
  for (int k = 0; k < kSamples; ++k) {
    const Vec3<double> h(uniform(rng, 0.2, 2), uniform(rng, 0.2, 2), uniform(rng, 0.2, 2));
    const double box_radius = k % 2 ? uniform(rng, 0.01, 0.5) : 0.0;
    const double sphere_radius = uniform(rng, 0.05, 1);
    const Pose<double> pa = random_pose(rng, 2);
    Pose<double> pb = random_pose(rng, 2);
    pb.translation = pa.translation + Vec3<double>(uniform(rng, -2.2, 2.2), uniform(rng, -2.2, 2.2),
                                                   uniform(rng, -2.2, 2.2));
    const auto r = nearpoint::distance(Shape<double>(Box<double>{h}, box_radius), pa,
                                       Shape<double>::sphere(sphere_radius), pb, options);
    const V c = to_real(pb.translation);
    const Real s = box_signed(to_local(pa, c), to_real(h));
    const std::string where = format("sample %d (box radius %.3g)", k, box_radius);
    if (!fam.check(where, r, s - box_radius - sphere_radius, 8)) continue;
    if (r.status == Status::separated) {
      const double tol = 1e-12 * 10;
      const Real off_a = box_signed(to_local(pa, to_real(r.point_a)), to_real(h)) - box_radius;
      const Real off_b = (to_real(r.point_b) - c).norm() - sphere_radius;
      if (!(std::abs(off_a) <= tol && std::abs(off_b) <= tol))
        fam.log.add("near points off the rounded surfaces",
                    format("%s off by %.3Lg, %.3Lg", where.c_str(), off_a, off_b));
    }
  }
  fam.expect_mixed(0.2);
  fam.finish();
}

// Ellipsoid vs point (a smooth shape: GJK converges geometrically and stops on eq. 35): the
// distance by the Lagrange-multiplier root find; the near point inside the ellipsoid and as close
// to the true nearest point (unique for a point outside) as the distance error allows.
TEST(Analytic, EllipsoidPoint) {
  std::mt19937_64 rng(606);
  Family fam("ellipsoid-point");
  const auto options = near_point_options();
  double max_point_error = 0;
  for (int k = 0; k < kSamples; ++k) {
    const Vec3<double> radii(uniform(rng, 0.3, 2), uniform(rng, 0.3, 2), uniform(rng, 0.3, 2));
    const Pose<double> pa = random_pose(rng, 2);
    Pose<double> pb;
    pb.translation = pa.translation + Vec3<double>(uniform(rng, -1.3, 1.3), uniform(rng, -1.3, 1.3),
                                                   uniform(rng, -1.3, 1.3));
    const auto r = nearpoint::distance(Shape<double>(Ellipsoid<double>{radii}), pa,
                                       Shape<double>(Point{}), pb, options);
    const V q = to_local(pa, to_real(pb.translation));
    V nearest;
    const Real d = ellipsoid_distance(q, to_real(radii), &nearest);
    // Inside: the level Σ(q/a)² − 1 < 0 decides; give it a margin so rounding cannot flip it.
    const Real level = q.cwiseQuotient(to_real(radii)).squaredNorm() - 1;
    const Real signed_truth = d > 0 ? d : (level < -1e-9 ? Real(-1) : Real(0));
    const std::string where = format("sample %d", k);
    if (!fam.check(where, r, signed_truth, 6)) continue;
    if (r.status == Status::separated) {
      const V local = to_local(pa, to_real(r.point_a));
      const double point_error = double((local - nearest).norm());
      max_point_error = std::max(max_point_error, point_error);
      const double floor = 1e-12 * 7;
      if (!(ellipsoid_distance(local, to_real(radii)) <= floor))
        fam.log.add("near point outside the ellipsoid", where);
      if (!(point_error <= stationary_radius(double(d), r.error_bound, floor)))
        fam.log.add("near point far from the true nearest point",
                    format("%s by %.3g", where.c_str(), point_error));
    }
  }
  std::printf("  ellipsoid near point vs true nearest point: max %.3g\n", max_point_error);
  fam.expect_mixed(0.15);
  fam.finish();
}

// Cylinder and cone vs point: closed forms in the meridian half-plane (ρ, z).
TEST(Analytic, CylinderAndConePoint) {
  std::mt19937_64 rng(707);
  Family cyl("cylinder-point"), cone("cone-point");
  const auto options = near_point_options();
  for (int k = 0; k < kSamples; ++k) {
    const double radius = uniform(rng, 0.3, 2), half_height = uniform(rng, 0.3, 2);
    const Pose<double> pa = random_pose(rng, 2);
    Pose<double> pb;
    pb.translation = pa.translation + Vec3<double>(uniform(rng, -1.4, 1.4), uniform(rng, -1.4, 1.4),
                                                   uniform(rng, -1.4, 1.4));
    const V q = to_local(pa, to_real(pb.translation));
    const std::string where = format("sample %d", k);
    const auto rc = nearpoint::distance(Shape<double>(Cylinder<double>{radius, half_height}), pa,
                                        Shape<double>(Point{}), pb, options);
    const Real cyl_truth = cylinder_signed(q, radius, half_height);
    if (cyl.check(where, rc, cyl_truth, 6) && rc.status == Status::separated) {
      const Real off = cylinder_signed(to_local(pa, to_real(rc.point_a)), radius, half_height);
      if (!on_surface(off, double(cyl_truth), rc.error_bound))
        cyl.log.add("near point off the cylinder surface",
                    format("%s by %.3Lg", where.c_str(), off));
    }
    const auto rk = nearpoint::distance(Shape<double>(Cone<double>{radius, half_height}), pa,
                                        Shape<double>(Point{}), pb, options);
    const Real cone_truth = cone_signed(q, radius, half_height);
    if (cone.check(where, rk, cone_truth, 6) && rk.status == Status::separated) {
      const Real off = cone_signed(to_local(pa, to_real(rk.point_a)), radius, half_height);
      if (!on_surface(off, double(cone_truth), rk.error_bound))
        cone.log.add("near point off the cone surface", format("%s by %.3Lg", where.c_str(), off));
    }
  }
  cyl.expect_mixed(0.15);
  cone.expect_mixed(0.1);
  cyl.finish();
  cone.finish();
}

// Rounded polytopes (eq. 5–8): with the exact core distance d₀ from CGAL, the rounded distance is
// (d₀ − r_A − r_B)⁺; separated near points lie on the rounded surfaces (their core point plus r
// along the normal, on the core's supporting plane); when only the rounded shapes overlap the
// penetration depth is exactly r_A + r_B − d₀, which bounds d⁻.
TEST(Analytic, RoundedPolytopes) {
  nearpoint::testkit::PaperExperimentConfig config;
  config.poses_per_case = 10;
  const auto examples = nearpoint::testkit::paper_experiment(config);
  std::mt19937_64 rng(808);
  Family fam("rounded polytopes");
  const auto options = near_point_options();
  for (const auto& e : examples) {
    if (e.kind != nearpoint::testkit::PaperCase::separated) continue;
    const double d0 = e.exact.distance;
    // Radii summing to 0–2·d₀: about half the pairs end up overlapping.
    const double total = uniform(rng, 0, 2) * d0, split = uniform(rng, 0, 1);
    const double ra = total * split, rb = total - ra;
    const auto r =
        nearpoint::distance(Shape<double>(Polytope<double>(*e.vertices_a), ra), e.pose_a,
                            Shape<double>(Polytope<double>(*e.vertices_b), rb), e.pose_b, options);
    const std::string where =
        format("pair %d draw %d r=%.3g+%.3g d0=%.3g", e.pair + 1, e.draw, ra, rb, d0);
    if (!fam.check(where, r, Real(d0) - ra - rb, 15)) continue;
    const double tol = 1e-12 * 16;
    const V n = to_real(r.normal);
    // Core support values along ±n (long double on the posed vertices).
    const Real ha = nearpoint::testkit::support_value<double>(*e.vertices_a, e.pose_a, n);
    const Real hb = nearpoint::testkit::support_value<double>(*e.vertices_b, e.pose_b, V(-n));
    // On the rounded surfaces along the normal: n·p_a = h_A(n) + r_A, −n·p_b = h_B(−n) + r_B,
    // to within the plane-gap bound g/|ν| of the core result.
    const double allowed = tol + r.gap / std::max(d0, 1e-300);
    const Real off_a = n.dot(to_real(r.point_a)) - ha - ra;
    const Real off_b = -n.dot(to_real(r.point_b)) - hb - rb;
    if (!(std::abs(off_a) <= allowed && std::abs(off_b) <= allowed))
      fam.log.add("near points off the rounded surfaces along the normal",
                  format("%s off by %.3Lg, %.3Lg", where.c_str(), off_a, off_b));
    // p − r·n lies in the core.
    const V core_a = to_real(r.point_a) - ra * n, core_b = to_real(r.point_b) + rb * n;
    for (int t = 0; t < 20; ++t) {
      const V u = random_unit_vector(rng).cast<Real>();
      if (u.dot(core_a) >
              nearpoint::testkit::support_value<double>(*e.vertices_a, e.pose_a, u) + tol ||
          u.dot(core_b) >
              nearpoint::testkit::support_value<double>(*e.vertices_b, e.pose_b, u) + tol) {
        fam.log.add("near point minus radius outside the core", where);
        break;
      }
    }
    if (r.status == Status::intersecting) {
      if (!r.has_penetration_bound ||
          !(r.penetration_bound >= 0 && r.penetration_bound <= ra + rb - d0 + tol))
        fam.log.add("penetration bound outside [0, r_A + r_B - d0]",
                    format("%s bound=%.17g", where.c_str(), r.penetration_bound));
    }
  }
  fam.expect_mixed(0.2);
  fam.finish();
}

// Poses: moving both shapes by the same rigid motion leaves the distance unchanged (within the
// two error bounds plus the rounding of composing the poses), for every shape type.
TEST(Analytic, CommonRigidMotionPreservesDistance) {
  std::mt19937_64 rng(909);
  const auto polytopes = nearpoint::testkit::paper_polytopes();
  std::vector<Shape<double>> shapes = {
      Shape<double>::sphere(0.7),
      Shape<double>::capsule(Vec3<double>(-1, 0.2, 0), Vec3<double>(1, -0.3, 0.5), 0.3),
      Shape<double>(Box<double>{Vec3<double>(1.2, 0.5, 0.8)}),
      Shape<double>(Box<double>{Vec3<double>(0.6, 0.9, 0.4)}, 0.2),
      Shape<double>(Cylinder<double>{0.8, 1.1}),
      Shape<double>(Cone<double>{1.0, 0.9}),
      Shape<double>(Ellipsoid<double>{Vec3<double>(1.5, 0.6, 0.9)}),
      Shape<double>(Polytope<double>(*polytopes[3].vertices)),
      Shape<double>(Polytope<double>(*polytopes[8].vertices), 0.1),
  };
  FailureLog log;
  int separated = 0, intersecting = 0, n = 0;
  double max_difference = 0;
  for (int k = 0; k < kSamples; ++k) {
    const Shape<double>& a = shapes[rng() % shapes.size()];
    const Shape<double>& b = shapes[rng() % shapes.size()];
    const Pose<double> pa = random_pose(rng, 2), pb = random_pose(rng, 2);
    Pose<double> motion = random_pose(rng, 50);
    const auto r1 = nearpoint::distance(a, pa, b, pb);
    const auto r2 = nearpoint::distance(a, motion.compose(pa), b, motion.compose(pb));
    ++n;
    const std::string where = format("sample %d", k);
    if (!nearpoint::testkit::all_finite(r1) || !nearpoint::testkit::all_finite(r2))
      log.add("NaN", where);
    // Composing rounds the posed shapes by a few ulps of |translation| ≲ 100.
    const double allowed = r1.error_bound + r2.error_bound + 1e-12 * 100;
    const double difference = std::abs(r1.distance - r2.distance);
    max_difference = std::max(max_difference, difference);
    if (!(difference <= allowed))
      log.add("distance changed under a common motion",
              format("%s %.17g vs %.17g allowed %.3g", where.c_str(), r1.distance, r2.distance,
                     allowed));
    if (r1.distance > 1e-9) {
      ++separated;
      if (r1.status != r2.status) log.add("verdict changed under a common motion", where);
    } else {
      intersecting += r1.status == Status::intersecting;
    }
  }
  std::printf("  common rigid motion: n=%d separated %d intersecting %d max |d1 - d2| %.3g\n", n,
              separated, intersecting, max_difference);
  EXPECT_GE(separated, n / 5);
  EXPECT_GE(intersecting, n / 5);
  EXPECT_EQ(log.total(), 0) << log.report();
}

// ---- a certificate for any pair: support planes below, near points above ----

// A shape of the test with what its truth functions need (a polytope's vertices as given).
struct TestShape {
  const char* name;
  Shape<double> shape;
  const std::vector<Vec3<double>>* vertices = nullptr;
};

// h(u) of the posed core along a world direction, in long double from closed forms written
// independently of the engine (plus nothing for the radius: the caller adds r·|u|).
Real core_support(const TestShape& t, const Pose<double>& pose, const V& u) {
  const V l = pose.rotation.cast<Real>().transpose() * u;
  const Real radial = std::hypot(l.x(), l.y());
  Real h = 0;
  if (std::holds_alternative<Point>(t.shape.geometry)) {
    h = 0;
  } else if (const auto* seg = std::get_if<Segment<double>>(&t.shape.geometry)) {
    h = std::max(l.dot(to_real(seg->a)), l.dot(to_real(seg->b)));
  } else if (const auto* box = std::get_if<Box<double>>(&t.shape.geometry)) {
    h = l.cwiseAbs().dot(to_real(box->half_extents));
  } else if (std::holds_alternative<Polytope<double>>(t.shape.geometry)) {
    h = -INFINITY;
    for (const auto& v : *t.vertices) h = std::max(h, l.dot(to_real(v)));
  } else if (const auto* c = std::get_if<Cylinder<double>>(&t.shape.geometry)) {
    h = Real(c->radius) * radial + Real(c->half_height) * std::abs(l.z());
  } else if (const auto* k = std::get_if<Cone<double>>(&t.shape.geometry)) {
    h = std::max(Real(k->half_height) * l.z(),
                 -Real(k->half_height) * l.z() + Real(k->radius) * radial);
  } else if (const auto* e = std::get_if<Ellipsoid<double>>(&t.shape.geometry)) {
    h = to_real(e->radii).cwiseProduct(l).norm();
  }
  return h + u.dot(to_real(pose.translation));
}

// Distance from a world point to the posed core (0 inside), closed forms; for a polytope the
// exact CGAL distance from the point to the hull.
Real core_distance(const TestShape& t, const Pose<double>& pose, const Vec3<double>& p) {
  const V q = to_local(pose, to_real(p));
  if (std::holds_alternative<Point>(t.shape.geometry)) return q.norm();
  if (const auto* seg = std::get_if<Segment<double>>(&t.shape.geometry))
    return point_segment(q, to_real(seg->a), to_real(seg->b));
  if (const auto* box = std::get_if<Box<double>>(&t.shape.geometry))
    return std::max(box_signed(q, to_real(box->half_extents)), Real(0));
  if (std::holds_alternative<Polytope<double>>(t.shape.geometry)) {
    const std::vector<Vec3<double>> point = {p};
    return nearpoint::testkit::exact_distance(*t.vertices, pose, point, Pose<double>()).distance;
  }
  if (const auto* c = std::get_if<Cylinder<double>>(&t.shape.geometry))
    return std::max(cylinder_signed(q, c->radius, c->half_height), Real(0));
  if (const auto* k = std::get_if<Cone<double>>(&t.shape.geometry))
    return std::max(cone_signed(q, k->radius, k->half_height), Real(0));
  if (const auto* e = std::get_if<Ellipsoid<double>>(&t.shape.geometry))
    return ellipsoid_distance(q, to_real(e->radii));
  return INFINITY;
}

// Every pair of shape types, curved ones included, without a closed form for the pair: the
// result certifies itself through independent truths. For any unit u the support planes give
// d ≥ L(u) = −h_A(u) − h_B(−u) − r_A − r_B (closed-form support functions, long double), and
// points p_a ∈ A, p_b ∈ B give d ≤ |p_b − p_a|. With u the reported normal and the reported near
// points (checked to lie in their shapes, and |p_b − p_a| = d as result.hpp promises), a distance
// correct to its error bound e must satisfy d ≥ L − e; the upper side holds by the near points.
// An intersecting verdict is certified by its common point lying in both shapes (or, when only
// the rounded shapes overlap, by core points within r_A + r_B of each other). Both subalgorithms.
TEST(Analytic, EveryShapePairCertifiedByPlanesAndPoints) {
  std::mt19937_64 rng(1111);
  const auto polytopes = nearpoint::testkit::paper_polytopes();
  const std::vector<TestShape> shapes = {
      {"sphere", Shape<double>::sphere(0.7)},
      {"capsule",
       Shape<double>::capsule(Vec3<double>(-1, 0.2, 0), Vec3<double>(1, -0.3, 0.5), 0.3)},
      {"box", Shape<double>(Box<double>{Vec3<double>(1.2, 0.5, 0.8)})},
      {"rounded box", Shape<double>(Box<double>{Vec3<double>(0.6, 0.9, 0.4)}, 0.2)},
      {"cylinder", Shape<double>(Cylinder<double>{0.8, 1.1})},
      {"rounded cylinder", Shape<double>(Cylinder<double>{0.5, 0.7}, 0.15)},
      {"cone", Shape<double>(Cone<double>{1.0, 0.9})},
      {"ellipsoid", Shape<double>(Ellipsoid<double>{Vec3<double>(1.5, 0.6, 0.9)})},
      {"hexagonal cone polytope", Shape<double>(Polytope<double>(*polytopes[3].vertices)),
       polytopes[3].vertices.get()},
      {"rounded irregular polytope", Shape<double>(Polytope<double>(*polytopes[8].vertices), 0.1),
       polytopes[8].vertices.get()},
  };
  FailureLog log;
  // Both subalgorithms, each held to the same certificate.
  const std::array<nearpoint::Subalgorithm, 2> variants = {nearpoint::Subalgorithm::johnson,
                                                           nearpoint::Subalgorithm::signed_volumes};
  const std::array<const char*, 2> variant_names = {"johnson", "signed volumes"};
  std::array<int, 2> separated{}, intersecting{};
  std::array<double, 2> max_width{}, max_below{};
  for (int k = 0; k < 2000; ++k) {
    const TestShape& a = shapes[rng() % shapes.size()];
    const TestShape& b = shapes[rng() % shapes.size()];
    const Pose<double> pa = random_pose(rng, 1.6), pb = random_pose(rng, 1.6);
    for (std::size_t v = 0; v < variants.size(); ++v) {
      auto options = near_point_options();
      options.subalgorithm = variants[v];
      const auto r = nearpoint::distance(a.shape, pa, b.shape, pb, options);
      const std::string where =
          format("%s, sample %d: %s vs %s", variant_names[v], k, a.name, b.name);
      if (!nearpoint::testkit::all_finite(r)) log.add("NaN or infinity", where);
      if (r.status != Status::separated && r.status != Status::intersecting) {
        log.add("status", where + " " + nearpoint::to_string(r.status));
        continue;
      }
      // Rounding of the engine's points and of the truths at coordinates ≲ 5: 1e-12·(1 + 5).
      const double tol = 6e-12;
      const double ra = a.shape.radius, rb = b.shape.radius;
      if (r.status == Status::separated) {
        ++separated[v];
        const V n = to_real(r.normal);
        const Real lower = -core_support(a, pa, n) - core_support(b, pb, V(-n)) - ra - rb;
        const Real upper = to_real(r.point_b - r.point_a).norm();
        const Real in_a = core_distance(a, pa, r.point_a) - ra,
                   in_b = core_distance(b, pb, r.point_b) - rb;
        if (!(in_a <= tol && in_b <= tol))
          log.add("near point outside its shape",
                  format("%s by %.3Lg, %.3Lg", where.c_str(), in_a, in_b));
        max_width[v] = std::max(max_width[v], double(upper - lower));
        max_below[v] = std::max(max_below[v], double(lower - r.distance));
        if (!(r.distance >= lower - r.error_bound - tol))
          log.add(
              "distance below a support-plane lower bound by more than its error bound",
              format("%s d=%.17g lower=%.17Lg bound=%.3g (%s, %s)", where.c_str(), r.distance,
                     lower, r.error_bound, nearpoint::to_string(r.termination),
                     r.finished_by == nearpoint::FinishedBy::backup_procedure ? "backup"
                                                                              : "subalgorithm"));
        if (!(std::abs(upper - r.distance) <= tol))
          log.add("|point_b - point_a| != distance",
                  format("%s d=%.17g |pb-pa|=%.17Lg", where.c_str(), r.distance, upper));
      } else {
        ++intersecting[v];
        const bool common = r.normal.squaredNorm() == 0;  // cores intersect: one common point
        if (common) {
          const Real in_a = core_distance(a, pa, r.point_a) - ra,
                     in_b = core_distance(b, pb, r.point_a) - rb;
          if (!(in_a <= tol && in_b <= tol))
            log.add("intersecting: common point not in both shapes",
                    format("%s by %.3Lg, %.3Lg", where.c_str(), in_a, in_b));
        } else {
          const Vec3<double> ca = r.point_a - ra * r.normal, cb = r.point_b + rb * r.normal;
          const Real in_a = core_distance(a, pa, ca), in_b = core_distance(b, pb, cb);
          const Real apart = to_real(cb - ca).norm();
          if (!(in_a <= tol && in_b <= tol && apart <= ra + rb + tol))
            log.add("intersecting (rounded): core points do not certify the overlap",
                    format("%s cores %.3Lg, %.3Lg; apart %.17Lg vs radii %.17g", where.c_str(),
                           in_a, in_b, apart, ra + rb));
        }
      }
    }
  }
  for (std::size_t v = 0; v < variants.size(); ++v) {
    std::printf(
        "  every pair, %-14s n=2000 separated %d intersecting %d; separated: "
        "max(|pb-pa| - L) %.3g, max(L - d) %.3g\n",
        variant_names[v], separated[v], intersecting[v], max_width[v], max_below[v]);
    EXPECT_GE(separated[v], 400);
    EXPECT_GE(intersecting[v], 400);
  }
  EXPECT_EQ(log.total(), 0) << log.report();
}

}  // namespace
