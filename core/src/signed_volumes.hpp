// SPDX-License-Identifier: Apache-2.0
// The signed-volumes subalgorithm (Montanari, Petrinic & Barbieri, "Improving the GJK algorithm
// for faster and more reliable distance queries between convex objects", ACM TOG 36(3), 2017).
//
// It answers the same question as Johnson's subalgorithm, ν(co Y) for |Y| ≤ 4, but from signed
// volumes of the simplex, signed areas of its projection onto the best-conditioned coordinate
// plane, and for a segment each endpoint's own inner product, instead of the Δ recursion. The Δ's
// are differences of inner products and lose relative precision when the simplex is small or flat
// compared with its distance from the origin; the signed volumes are formed from coordinates and do
// not.
//
// Unlike the published version, which assumes the newest point belongs to the answer, every face
// that is visible from the origin's projection is examined, so the routine is also correct for the
// arbitrary initial simplices of warm starts.
#pragma once

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

// Every case below writes its answer straight into a Nearest, with the points passed as
// references together with their slot numbers, and each case has one call site. Earlier versions
// returned a small answer struct per case, copied it up through the callers, looked the points up
// through an index array and inlined a copy of every case at every call (22 KB of code); the
// copies and the indirection cost more than the arithmetic. Measured on the 31,443 simplices the
// paper set hands to this routine, latency per call (each call waiting for the last, as in GJK's
// loop): tetrahedron 79 → 53 ns, triangle 55 → 40 ns, segment 40 → 24 ns, point 17 → 13 ns.

template <class S>
[[gnu::always_inline]] inline void clear_weights(Nearest<S>& out) {
  out.lambda[0] = out.lambda[1] = out.lambda[2] = out.lambda[3] = 0;
}

template <class S>
[[gnu::always_inline]] inline void sv_point(const Vec3<S>& s, int i, Nearest<S>& out) {
  out.subset = 1u << i;
  clear_weights(out);
  out.lambda[i] = 1;
  out.nu = s;
  out.nu_norm2 = s.squaredNorm();
}

/// The segment (s1, s2) held in slots i and j.
template <class S>
[[gnu::always_inline]] inline void sv_segment(const Vec3<S>& s1, int i, const Vec3<S>& s2, int j,
                                              Nearest<S>& out) {
  // The origin's weights on the line, times |t|²: λ₁|t|² = s₂·t and λ₂|t|² = −s₁·t. Each from
  // its own inner product rather than one from the other (λ₁ = 1 − λ₂ would lose λ₁'s relative
  // precision near the s₂ end), and both without forming the projection of the origin first:
  // the published routine projects, divides by |t|² and measures along the longest axis, which
  // puts two more roundings and a division on GJK's critical path for the same quantities
  // (measured: 33 → 24 ns per segment call on the paper set's simplices).
  const Vec3<S> t = s2 - s1;
  const S c1 = s2.dot(t);
  const S c2 = -s1.dot(t);
  if ((c1 > 0) & (c2 > 0)) {  // strictly inside; NaN fails both
    // Weights normalised by their own sum, not by |t|²: computed separately, c₁ + c₂ need not
    // equal |t|² to the last bit, and Σλ ≠ 1 would scale ν off the segment (and out of K).
    const S l1 = c1 / (c1 + c2), l2 = c2 / (c1 + c2);
    out.subset = (1u << i) | (1u << j);
    clear_weights(out);
    out.lambda[i] = l1;
    out.lambda[j] = l2;
    out.nu = l1 * s1 + l2 * s2;
    out.nu_norm2 = out.nu.squaredNorm();
    return;
  }
  // The nearer endpoint (s1 on ties).
  if (s2.squaredNorm() < s1.squaredNorm())
    sv_point(s2, j, out);
  else
    sv_point(s1, i, out);
}

/// Keeps `candidate` in `best` when it is strictly nearer: the first of equals wins.
template <class S>
[[gnu::always_inline]] inline void keep_nearer(const Nearest<S>& candidate, Nearest<S>& best) {
  if (candidate.nu_norm2 < best.nu_norm2) best = candidate;
}

/// The nearest of the triangle's edges that `edges` selects: bit m the edge opposite vertex m;
/// the value 8 all three, in the order (s1 s2), (s2 s3), (s1 s3) of a collinear triangle. One
/// call site for sv_segment keeps the flattened routine small (8 KB against 79 KB with a call per
/// case, which was faster replayed alone but not in the GJK loop, where the routine shares the
/// instruction cache with the support scans).
template <class S>
inline void nearest_edge(const Vec3<S>& s1, int i, const Vec3<S>& s2, int j, const Vec3<S>& s3,
                         int k, unsigned edges, Nearest<S>& out) {
  const Vec3<S>* const point[3] = {&s1, &s2, &s3};
  const int slot[3] = {i, j, k};
  // Edge m of the list: its endpoints (positions into point[]) and whether it is taken.
  static constexpr unsigned char kOpposite[3][2] = {{1, 2}, {2, 0}, {0, 1}};
  static constexpr unsigned char kCollinear[3][2] = {{0, 1}, {1, 2}, {0, 2}};
  const auto& ends = edges == 8u ? kCollinear : kOpposite;
  const unsigned taken = edges == 8u ? 7u : edges;
  Nearest<S> edge;
  bool first = true;
  for (int m = 0; m < 3; ++m) {
    if (!((taken >> m) & 1u)) continue;
    const int a = ends[m][0], b = ends[m][1];
    sv_segment(*point[a], slot[a], *point[b], slot[b], first ? out : edge);
    if (!first) keep_nearer(edge, out);
    first = false;
  }
}

/// The triangle (s1, s2, s3) held in slots i, j and k.
template <class S>
inline void sv_triangle(const Vec3<S>& s1, int i, const Vec3<S>& s2, int j, const Vec3<S>& s3,
                        int k, Nearest<S>& out) {
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
    const S c1 = area(p0, s2, s3), c2 = area(s1, p0, s3), c3 = area(s1, s2, p0);
    // Bit m: the area opposite vertex m keeps the whole's sign. One mask, not a chain of
    // branches: which edges face the origin is data.
    const unsigned kept = unsigned(same_sign(mu, c1)) | unsigned(same_sign(mu, c2)) << 1 |
                          unsigned(same_sign(mu, c3)) << 2;
    if (kept == 7u) {
      // Normalised by Σc rather than μ (see sv_segment): on a sliver triangle μ and the c's carry
      // large relative errors, and only Σλ = 1 with λ > 0 keeps ν inside the triangle.
      const S sum = c1 + c2 + c3;
      const S l1 = c1 / sum, l2 = c2 / sum, l3 = c3 / sum;
      out.subset = (1u << i) | (1u << j) | (1u << k);
      clear_weights(out);
      out.lambda[i] = l1;
      out.lambda[j] = l2;
      out.lambda[k] = l3;
      out.nu.setZero();
      out.nu += l1 * s1;
      out.nu += l2 * s2;
      out.nu += l3 * s3;
      out.nu_norm2 = out.nu.squaredNorm();
      return;
    }
    // Outside: the answer is on an edge seen from p0 (opposite a vertex whose area changed sign):
    // usually one, at most two in exact arithmetic, three only through roundoff.
    return nearest_edge(s1, i, s2, j, s3, k, ~kept & 7u, out);
  }
  // Degenerate (collinear) triangle: the nearest of its three edges.
  nearest_edge(s1, i, s2, j, s3, k, 8u, out);
}

/// The nearest point of the tetrahedron's faces opposite the vertices in `faces` (bit m: the face
/// without slot m). The face opposite vertex m is (m + 1, m + 2, m + 3) mod 4. In a GJK step about
/// 60% of the tetrahedra that do not enclose the origin show it one face only, and the nearest
/// point lies on it: the loop then runs once, straight into `out`.
template <class S>
inline void nearest_of_faces(const Vec3<S> (&y)[4], unsigned faces, Nearest<S>& out) {
  Nearest<S> face;
  bool first = true;
  for (int m = 0; m < 4; ++m) {
    if (!((faces >> m) & 1u)) continue;
    const int a = (m + 1) % 4, b = (m + 2) % 4, c3 = (m + 3) % 4;
    sv_triangle(y[a], a, y[b], b, y[c3], c3, first ? out : face);
    if (!first) keep_nearer(face, out);
    first = false;
  }
}

/// The tetrahedron of all four slots.
template <class S>
inline void sv_tetrahedron(const Vec3<S> (&y)[4], Nearest<S>& out) {
  const Vec3<S> zero = Vec3<S>::Zero();
  const Vec3<S>& s1 = y[0];
  const Vec3<S>& s2 = y[1];
  const Vec3<S>& s3 = y[2];
  const Vec3<S>& s4 = y[3];
  // Signed volumes with one vertex moved to the origin: the origin's barycentric weights times
  // the whole volume.
  const S mu = det3<S>(s2 - s1, s3 - s1, s4 - s1);
  const S c[4] = {volume_with_origin(s2, s3, s4), det3<S>(zero - s1, s3 - s1, s4 - s1),
                  det3<S>(s2 - s1, zero - s1, s4 - s1), det3<S>(s2 - s1, s3 - s1, zero - s1)};
  // Faces whose opposite vertex shares the whole's sign hide the origin. One mask, not a chain of
  // branches: which faces those are is data.
  const unsigned hidden = unsigned(same_sign(mu, c[0])) | unsigned(same_sign(mu, c[1])) << 1 |
                          unsigned(same_sign(mu, c[2])) << 2 | unsigned(same_sign(mu, c[3])) << 3;
  if (hidden == 15u) {
    const S sum = c[0] + c[1] + c[2] + c[3];
    out.subset = 15u;
    for (int m = 0; m < 4; ++m) out.lambda[m] = c[m] / sum;
    out.nu.setZero();  // the origin is enclosed
    out.nu_norm2 = 0;
    return;
  }
  // A flat tetrahedron hides nothing: every face is a candidate.
  const bool flat = !(mu != 0);
  nearest_of_faces(y, flat ? 15u : ~hidden & 15u, out);
}

/// ν(co V_k) by signed volumes, on the occupied slots of the simplex: a table gives each occupancy
/// mask's slots, so the points are read from their slots directly. Flattened: the cases inline
/// into one body, which saves the calls (measured: 3–5% of a query on the paper set).
template <class S>
[[gnu::flatten]] void signed_volumes(const Simplex<S>& sx, Nearest<S>& out) {
  // The occupied slots of each mask, in increasing order.
  static constexpr unsigned char kSlots[16][4] = {
      {0, 0, 0, 0}, {0, 0, 0, 0}, {1, 0, 0, 0}, {0, 1, 0, 0}, {2, 0, 0, 0}, {0, 2, 0, 0},
      {1, 2, 0, 0}, {0, 1, 2, 0}, {3, 0, 0, 0}, {0, 3, 0, 0}, {1, 3, 0, 0}, {0, 1, 3, 0},
      {2, 3, 0, 0}, {0, 2, 3, 0}, {1, 2, 3, 0}, {0, 1, 2, 3}};
  const unsigned used = sx.used & 15u;
  const unsigned char* slot = kSlots[used];
  const Vec3<S>(&y)[4] = sx.y;
  switch (subset_size(used)) {
    case 1:
      return sv_point(y[slot[0]], slot[0], out);
    case 2:
      return sv_segment(y[slot[0]], slot[0], y[slot[1]], slot[1], out);
    case 3:
      return sv_triangle(y[slot[0]], slot[0], y[slot[1]], slot[1], y[slot[2]], slot[2], out);
    case 4:
      return sv_tetrahedron(y, out);
    default:  // an empty simplex (never formed by the loop): no point, ν undefined
      out.subset = 0;
      clear_weights(out);
      out.nu.setZero();
      out.nu_norm2 = std::numeric_limits<S>::infinity();
      return;
  }
}

}  // namespace nearpoint::detail
