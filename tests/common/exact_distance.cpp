// SPDX-License-Identifier: Apache-2.0
#include "common/exact_distance.hpp"

#include <CGAL/Gmpzf.h>
#include <CGAL/Homogeneous.h>
#include <CGAL/Polytope_distance_d.h>
#include <CGAL/Polytope_distance_d_traits_3.h>
#include <mpfr.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <optional>
#include <utility>

namespace nearpoint::testkit {
namespace {

// Homogeneous coordinates over Gmpzf (exact +, −, ×; no division is ever needed because every
// point gets the homogeneous weight 1). CGAL's documentation recommends this kernel for
// Polytope_distance_d on double input. NT = ET = Gmpzf: the QP solver runs fully exactly.
using ExactNumber = CGAL::Gmpzf;
using Kernel = CGAL::Homogeneous<ExactNumber>;
using ExactPoint = Kernel::Point_3;
using Traits = CGAL::Polytope_distance_d_traits_3<Kernel, ExactNumber, ExactNumber>;
using PolytopeDistance = CGAL::Polytope_distance_d<Traits>;

constexpr mpfr_prec_t kPrecision = 256;

// x = mantissa · 2^exponent into 256-bit MPFR (exact unless the mantissa exceeds 256 bits).
void to_mpfr(const ExactNumber& x, mpfr_t out) {
  mpfr_set_z(out, x.man(), MPFR_RNDN);
  mpfr_mul_2si(out, out, x.exp(), MPFR_RNDN);
}

// numerator / denominator (or its square root) rounded to the nearest double via 256-bit MPFR.
double ratio_to_double(const ExactNumber& numerator, const ExactNumber& denominator,
                       bool square_root = false) {
  mpfr_t n, d;
  mpfr_init2(n, kPrecision);
  mpfr_init2(d, kPrecision);
  to_mpfr(numerator, n);
  to_mpfr(denominator, d);
  mpfr_div(n, n, d, MPFR_RNDN);
  if (square_root) mpfr_sqrt(n, n, MPFR_RNDN);
  const double out = mpfr_get_d(n, MPFR_RNDN);
  mpfr_clear(n);
  mpfr_clear(d);
  return out;
}

// A posed vertex list: world coordinates in double for screening, exact ones on demand (most
// vertices are screened out in double and never need their exact coordinates).
template <class Scalar>
class PosedVertices {
 public:
  PosedVertices(std::span<const Vec3<Scalar>> local, const Pose<Scalar>& pose)
      : local_(local), exact_(local.size()), approx_(local.size()) {
    for (int i = 0; i < 3; ++i) {
      t_[i] = ExactNumber(double(pose.translation[i]));
      for (int j = 0; j < 3; ++j) r_[i][j] = ExactNumber(double(pose.rotation(i, j)));
    }
    const Mat3<long double> r = pose.rotation.template cast<long double>();
    const Vec3<long double> t = pose.translation.template cast<long double>();
    for (std::size_t k = 0; k < local.size(); ++k) {
      approx_[k] = (r * local[k].template cast<long double>() + t).template cast<double>();
      scale_ = std::max(scale_, approx_[k].template lpNorm<Eigen::Infinity>());
    }
  }

  int size() const { return int(local_.size()); }
  /// World coordinates rounded to double (off by about one unit in the last place).
  const Vec3<double>& approx(int k) const { return approx_[std::size_t(k)]; }
  /// The largest |coordinate| of any vertex.
  double scale() const { return scale_; }

  /// R·v + t evaluated exactly (float and double convert to Gmpzf exactly; +, × are exact).
  const std::array<ExactNumber, 3>& exact(int k) {
    std::optional<std::array<ExactNumber, 3>>& slot = exact_[std::size_t(k)];
    if (!slot) {
      const Vec3<Scalar>& v = local_[std::size_t(k)];
      const ExactNumber x[3] = {ExactNumber(double(v[0])), ExactNumber(double(v[1])),
                                ExactNumber(double(v[2]))};
      std::array<ExactNumber, 3> w;
      for (int i = 0; i < 3; ++i)
        w[std::size_t(i)] = r_[i][0] * x[0] + r_[i][1] * x[1] + r_[i][2] * x[2] + t_[i];
      slot = w;
    }
    return *slot;
  }

  ExactPoint exact_point(int k) {
    const std::array<ExactNumber, 3>& w = exact(k);
    return ExactPoint(w[0], w[1], w[2], ExactNumber(1));
  }

 private:
  std::span<const Vec3<Scalar>> local_;
  ExactNumber r_[3][3];
  ExactNumber t_[3];
  std::vector<std::optional<std::array<ExactNumber, 3>>> exact_;
  std::vector<Vec3<double>> approx_;
  double scale_ = 0;
};

// A candidate subset of a vertex list, without duplicates.
struct Subset {
  std::vector<int> indices;
  std::vector<char> member;
  explicit Subset(int n) : member(std::size_t(n), 0) {}
  void add(int k) {
    if (k < 0 || k >= int(member.size()) || member[std::size_t(k)]) return;
    member[std::size_t(k)] = 1;
    indices.push_back(k);
  }
};

// The `count` vertices reaching furthest along `direction`.
template <class Scalar>
void add_extremes(const PosedVertices<Scalar>& set, const Vec3<double>& direction, int count,
                  Subset& subset) {
  std::vector<std::pair<double, int>> order;
  order.reserve(std::size_t(set.size()));
  for (int k = 0; k < set.size(); ++k) order.emplace_back(-direction.dot(set.approx(k)), k);
  count = std::min(count, set.size());
  std::partial_sort(order.begin(), order.begin() + count, order.end());
  for (int k = 0; k < count; ++k) subset.add(order[std::size_t(k)].second);
}

template <class Scalar>
Vec3<double> centroid(const PosedVertices<Scalar>& set) {
  Vec3<double> sum = Vec3<double>::Zero();
  for (int k = 0; k < set.size(); ++k) sum += set.approx(k);
  return sum / double(set.size());
}

ExactNumber dot(const std::array<ExactNumber, 3>& a, const ExactNumber* b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

}  // namespace

template <class Scalar>
ExactDistance exact_distance(std::span<const Vec3<Scalar>> local_a, const Pose<Scalar>& pose_a,
                             std::span<const Vec3<Scalar>> local_b, const Pose<Scalar>& pose_b,
                             std::span<const int> hint_a, std::span<const int> hint_b) {
  assert(!local_a.empty() && !local_b.empty());
  PosedVertices<Scalar> a(local_a, pose_a);
  PosedVertices<Scalar> b(local_b, pose_b);
  Subset sub_a(a.size()), sub_b(b.size());
  for (int k : hint_a) sub_a.add(k);
  for (int k : hint_b) sub_b.add(k);
  // Without a hint, start from the vertices facing the other set along the line between the
  // vertex centroids (6 each: enough to hold the realising features most of the time).
  constexpr int kStartCount = 6;
  Vec3<double> between = centroid(b) - centroid(a);
  if (!(between.norm() > 0)) between = Vec3<double>::UnitX();
  if (sub_a.indices.empty()) add_extremes(a, between, kStartCount, sub_a);
  if (sub_b.indices.empty()) add_extremes(b, Vec3<double>(-between), kStartCount, sub_b);

  // Screening margin: a vertex whose double-precision slack w·(x − p)/|w| is below −margin is
  // certainly not violating. The double evaluation errs by a few units in the last place of the
  // coordinates (~1e-15·scale), so 1e-9·scale leaves six orders of magnitude of safety.
  const double margin = 1e-9 * (1.0 + std::max(a.scale(), b.scale()));
  // At most this many violators join each subset per round: enough to add a missing face at
  // once, few enough to keep the subproblem small.
  constexpr std::size_t kAddPerRound = 6;

  ExactDistance out;
  for (;;) {
    ++out.rounds;
    std::vector<ExactPoint> pa, pb;
    pa.reserve(sub_a.indices.size());
    pb.reserve(sub_b.indices.size());
    for (int k : sub_a.indices) pa.push_back(a.exact_point(k));
    for (int k : sub_b.indices) pb.push_back(b.exact_point(k));
    const PolytopeDistance solver(pa.begin(), pa.end(), pb.begin(), pb.end());

    // Realising points in homogeneous form: p_a = P / D, p_b = Q / D (common denominator D).
    const std::vector<ExactNumber> p(solver.realizing_point_p_coordinates_begin(),
                                     solver.realizing_point_p_coordinates_end());
    const std::vector<ExactNumber> q(solver.realizing_point_q_coordinates_begin(),
                                     solver.realizing_point_q_coordinates_end());
    const ExactNumber& denominator = p[3];
    const ExactNumber numerator_d2 = solver.squared_distance_numerator();
    const ExactNumber denominator_d2 = solver.squared_distance_denominator();
    Vec3<double> point_a, point_b;
    for (int i = 0; i < 3; ++i) {
      point_a[i] = ratio_to_double(p[std::size_t(i)], denominator);
      point_b[i] = ratio_to_double(q[std::size_t(i)], denominator);
    }

    auto finish = [&] {
      out.intersecting = CGAL::is_zero(numerator_d2);
      out.squared_distance = ratio_to_double(numerator_d2, denominator_d2);
      out.distance = ratio_to_double(numerator_d2, denominator_d2, /*square_root=*/true);
      out.point_a = point_a;
      out.point_b = point_b;
      for (auto it = solver.support_points_p_indices_begin();
           it != solver.support_points_p_indices_end(); ++it)
        out.support_a.push_back(sub_a.indices[std::size_t(*it)]);
      for (auto it = solver.support_points_q_indices_begin();
           it != solver.support_points_q_indices_end(); ++it)
        out.support_b.push_back(sub_b.indices[std::size_t(*it)]);
      return out;
    };
    // Subsets that intersect prove that the full hulls do.
    if (CGAL::is_zero(numerator_d2)) return finish();

    // w = p_b − p_a = W / D. For a vertex x of A: w·x ≤ w·p_a ⇔ D·(W·x) ≤ W·P (multiply by
    // D² > 0); for a vertex y of B: w·y ≥ w·p_b ⇔ D·(W·y) ≥ W·Q.
    const ExactNumber w[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};
    const ExactNumber w_dot_p = w[0] * p[0] + w[1] * p[1] + w[2] * p[2];
    const ExactNumber w_dot_q = w[0] * q[0] + w[1] * q[1] + w[2] * q[2];
    Vec3<double> direction(CGAL::to_double(w[0]), CGAL::to_double(w[1]), CGAL::to_double(w[2]));
    if (CGAL::sign(denominator) == CGAL::NEGATIVE) direction = -direction;
    direction.normalize();

    std::vector<std::pair<double, int>> violators_a, violators_b;
    for (int k = 0; k < a.size(); ++k) {
      if (sub_a.member[std::size_t(k)]) continue;  // the subproblem's optimum satisfies these
      const double slack = direction.dot(a.approx(k) - point_a);
      if (slack <= -margin) continue;
      if (denominator * dot(a.exact(k), w) > w_dot_p) violators_a.emplace_back(-slack, k);
    }
    for (int k = 0; k < b.size(); ++k) {
      if (sub_b.member[std::size_t(k)]) continue;
      const double slack = direction.dot(point_b - b.approx(k));
      if (slack <= -margin) continue;
      if (denominator * dot(b.exact(k), w) < w_dot_q) violators_b.emplace_back(-slack, k);
    }
    // No violator: the slab between the two support planes separates the full hulls, so the
    // subproblem's distance is the full one.
    if (violators_a.empty() && violators_b.empty()) return finish();
    std::sort(violators_a.begin(), violators_a.end());
    std::sort(violators_b.begin(), violators_b.end());
    for (std::size_t i = 0; i < std::min(kAddPerRound, violators_a.size()); ++i)
      sub_a.add(violators_a[i].second);
    for (std::size_t i = 0; i < std::min(kAddPerRound, violators_b.size()); ++i)
      sub_b.add(violators_b[i].second);
  }
}

template <class Scalar>
long double support_value(std::span<const Vec3<Scalar>> local, const Pose<Scalar>& pose,
                          const Vec3<long double>& direction) {
  const Mat3<long double> r = pose.rotation.template cast<long double>();
  const Vec3<long double> t = pose.translation.template cast<long double>();
  long double best = -INFINITY;
  for (const Vec3<Scalar>& v : local)
    best = std::max(best, direction.dot(r * v.template cast<long double>() + t));
  return best;
}

template ExactDistance exact_distance<double>(std::span<const Vec3<double>>, const Pose<double>&,
                                              std::span<const Vec3<double>>, const Pose<double>&,
                                              std::span<const int>, std::span<const int>);
template ExactDistance exact_distance<float>(std::span<const Vec3<float>>, const Pose<float>&,
                                             std::span<const Vec3<float>>, const Pose<float>&,
                                             std::span<const int>, std::span<const int>);
template long double support_value<double>(std::span<const Vec3<double>>, const Pose<double>&,
                                           const Vec3<long double>&);
template long double support_value<float>(std::span<const Vec3<float>>, const Pose<float>&,
                                          const Vec3<long double>&);

}  // namespace nearpoint::testkit
