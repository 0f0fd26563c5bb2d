// The signed-volumes subalgorithm (Montanari, Petrinic & Barbieri, "Improving the GJK algorithm
// for faster and more reliable distance queries between convex objects", ACM TOG 36(3), 2017).
//
// It answers the same question as Johnson's subalgorithm, ν(co Y) for |Y| ≤ 4, but from signed
// volumes, areas and lengths of the simplex and of its projection onto the best-conditioned
// coordinate plane or axis, instead of the Δ recursion. The Δ's are differences of inner products
// and lose relative precision when the simplex is small or flat compared with its distance from
// the origin; the signed volumes are formed from coordinates and do not.
//
// Unlike the published version, which assumes the newest point belongs to the answer, every face
// that is visible from the origin's projection is examined, so the routine is also correct for the
// arbitrary initial simplices of warm starts.
#pragma once

#include <bit>
#include <cmath>

#include "johnson.hpp"

namespace nearpoint::detail {

/// The axis along which |v| is largest, the first on ties (as Eigen's maxCoeff). Selects rather
/// than branches: which axis wins is data, and a branch on it mispredicted often.
template <class S>
[[gnu::always_inline]] inline int largest_component(const Vec3<S>& v) {
  using std::abs;
  const S x = abs(v.x()), y = abs(v.y()), z = abs(v.z());
  const int xy = int(y > x);
  const S top = y > x ? y : x;
  return xy + int(z > top) * (2 - xy);  // arithmetic: GCC made `z > top ? 2 : xy` a jump
}

/// Result on up to 4 points given by slot numbers into the simplex.
template <class S>
struct SvAnswer {
  unsigned subset = 0;
  S lambda[4] = {0, 0, 0, 0};
  Vec3<S> nu = Vec3<S>::Zero();
  S nu_norm2 = std::numeric_limits<S>::infinity();
};

template <class S>
SvAnswer<S> sv_point(const Simplex<S>& sx, int i) {
  SvAnswer<S> out;
  out.subset = 1u << i;
  out.lambda[i] = 1;
  out.nu = sx.y[i];
  out.nu_norm2 = out.nu.squaredNorm();
  return out;
}

template <class S>
SvAnswer<S> sv_segment(const Simplex<S>& sx, int i, int j) {
  const Vec3<S>& s1 = sx.y[i];
  const Vec3<S>& s2 = sx.y[j];
  const Vec3<S> t = s2 - s1;
  const S tt = t.squaredNorm();
  if (tt > 0) {
    // Project the origin on the line, then measure along the axis where the segment is longest.
    const Vec3<S> p0 = s1 - (s1.dot(t) / tt) * t;
    const int axis = largest_component(t);
    const S mu = s2[axis] - s1[axis];
    const S c1 = s2[axis] - p0[axis];  // weight of s1, times mu
    const S c2 = p0[axis] - s1[axis];  // weight of s2, times mu
    if (same_sign(mu, c1) & same_sign(mu, c2)) {
      // Weights normalised by their own sum, not by μ: computed separately, c₁ + c₂ need not
      // equal μ to the last bit, and Σλ ≠ 1 would scale ν off the segment (and out of K).
      SvAnswer<S> out;
      out.subset = (1u << i) | (1u << j);
      out.lambda[i] = c1 / (c1 + c2);
      out.lambda[j] = c2 / (c1 + c2);
      out.nu = out.lambda[i] * s1 + out.lambda[j] * s2;
      out.nu_norm2 = out.nu.squaredNorm();
      return out;
    }
  }
  const SvAnswer<S> a = sv_point(sx, i), b = sv_point(sx, j);
  return b.nu_norm2 < a.nu_norm2 ? b : a;
}

template <class S>
SvAnswer<S> sv_triangle(const Simplex<S>& sx, int i, int j, int k) {
  const int idx[3] = {i, j, k};
  const Vec3<S>& s1 = sx.y[i];
  const Vec3<S>& s2 = sx.y[j];
  const Vec3<S>& s3 = sx.y[k];
  const Vec3<S> n = (s2 - s1).cross(s3 - s1);
  const S nn = n.squaredNorm();
  if (nn > 0) {
    // The origin's projection on the plane, then signed areas in the coordinate plane on which the
    // triangle's projection is largest (drop the axis along which |n| is largest).
    const Vec3<S> p0 = (s1.dot(n) / nn) * n;
    const int drop = largest_component(n);
    const int u = (drop + 1) % 3, v = (drop + 2) % 3;
    auto area = [&](const Vec3<S>& a, const Vec3<S>& b, const Vec3<S>& c) {
      return (b[u] - a[u]) * (c[v] - a[v]) - (b[v] - a[v]) * (c[u] - a[u]);
    };
    const S mu = area(s1, s2, s3);
    const S c[3] = {area(p0, s2, s3), area(s1, p0, s3), area(s1, s2, p0)};
    if (same_sign(mu, c[0]) & same_sign(mu, c[1]) & same_sign(mu, c[2])) {
      // Normalised by Σc rather than μ (see sv_segment): on a sliver triangle μ and the c's carry
      // large relative errors, and only Σλ = 1 with λ > 0 keeps ν inside the triangle.
      SvAnswer<S> out;
      out.subset = (1u << i) | (1u << j) | (1u << k);
      out.nu.setZero();
      const S sum = c[0] + c[1] + c[2];
      for (int m = 0; m < 3; ++m) {
        out.lambda[idx[m]] = c[m] / sum;
        out.nu += out.lambda[idx[m]] * sx.y[idx[m]];
      }
      out.nu_norm2 = out.nu.squaredNorm();
      return out;
    }
    // Outside: the answer is on an edge seen from p0 (opposite a vertex whose area changed sign).
    const unsigned kept = unsigned(same_sign(mu, c[0])) | unsigned(same_sign(mu, c[1])) << 1 |
                          unsigned(same_sign(mu, c[2])) << 2;
    const unsigned seen = ~kept & 7u;
    if (std::has_single_bit(seen)) {  // one edge faces p0 (the common case): no comparisons
      const int m = std::countr_zero(seen);
      return sv_segment(sx, idx[(m + 1) % 3], idx[(m + 2) % 3]);
    }
    SvAnswer<S> best;
    for (int m = 0; m < 3; ++m) {
      if ((kept >> m) & 1u) continue;
      const SvAnswer<S> e = sv_segment(sx, idx[(m + 1) % 3], idx[(m + 2) % 3]);
      if (e.nu_norm2 < best.nu_norm2) best = e;
    }
    if (best.subset) return best;
  }
  // Degenerate (collinear) triangle: the nearest of its three edges.
  SvAnswer<S> best = sv_segment(sx, i, j);
  for (const SvAnswer<S>& e : {sv_segment(sx, j, k), sv_segment(sx, i, k)})
    if (e.nu_norm2 < best.nu_norm2) best = e;
  return best;
}

template <class S>
SvAnswer<S> sv_tetrahedron(const Simplex<S>& sx, const int idx[4]) {
  const Vec3<S> zero = Vec3<S>::Zero();
  const Vec3<S>& s1 = sx.y[idx[0]];
  const Vec3<S>& s2 = sx.y[idx[1]];
  const Vec3<S>& s3 = sx.y[idx[2]];
  const Vec3<S>& s4 = sx.y[idx[3]];
  // Signed volumes with one vertex moved to the origin: the origin's barycentric weights times
  // the whole volume.
  const S mu = det3<S>(s2 - s1, s3 - s1, s4 - s1);
  const S c[4] = {det3<S>(s2 - zero, s3 - zero, s4 - zero), det3<S>(zero - s1, s3 - s1, s4 - s1),
                  det3<S>(s2 - s1, zero - s1, s4 - s1), det3<S>(s2 - s1, s3 - s1, zero - s1)};
  // Faces whose opposite vertex shares the whole's sign hide the origin. One mask, not a chain of
  // branches: which faces those are is data.
  const unsigned hidden = unsigned(same_sign(mu, c[0])) | unsigned(same_sign(mu, c[1])) << 1 |
                          unsigned(same_sign(mu, c[2])) << 2 | unsigned(same_sign(mu, c[3])) << 3;
  if (hidden == 15u) {
    SvAnswer<S> out;
    out.subset = 0;
    const S sum = c[0] + c[1] + c[2] + c[3];
    for (int m = 0; m < 4; ++m) {
      out.subset |= 1u << idx[m];
      out.lambda[idx[m]] = c[m] / sum;
    }
    out.nu.setZero();  // the origin is enclosed
    out.nu_norm2 = 0;
    return out;
  }
  const bool flat = !(mu != 0);
  const unsigned visible = ~hidden & 15u;
  if (!flat && std::has_single_bit(visible)) {
    // The common case (in a GJK step, about 60% of the tetrahedra that do not enclose the
    // origin): the origin sees one face only, and the nearest point lies on it.
    const int m = std::countr_zero(visible);
    return sv_triangle(sx, idx[(m + 1) % 4], idx[(m + 2) % 4], idx[(m + 3) % 4]);
  }
  SvAnswer<S> best;
  for (int m = 0; m < 4; ++m) {
    if (!flat && ((hidden >> m) & 1u)) continue;  // the face opposite m hides the origin
    const SvAnswer<S> f = sv_triangle(sx, idx[(m + 1) % 4], idx[(m + 2) % 4], idx[(m + 3) % 4]);
    if (f.nu_norm2 < best.nu_norm2) best = f;
  }
  return best;
}

/// ν(co V_k) by signed volumes, on the occupied slots of the simplex. Flattened: the segment,
/// triangle and tetrahedron cases inline into one body, which saves the calls and the copies of
/// their answers (measured: 3–5% of a query on the paper set).
template <class S>
[[gnu::flatten]] void signed_volumes(const Simplex<S>& sx, Nearest<S>& out) {
  // The occupied slots, compacted without branches (which slots are free is data).
  int idx[4] = {0, 0, 0, 0}, n = 0;
  for (int i = 0; i < 4; ++i) {
    idx[n] = i;
    n += int((sx.used >> i) & 1u);
  }
  SvAnswer<S> a;
  switch (n) {
    case 1:
      a = sv_point(sx, idx[0]);
      break;
    case 2:
      a = sv_segment(sx, idx[0], idx[1]);
      break;
    case 3:
      a = sv_triangle(sx, idx[0], idx[1], idx[2]);
      break;
    default:
      a = sv_tetrahedron(sx, idx);
      break;
  }
  out.subset = a.subset;
  for (int i = 0; i < 4; ++i) out.lambda[i] = a.lambda[i];
  out.nu = a.nu;
  out.nu_norm2 = a.nu_norm2;
}

}  // namespace nearpoint::detail
