// SPDX-License-Identifier: Apache-2.0
#include "common/exact_bracket.hpp"

#include <CGAL/Gmpzf.h>
#include <CGAL/Homogeneous.h>
#include <CGAL/Polytope_distance_d.h>
#include <CGAL/Polytope_distance_d_traits_3.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <type_traits>
#include <variant>

namespace nearpoint::testkit {
namespace {

using Exact = CGAL::Gmpzf;  // arbitrary-precision binary float: +, −, × exact
using E3 = std::array<Exact, 3>;
using Kernel = CGAL::Homogeneous<Exact>;
using Traits = CGAL::Polytope_distance_d_traits_3<Kernel, Exact, Exact>;
using PolytopeDistance = CGAL::Polytope_distance_d<Traits>;

Exact sum(const ExactSum& s) {
  Exact out(0);
  for (int i = 0; i < s.count; ++i) out = out + Exact(s.terms[i]);
  return out;
}

Exact dot(const E3& a, const E3& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

E3 exact3(const double v[3]) {
  return {Exact(v[0]), Exact(v[1]), Exact(v[2])};
}

bool usable_direction(const double u[3]) {
  return std::isfinite(u[0]) && std::isfinite(u[1]) && std::isfinite(u[2]) &&
         (u[0] != 0 || u[1] != 0 || u[2] != 0);
}

// x / |u| ≤ t, decided exactly for any signs (|u| > 0).
bool ratio_at_most(const Exact& x, const Exact& t, const Exact& u2) {
  const bool x_pos = CGAL::sign(x) == CGAL::POSITIVE;
  const bool t_neg = CGAL::sign(t) == CGAL::NEGATIVE;
  if (!x_pos && !t_neg) return true;      // x/|u| ≤ 0 ≤ t
  if (x_pos && t_neg) return false;       // x/|u| > 0 > t
  if (x_pos) return x * x <= t * t * u2;  // both ≥ 0
  return x * x >= t * t * u2;             // both < 0: |x|/|u| ≥ |t|
}

// √q ≥ t for q = num/den ≥ 0 (den > 0).
bool root_at_least(const Exact& num, const Exact& den, const Exact& t) {
  if (CGAL::sign(t) != CGAL::POSITIVE) return true;
  return num >= t * t * den;
}
// √q ≤ t.
bool root_at_most(const Exact& num, const Exact& den, const Exact& t) {
  if (CGAL::sign(t) == CGAL::NEGATIVE) return false;
  return num <= t * t * den;
}

// num/den as a long double (exponents kept apart: the squares of far coordinates overflow double).
long double approx_ratio(const Exact& num, const Exact& den) {
  const std::pair<double, long> n = num.to_double_exp(), d = den.to_double_exp();
  if (d.first == 0) return std::numeric_limits<long double>::infinity();
  return std::ldexp((long double)n.first / d.first, int(n.second - d.second));
}

template <class S>
bool is_identity(const Pose<S>& p) {
  return p.rotation == Mat3<S>::Identity() && p.translation == Vec3<S>::Zero();
}

}  // namespace

struct ExactBracket::Impl {
  struct Piece {
    std::vector<E3> world;  // exact world vertices
    E3 vertex_sum;          // Σ W (the vertex mean times n)
    Exact radius;
  };
  std::vector<Piece> side[2];

  template <class S>
  void add(const std::vector<BracketPiece<S>>& pieces, const Pose<S>& pose, int s) {
    Exact rb[3][3], tb[3];
    for (int i = 0; i < 3; ++i) {
      tb[i] = Exact(double(pose.translation[i]));
      for (int j = 0; j < 3; ++j) rb[i][j] = Exact(double(pose.rotation(i, j)));
    }
    for (const BracketPiece<S>& bp : pieces) {
      Piece& piece = side[s].emplace_back();
      piece.radius = Exact(double(bp.radius));
      const bool plain = is_identity(bp.offset);
      Exact ro[3][3], to[3];
      if (!plain)
        for (int i = 0; i < 3; ++i) {
          to[i] = Exact(double(bp.offset.translation[i]));
          for (int j = 0; j < 3; ++j) ro[i][j] = Exact(double(bp.offset.rotation(i, j)));
        }
      piece.vertex_sum = {Exact(0), Exact(0), Exact(0)};
      for (const Vec3<S>& v : bp.vertices) {
        E3 x = {Exact(double(v[0])), Exact(double(v[1])), Exact(double(v[2]))};
        if (!plain) {  // the offset first: the piece's frame in the body's
          E3 y;
          for (int i = 0; i < 3; ++i)
            y[std::size_t(i)] = ro[i][0] * x[0] + ro[i][1] * x[1] + ro[i][2] * x[2] + to[i];
          x = y;
        }
        E3 w;
        for (int i = 0; i < 3; ++i)
          w[std::size_t(i)] = rb[i][0] * x[0] + rb[i][1] * x[1] + rb[i][2] * x[2] + tb[i];
        for (std::size_t i = 0; i < 3; ++i) piece.vertex_sum[i] = piece.vertex_sum[i] + w[i];
        piece.world.push_back(w);
      }
    }
  }

  // max (s = 0) or min (s = 1) of u·W over a piece.
  static Exact extreme(const Piece& p, const E3& u, bool want_max) {
    Exact best = dot(u, p.world[0]);
    for (std::size_t k = 1; k < p.world.size(); ++k) {
      Exact x = dot(u, p.world[k]);
      if (want_max ? best < x : x < best) best = x;
    }
    return best;
  }
};

template <class S>
ExactBracket::ExactBracket(const std::vector<BracketPiece<S>>& a, const Pose<S>& pose_a,
                           const std::vector<BracketPiece<S>>& b, const Pose<S>& pose_b)
    : impl_(std::make_unique<Impl>()) {
  impl_->add(a, pose_a, 0);
  impl_->add(b, pose_b, 1);
}

ExactBracket::~ExactBracket() = default;

int ExactBracket::pieces(int side) const {
  return int(impl_->side[side].size());
}
int ExactBracket::vertices(int side, int piece) const {
  return int(impl_->side[side][std::size_t(piece)].world.size());
}

bool ExactBracket::lower_at_most(const double u_in[3], const ExactSum& threshold,
                                 double* approx) const {
  if (approx) *approx = 0;
  if (!usable_direction(u_in)) return true;
  const E3 u = exact3(u_in);
  const Exact u2 = dot(u, u);
  const Exact t = sum(threshold);
  std::vector<Exact> max_a, min_b;
  for (const Impl::Piece& p : impl_->side[0]) max_a.push_back(Impl::extreme(p, u, true));
  for (const Impl::Piece& p : impl_->side[1]) min_b.push_back(Impl::extreme(p, u, false));
  const long double norm_u =
      std::sqrt((long double)u_in[0] * u_in[0] + (long double)u_in[1] * u_in[1] +
                (long double)u_in[2] * u_in[2]);
  long double lowest = std::numeric_limits<long double>::infinity();
  bool at_most = CGAL::sign(t) != CGAL::NEGATIVE;  // the bound is ≥ 0 (clamped)
  bool some_pair_at_most = false;
  for (std::size_t i = 0; i < max_a.size(); ++i)
    for (std::size_t j = 0; j < min_b.size(); ++j) {
      const Exact gap = min_b[j] - max_a[i];
      const Exact radii = impl_->side[0][i].radius + impl_->side[1][j].radius;
      if (ratio_at_most(gap, t + radii, u2)) some_pair_at_most = true;
      if (approx)
        lowest = std::min(lowest, (long double)CGAL::to_double(gap) / norm_u -
                                      (long double)CGAL::to_double(radii));
    }
  if (approx) *approx = double(std::max(lowest, 0.0L));
  return at_most && some_pair_at_most;
}

ExactBracket::Upper ExactBracket::upper_at_least(int piece_a, int piece_b, int count,
                                                 const std::int32_t* index_a,
                                                 const std::int32_t* index_b, const double* weights,
                                                 const ExactSum& threshold, double* approx) const {
  if (approx) *approx = 0;
  if (piece_a < 0 || piece_a >= pieces(0) || piece_b < 0 || piece_b >= pieces(1))
    return Upper::unusable;
  const Impl::Piece& pa = impl_->side[0][std::size_t(piece_a)];
  const Impl::Piece& pb = impl_->side[1][std::size_t(piece_b)];
  if (count < 1 || count > 4) return Upper::unusable;
  double lambda_sum = 0;
  for (int k = 0; k < count; ++k) {
    if (!(std::isfinite(weights[k]) && weights[k] >= 0)) return Upper::unusable;
    lambda_sum += weights[k];
    const int na = int(pa.world.size()), nb = int(pb.world.size());
    if (index_a[k] < -1 || index_a[k] >= na || index_b[k] < -1 || index_b[k] >= nb)
      return Upper::out_of_range;
  }
  if (!(lambda_sum > 0)) return Upper::unusable;
  const Exact t = sum(threshold);
  // p = P' / (n_a Λ), q = Q' / (n_b Λ) with P' = Σλ·(n_a·W or ΣW): q − p = (n_a Q' − n_b P') /
  // (n_a n_b Λ), no division needed.
  const Exact na(int(pa.world.size())), nb(int(pb.world.size()));
  E3 p = {Exact(0), Exact(0), Exact(0)}, q = p;
  Exact lambda(0);
  for (int k = 0; k < count; ++k) {
    const Exact l(weights[k]);
    lambda = lambda + l;
    for (std::size_t i = 0; i < 3; ++i) {
      const Exact xa =
          index_a[k] < 0 ? pa.vertex_sum[i] : na * pa.world[std::size_t(index_a[k])][i];
      const Exact xb =
          index_b[k] < 0 ? pb.vertex_sum[i] : nb * pb.world[std::size_t(index_b[k])][i];
      p[i] = p[i] + l * xa;
      q[i] = q[i] + l * xb;
    }
  }
  E3 d;
  for (std::size_t i = 0; i < 3; ++i) d[i] = na * q[i] - nb * p[i];
  const Exact den = na * nb * lambda;
  const Exact num2 = dot(d, d), den2 = den * den;
  const Exact radii = pa.radius + pb.radius;
  if (approx) {
    const long double ratio = approx_ratio(num2, den2);
    *approx = double(std::max(0.0L, std::sqrt(ratio) - (long double)CGAL::to_double(radii)));
  }
  // (|q − p| − r)⁺ ≥ t: always when t ≤ 0 (the clamp), else |q − p| ≥ t + r.
  if (CGAL::sign(t) != CGAL::POSITIVE) return Upper::holds;
  return root_at_least(num2, den2, t + radii) ? Upper::holds : Upper::fails;
}

bool ExactBracket::within_along(int side, int piece, const double point[3], const double u_in[3],
                                const ExactSum& slack) const {
  if (!usable_direction(u_in)) return true;
  const Impl::Piece& p = impl_->side[side][std::size_t(piece)];
  const E3 u = exact3(u_in);
  const Exact excess = dot(u, exact3(point)) - Impl::extreme(p, u, true);
  return ratio_at_most(excess, p.radius + sum(slack), dot(u, u));
}

namespace {

// One piece pair's exact distance (√q − r)⁺ against lo and hi, by CGAL's QP.
struct PairTruth {
  bool at_least_lo, at_most_hi;
  long double approx;
};

template <class Piece>
PairTruth pair_truth(const Piece& pa, const Piece& pb, const Exact& lo, const Exact& hi) {
  std::vector<Kernel::Point_3> a, b;
  for (const E3& w : pa.world) a.emplace_back(w[0], w[1], w[2], Exact(1));
  for (const E3& w : pb.world) b.emplace_back(w[0], w[1], w[2], Exact(1));
  const PolytopeDistance solver(a.begin(), a.end(), b.begin(), b.end());
  Exact num = solver.squared_distance_numerator();
  Exact den = solver.squared_distance_denominator();
  if (CGAL::sign(den) == CGAL::NEGATIVE) {
    num = -num;
    den = -den;
  }
  const Exact radii = pa.radius + pb.radius;
  PairTruth out;
  // (√q − r)⁺ ≥ lo (always when lo ≤ 0); ≤ hi.
  out.at_least_lo = CGAL::sign(lo) != CGAL::POSITIVE || root_at_least(num, den, lo + radii);
  out.at_most_hi = CGAL::sign(hi) != CGAL::NEGATIVE && root_at_most(num, den, hi + radii);
  out.approx =
      std::max(0.0L, std::sqrt(approx_ratio(num, den)) - (long double)CGAL::to_double(radii));
  return out;
}

}  // namespace

ExactBracket::Truth ExactBracket::truth(const ExactSum& lo_sum, const ExactSum& hi_sum) const {
  Truth out;
  const Exact lo = sum(lo_sum), hi = sum(hi_sum);
  out.at_most_hi = false;
  long double best = std::numeric_limits<long double>::infinity();
  for (const Impl::Piece& pa : impl_->side[0])
    for (const Impl::Piece& pb : impl_->side[1]) {
      const PairTruth t = pair_truth(pa, pb, lo, hi);
      ++out.qp_pairs;
      out.at_least_lo = out.at_least_lo && t.at_least_lo;
      out.at_most_hi = out.at_most_hi || t.at_most_hi;
      best = std::min(best, t.approx);
    }
  out.approx = double(best);
  return out;
}

ExactBracket::Truth ExactBracket::truth_where_needed(
    const ExactSum& lo_sum, const ExactSum& hi_sum,
    const std::vector<std::array<double, 3>>& directions, bool hi_known, int prefer_a,
    int prefer_b) const {
  Truth out;
  const Exact lo = sum(lo_sum), hi = sum(hi_sum);
  out.at_most_hi = hi_known;
  long double best = std::numeric_limits<long double>::infinity();
  const int na = pieces(0), nb = pieces(1);
  // Piece pairs in the order the QP should try them for hi: the preferred pair first.
  std::vector<std::pair<int, int>> order;
  if (prefer_a >= 0 && prefer_a < na && prefer_b >= 0 && prefer_b < nb)
    order.emplace_back(prefer_a, prefer_b);
  for (int i = 0; i < na; ++i)
    for (int j = 0; j < nb; ++j)
      if (i != prefer_a || j != prefer_b) order.emplace_back(i, j);
  std::vector<char> qp_done(order.size(), 0);

  // The lower half, pair by pair: L_ij(u) > lo along some direction proves d(A_i, B_j) − r ≥ lo.
  for (std::size_t k = 0; k < order.size(); ++k) {
    const Impl::Piece& pa = impl_->side[0][std::size_t(order[k].first)];
    const Impl::Piece& pb = impl_->side[1][std::size_t(order[k].second)];
    const auto above_lo = [&](const std::array<double, 3>& ud) {
      if (!usable_direction(ud.data())) return false;
      const E3 u = exact3(ud.data());
      const Exact gap = Impl::extreme(pb, u, false) - Impl::extreme(pa, u, true);
      return !ratio_at_most(gap, lo + pa.radius + pb.radius, dot(u, u));
    };
    // The caller's directions, then the vertex means' difference, rounded (any direction gives
    // a valid bound).
    const Exact ca(int(pa.world.size())), cb(int(pb.world.size()));
    std::array<double, 3> means{};
    for (std::size_t c = 0; c < 3; ++c)
      means[c] = double(approx_ratio(ca * pb.vertex_sum[c] - cb * pa.vertex_sum[c], ca * cb));
    if (CGAL::sign(lo) != CGAL::POSITIVE ||
        std::any_of(directions.begin(), directions.end(), above_lo) || above_lo(means))
      continue;
    const PairTruth t = pair_truth(pa, pb, lo, hi);
    qp_done[k] = 1;
    ++out.qp_pairs;
    out.at_least_lo = out.at_least_lo && t.at_least_lo;
    out.at_most_hi = out.at_most_hi || t.at_most_hi;
    best = std::min(best, t.approx);
  }
  // The upper half: some pair at most hi.
  for (std::size_t k = 0; k < order.size() && !out.at_most_hi; ++k) {
    if (qp_done[k]) continue;
    const PairTruth t = pair_truth(impl_->side[0][std::size_t(order[k].first)],
                                   impl_->side[1][std::size_t(order[k].second)], lo, hi);
    ++out.qp_pairs;
    out.at_most_hi = t.at_most_hi;
    best = std::min(best, t.approx);
  }
  out.approx = out.qp_pairs > 0 ? double(best) : 0.0;
  return out;
}

bool ExactBracket::closest_on_simplex(int piece_a, int piece_b, int count,
                                      const std::int32_t* index_a, const std::int32_t* index_b,
                                      double weights[4], double direction[3]) const {
  if (piece_a < 0 || piece_a >= pieces(0) || piece_b < 0 || piece_b >= pieces(1)) return false;
  if (count < 1 || count > 4) return false;
  const Impl::Piece& pa = impl_->side[0][std::size_t(piece_a)];
  const Impl::Piece& pb = impl_->side[1][std::size_t(piece_b)];
  const int size_a = int(pa.world.size()), size_b = int(pb.world.size());
  using LD = long double;
  std::array<std::array<LD, 3>, 4> d{};
  for (int k = 0; k < count; ++k) {
    if (index_a[k] < -1 || index_a[k] >= size_a || index_b[k] < -1 || index_b[k] >= size_b)
      return false;
    // q − p exactly as (n_p·x_q − n_q·x_p) / (n_p·n_q), n = 1 for a vertex, the count for a mean.
    const Exact np(index_a[k] < 0 ? size_a : 1), nq(index_b[k] < 0 ? size_b : 1);
    for (std::size_t c = 0; c < 3; ++c) {
      const Exact xp = index_a[k] < 0 ? pa.vertex_sum[c] : pa.world[std::size_t(index_a[k])][c];
      const Exact xq = index_b[k] < 0 ? pb.vertex_sum[c] : pb.world[std::size_t(index_b[k])][c];
      d[std::size_t(k)][c] = approx_ratio(np * xq - nq * xp, np * nq);
    }
  }
  const auto dot3 = [](const std::array<LD, 3>& x, const std::array<LD, 3>& y) {
    return x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
  };
  // Every subset: the origin's projection on its affine hull (normal equations, Gaussian
  // elimination with partial pivoting), kept when its weights are ≥ 0 after clamping round-off.
  LD best_norm2 = std::numeric_limits<LD>::infinity();
  std::array<LD, 4> best{};
  std::array<LD, 3> best_point{};
  for (int mask = 1; mask < (1 << count); ++mask) {
    int members[4], m = 0;
    for (int k = 0; k < count; ++k)
      if (mask & (1 << k)) members[m++] = k;
    std::array<LD, 4> lambda{};
    if (m == 1) {
      lambda[std::size_t(members[0])] = 1;
    } else {
      // minimise |P0 + Σ μ_i E_i|²: G μ = −E·P0 with G_ij = E_i·E_j.
      const std::array<LD, 3>& p0 = d[std::size_t(members[0])];
      std::array<std::array<LD, 3>, 3> e{};
      for (int i = 1; i < m; ++i)
        for (std::size_t c = 0; c < 3; ++c)
          e[std::size_t(i - 1)][c] = d[std::size_t(members[i])][c] - p0[c];
      const int n = m - 1;
      LD g[3][4];
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) g[i][j] = dot3(e[std::size_t(i)], e[std::size_t(j)]);
        g[i][n] = -dot3(e[std::size_t(i)], p0);
      }
      bool singular = false;
      for (int col = 0; col < n; ++col) {
        int pivot = col;
        for (int row = col + 1; row < n; ++row)
          if (std::abs(g[row][col]) > std::abs(g[pivot][col])) pivot = row;
        if (!(std::abs(g[pivot][col]) > 0)) {
          singular = true;
          break;
        }
        for (int j = 0; j <= n; ++j) std::swap(g[col][j], g[pivot][j]);
        for (int row = 0; row < n; ++row) {
          if (row == col) continue;
          const LD f = g[row][col] / g[col][col];
          for (int j = col; j <= n; ++j) g[row][j] -= f * g[col][j];
        }
      }
      if (singular) continue;
      LD mu_sum = 0;
      for (int i = 0; i < n; ++i) {
        const LD mu = g[i][n] / g[i][i];
        if (!std::isfinite(mu)) singular = true;
        lambda[std::size_t(members[i + 1])] = mu;
        mu_sum += mu;
      }
      if (singular) continue;
      lambda[std::size_t(members[0])] = 1 - mu_sum;
      // Clearly outside the subset's hull: another subset holds the closest point.
      bool inside = true;
      for (int i = 0; i < m; ++i)
        if (lambda[std::size_t(members[i])] < -1e-9L) inside = false;
      if (!inside) continue;
      LD total = 0;
      for (LD& l : lambda) total += (l = std::max(l, LD(0)));
      if (!(total > 0)) continue;
      for (LD& l : lambda) l /= total;
    }
    std::array<LD, 3> x{};
    for (int k = 0; k < count; ++k)
      for (std::size_t c = 0; c < 3; ++c) x[c] += lambda[std::size_t(k)] * d[std::size_t(k)][c];
    const LD norm2 = dot3(x, x);
    if (norm2 < best_norm2) {
      best_norm2 = norm2;
      best = lambda;
      best_point = x;
    }
  }
  if (!(best_norm2 > 0) || !std::isfinite(best_norm2)) return false;
  for (int k = 0; k < 4; ++k) weights[k] = k < count ? double(best[std::size_t(k)]) : 0.0;
  for (std::size_t c = 0; c < 3; ++c) direction[c] = double(best_point[c]);
  return usable_direction(direction);
}

template <class S>
bool core_vertices(const Shape<S>& shape, std::vector<Vec3<S>>& out) {
  out.clear();
  return std::visit(
      [&](const auto& g) {
        using G = std::decay_t<decltype(g)>;
        if constexpr (std::is_same_v<G, Point>) {
          out.push_back(Vec3<S>::Zero());
        } else if constexpr (std::is_same_v<G, Segment<S>>) {
          out.push_back(g.a);
          out.push_back(g.b);
        } else if constexpr (std::is_same_v<G, Box<S>>) {
          for (int c = 0; c < 8; ++c)
            out.push_back(Vec3<S>((c & 1) ? g.half_extents.x() : -g.half_extents.x(),
                                  (c & 2) ? g.half_extents.y() : -g.half_extents.y(),
                                  (c & 4) ? g.half_extents.z() : -g.half_extents.z()));
        } else if constexpr (std::is_same_v<G, Polytope<S>>) {
          for (std::size_t i = 0; i < g.size(); ++i) out.push_back(g.vertex(i));
        } else {
          return false;
        }
        return true;
      },
      shape.geometry);
}

template ExactBracket::ExactBracket(const std::vector<BracketPiece<float>>&, const Pose<float>&,
                                    const std::vector<BracketPiece<float>>&, const Pose<float>&);
template ExactBracket::ExactBracket(const std::vector<BracketPiece<double>>&, const Pose<double>&,
                                    const std::vector<BracketPiece<double>>&, const Pose<double>&);
template bool core_vertices<float>(const Shape<float>&, std::vector<Vec3<float>>&);
template bool core_vertices<double>(const Shape<double>&, std::vector<Vec3<double>>&);

}  // namespace nearpoint::testkit
