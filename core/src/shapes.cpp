// SPDX-License-Identifier: Apache-2.0
// The shapes' validation, centres and extents, and the polytope's support search (paper eq. 17:
// an enumeration of inner products, vectorised; or a climb over the hull's edges for large hulls).
// E. G. Gilbert, D. W. Johnson, S. S. Keerthi, "A Fast Procedure for Computing the Distance Between
// Complex Objects in Three-Dimensional Space", IEEE Journal of Robotics and Automation 4(2), 1988
// (equations as numbered there; docs/design.md has the paper by section).
#include "nearpoint/shapes.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>
#include <utility>

#include "support.hpp"

namespace nearpoint {

template <class S>
Polytope<S>::Polytope(std::span<const Vec3<S>> vertices) {
  if (vertices.empty()) {
    invalid_reason_ = "polytope has no vertices";
    return;
  }
  // The vertex mean z̄ of eq. (34), accumulated in long double so that a million vertices far
  // from the origin do not bias it.
  long double sum[3] = {0, 0, 0};
  for (const Vec3<S>& v : vertices) {
    if (!v.allFinite()) {
      invalid_reason_ = "polytope has a non-finite vertex coordinate";
      return;
    }
    for (int k = 0; k < 3; ++k) sum[k] += v[k];
  }
  const long double n = static_cast<long double>(vertices.size());
  centroid_ = Vec3<S>(S(sum[0] / n), S(sum[1] / n), S(sum[2] / n));
  size_ = vertices.size();
  // Whole blocks of two vectors (2 × 4 doubles or 2 × 8 floats), the scan's unit of work.
  constexpr std::size_t kBlock = std::is_same_v<S, double> ? 8 : 16;
  const std::size_t padded = (size_ + kBlock - 1) / kBlock * kBlock;
  xs_.resize(padded);
  ys_.resize(padded);
  zs_.resize(padded);
  S extent2 = 0, largest = 0;
  long double centered_sum[3] = {0, 0, 0};
  for (std::size_t i = 0; i < padded; ++i) {
    const Vec3<S> c = vertices[i < size_ ? i : 0] - centroid_;
    xs_[i] = c.x();
    ys_[i] = c.y();
    zs_[i] = c.z();
    extent2 = std::max(extent2, c.squaredNorm());
    largest = std::max(largest, c.cwiseAbs().maxCoeff());
    if (i < size_)
      for (int k = 0; k < 3; ++k) centered_sum[k] += c[k];
  }
  // The cold start's centroids' point must be a point of the shape (gjk.hpp, initial_simplex):
  // z̄ rounded by an ulp of itself was not, for a thin polytope 8.6e11 from its origin, and the
  // answer came out 3% short with a bound of 1e-15 (found by fuzz_engine). The mean of the
  // centred vertices is off by ulps of the extent only, which the bound's roundoff covers.
  centered_interior_ =
      Vec3<S>(S(centered_sum[0] / n), S(centered_sum[1] / n), S(centered_sum[2] / n));
  if (!std::isfinite(largest)) {
    invalid_reason_ = "polytope coordinates are too large to represent differences";
    return;
  }
  using std::sqrt;
  extent_ = sqrt(extent2);
  // The squares under- or overflow for a polytope smaller than ~1e-150 or larger than ~1e150
  // (double; ~1e-19 and ~1e19 in float), where the engine rescales K (distance.cpp) and needs the
  // true extent to choose the scale. Then again with the coordinates scaled by a power of two,
  // which is exact; in between the value above is kept as it was, bit for bit.
  const S tiny = sqrt(std::numeric_limits<S>::min()) * S(1024);
  const S huge = sqrt(std::numeric_limits<S>::max()) / S(1024);
  if (largest > 0 && !(largest >= tiny && largest <= huge)) {
    const int e = -std::ilogb(largest);
    S scaled2 = 0;
    for (std::size_t i = 0; i < size_; ++i) {
      const Vec3<S> c(std::ldexp(xs_[i], e), std::ldexp(ys_[i], e), std::ldexp(zs_[i], e));
      scaled2 = std::max(scaled2, c.squaredNorm());
    }
    // Rounded up by an ulp: the extent enters D(K), which bounds, and is never below the truth.
    extent_ = std::ldexp(std::nextafter(sqrt(scaled2), std::numeric_limits<S>::infinity()), -e);
  }
  invalid_reason_ = nullptr;
}

namespace {

// The support scan of eq. (17): argmax of x·dx + y·dy + z·dz over n vertices (n a multiple of
// 2 × kLanes), first index on ties. Written with GCC vector types so that it is SIMD whatever the
// optimiser decides: running maxima and their indices per lane, then a reduction that prefers the
// lowest index among equal values. '>' is false for NaN, so a NaN product is never selected.
// Compiled for AVX2 and for the baseline (where each vector becomes SSE2 pairs), chosen at load
// time. A state object, so that two scans can run interleaved (PairScan).
template <class V, class I, class S, int kLanes, bool kFirstHalfOnly = false>
struct ArgmaxDot {
  using Index = std::remove_reference_t<decltype(std::declval<I>()[0])>;
  const S *xs, *ys, *zs;
  V vx, vy, vz;
  V best[2];
  I where[2];
  I lane_index;
  // kFirstHalfOnly: a polytope of at most kLanes vertices, whose one block's second half holds
  // copies of vertex 0 (the padding), which can never win against vertex 0 itself: only the first
  // half is evaluated and the first merge of the reduction is skipped. The same index, bit for
  // bit. A template parameter, so that the scan of larger polytopes is compiled as before.

  /// kLanes copies of s. A broadcast, where V{} + s added zero on GJK's critical path (and
  /// writing lane by lane went through memory).
  [[gnu::always_inline]] static void splat(S s, V& out) {
    if constexpr (kLanes == 4)
      out = V{s, s, s, s};
    else
      out = V{s, s, s, s, s, s, s, s};
  }
  /// The first block of 2 × kLanes vertices.
  [[gnu::always_inline]] ArgmaxDot(const S* x, const S* y, const S* z, S dx, S dy, S dz)
      : xs(x), ys(y), zs(z) {
    splat(dx, vx);
    splat(dy, vy);
    splat(dz, vz);
    for (int l = 0; l < kLanes; ++l) lane_index[l] = Index(l);
    value(0, best[0]);
    where[0] = lane_index;
    if constexpr (!kFirstHalfOnly) {
      value(kLanes, best[1]);
      where[1] = lane_index + Index(kLanes);
    } else {
      best[1] = best[0];  // never read (no further blocks); keeps the state defined
      where[1] = where[0];
    }
  }
  // By reference, not by value: a vector return type would change the ABI of the baseline copy
  // (it is inlined either way).
  [[gnu::always_inline]] void value(std::size_t i, V& out) const {
    V x, y, z;
    std::memcpy(&x, xs + i, sizeof x);
    std::memcpy(&y, ys + i, sizeof y);
    std::memcpy(&z, zs + i, sizeof z);
    out = x * vx + y * vy + z * vz;
  }
  /// The block of 2 × kLanes vertices starting at i.
  [[gnu::always_inline]] void step(std::size_t i) {
    for (int h = 0; h < 2; ++h) {
      V v;
      value(i + h * kLanes, v);
      const auto better = v > best[h];
      best[h] = better ? v : best[h];
      where[h] = better ? lane_index + Index(i + h * kLanes) : where[h];
    }
  }
  // Reduction without branches: the largest lane value and, among the lanes holding it, the
  // smallest index (each lane kept its earliest index on ties, so this is the first maximiser),
  // in log2(kLanes) lane swaps on whole vectors of (value, index) pairs: a lane takes its
  // partner's pair when the partner's value is larger, when its own value is NaN, or when the
  // values are equal and the partner's index is smaller. One pass over the pairs rather than the
  // maximum first and the index after it: half the dependent steps on GJK's critical path. (A
  // scalar loop over the lanes compiles to data-dependent branches, which mispredicted about once
  // per call.) NaN never wins a comparison but is replaced by any other value, so it survives
  // only if every lane is NaN; then vertex 0 is returned.
  [[gnu::always_inline]] std::size_t index() const {
    auto merge = [](V& v, I& at, const V& ov, const I& oi) {
      const auto take = (ov > v) | (v != v) | ((ov == v) & (oi < at));
      v = take ? ov : v;
      at = take ? oi : at;
    };
    V top = best[0];
    I at = where[0];
    if constexpr (!kFirstHalfOnly) merge(top, at, best[1], where[1]);
    if constexpr (kLanes == 4) {
      merge(top, at, __builtin_shufflevector(top, top, 1, 0, 3, 2),
            __builtin_shufflevector(at, at, 1, 0, 3, 2));
      merge(top, at, __builtin_shufflevector(top, top, 2, 3, 0, 1),
            __builtin_shufflevector(at, at, 2, 3, 0, 1));
    } else {
      merge(top, at, __builtin_shufflevector(top, top, 1, 0, 3, 2, 5, 4, 7, 6),
            __builtin_shufflevector(at, at, 1, 0, 3, 2, 5, 4, 7, 6));
      merge(top, at, __builtin_shufflevector(top, top, 2, 3, 0, 1, 6, 7, 4, 5),
            __builtin_shufflevector(at, at, 2, 3, 0, 1, 6, 7, 4, 5));
      merge(top, at, __builtin_shufflevector(top, top, 4, 5, 6, 7, 0, 1, 2, 3),
            __builtin_shufflevector(at, at, 4, 5, 6, 7, 0, 1, 2, 3));
    }
    if (top[0] != top[0]) return 0;  // every lane NaN
    return std::size_t(at[0]);
  }
};

template <class V, class I, class S, int kLanes>
[[gnu::always_inline]] inline std::size_t argmax_dot_simd(const S* xs, const S* ys, const S* zs,
                                                          std::size_t n, S dx, S dy, S dz) {
  ArgmaxDot<V, I, S, kLanes> scan(xs, ys, zs, dx, dy, dz);
  for (std::size_t i = 2 * kLanes; i < n; i += 2 * kLanes) scan.step(i);
  return scan.index();
}

/// Two scans in one loop (see PairScan): the common blocks interleaved, then the longer one's rest.
/// kTiny: both polytopes have at most kLanes vertices (one block each, see ArgmaxDot).
template <class V, class I, class S, int kLanes, bool kTiny>
[[gnu::always_inline]] inline detail::IndexPair argmax_dot_pair_simd(const S* const a[3],
                                                                     std::size_t na, S ax, S ay,
                                                                     S az, const S* const b[3],
                                                                     std::size_t nb, S bx, S by,
                                                                     S bz) {
  if constexpr (kTiny) {
    ArgmaxDot<V, I, S, kLanes, true> scan_a(a[0], a[1], a[2], ax, ay, az);
    ArgmaxDot<V, I, S, kLanes, true> scan_b(b[0], b[1], b[2], bx, by, bz);
    return {scan_a.index(), scan_b.index()};
  }
  ArgmaxDot<V, I, S, kLanes> scan_a(a[0], a[1], a[2], ax, ay, az);
  ArgmaxDot<V, I, S, kLanes> scan_b(b[0], b[1], b[2], bx, by, bz);
  const std::size_t common = std::min(na, nb);
  std::size_t i = 2 * kLanes;
  for (; i < common; i += 2 * kLanes) {
    scan_a.step(i);
    scan_b.step(i);
  }
  for (std::size_t j = i; j < na; j += 2 * kLanes) scan_a.step(j);
  for (std::size_t j = i; j < nb; j += 2 * kLanes) scan_b.step(j);
  return {scan_a.index(), scan_b.index()};
}

using Double4 = double __attribute__((vector_size(32)));
using Int64x4 = std::int64_t __attribute__((vector_size(32)));
using Float8 = float __attribute__((vector_size(32)));
using Int32x8 = std::int32_t __attribute__((vector_size(32)));

template <class S>
__attribute__((always_inline)) inline std::size_t argmax_dot(const S* xs, const S* ys, const S* zs,
                                                             std::size_t n, S dx, S dy, S dz) {
  if constexpr (std::is_same_v<S, double>)
    return argmax_dot_simd<Double4, Int64x4, double, 4>(xs, ys, zs, n, dx, dy, dz);
  else
    return argmax_dot_simd<Float8, Int32x8, float, 8>(xs, ys, zs, n, dx, dy, dz);
}
/// The lanes of one vector of S: a polytope of at most this many vertices scans one vector.
template <class S>
constexpr std::size_t kScanLanes = std::is_same_v<S, double> ? 4 : 8;

template <class S, bool kTiny>
__attribute__((always_inline)) inline detail::IndexPair argmax_dot_pair(const S* const a[3],
                                                                        std::size_t na, S ax, S ay,
                                                                        S az, const S* const b[3],
                                                                        std::size_t nb, S bx, S by,
                                                                        S bz) {
  if constexpr (std::is_same_v<S, double>)
    return argmax_dot_pair_simd<Double4, Int64x4, double, 4, kTiny>(a, na, ax, ay, az, b, nb, bx,
                                                                    by, bz);
  else
    return argmax_dot_pair_simd<Float8, Int32x8, float, 8, kTiny>(a, na, ax, ay, az, b, nb, bx, by,
                                                                  bz);
}

// One copy compiled for AVX2 and one for the baseline, chosen once at run time. Explicit dispatch
// rather than target_clones: an ifunc resolver runs during relocation, before a sanitizer's
// runtime is up, and crashes ThreadSanitizer builds.
#if defined(__x86_64__) || defined(__i386__)
#define NEARPOINT_HAVE_AVX2_CLONE 1
__attribute__((target("avx2"))) std::size_t argmax_dot_avx2(const double* xs, const double* ys,
                                                            const double* zs, std::size_t n,
                                                            double dx, double dy, double dz) {
  return argmax_dot(xs, ys, zs, n, dx, dy, dz);
}
__attribute__((target("avx2"))) std::size_t argmax_dot_avx2(const float* xs, const float* ys,
                                                            const float* zs, std::size_t n,
                                                            float dx, float dy, float dz) {
  return argmax_dot(xs, ys, zs, n, dx, dy, dz);
}
bool cpu_has_avx2() {
  static const bool has = [] {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") != 0;
  }();
  return has;
}
#endif

template <class S>
std::size_t argmax_dot_baseline(const S* xs, const S* ys, const S* zs, std::size_t n, S dx, S dy,
                                S dz) {
  return argmax_dot(xs, ys, zs, n, dx, dy, dz);
}

/// Climbing seeds are the extreme vertices along the integer directions (x, y, z) ∈
/// {-kSeedGrid … kSeedGrid}³ \ {0}: 728 directions; rounding d scaled to the grid lands within
/// about 10° of it.
constexpr int kSeedGrid = 4;
constexpr std::size_t kSeedSlots = (2 * kSeedGrid + 1) * (2 * kSeedGrid + 1) * (2 * kSeedGrid + 1);
/// Where the seed found along grid direction (x, y, z) is kept in seeds_.
constexpr std::size_t seed_code(int x, int y, int z) {
  constexpr int width = 2 * kSeedGrid + 1;
  return std::size_t(((x + kSeedGrid) * width + (y + kSeedGrid)) * width + (z + kSeedGrid));
}

template <class S>
bool finite_nonnegative(S value) {
  return std::isfinite(value) && value >= 0;
}

template <class S>
struct ReasonVisitor {
  const char* operator()(const Point&) const { return nullptr; }
  const char* operator()(const Segment<S>& s) const {
    return s.a.allFinite() && s.b.allFinite() ? nullptr : "segment has a non-finite end point";
  }
  const char* operator()(const Box<S>& b) const {
    for (int k = 0; k < 3; ++k)
      if (!finite_nonnegative(b.half_extents[k])) return "box half extents must be finite and >= 0";
    return nullptr;
  }
  const char* operator()(const Polytope<S>& p) const { return p.invalid_reason(); }
  const char* operator()(const Cylinder<S>& c) const {
    return finite_nonnegative(c.radius) && finite_nonnegative(c.half_height)
               ? nullptr
               : "cylinder radius and half height must be finite and >= 0";
  }
  const char* operator()(const Cone<S>& c) const {
    return finite_nonnegative(c.radius) && finite_nonnegative(c.half_height)
               ? nullptr
               : "cone radius and half height must be finite and >= 0";
  }
  const char* operator()(const Ellipsoid<S>& e) const {
    for (int k = 0; k < 3; ++k)
      if (!finite_nonnegative(e.radii[k])) return "ellipsoid radii must be finite and >= 0";
    return nullptr;
  }
};
}  // namespace

template <class S>
Polytope<S>::Polytope(std::span<const Vec3<S>> vertices, std::span<const std::vector<int>> faces,
                      FacesCheck check)
    : Polytope(vertices) {
  if (invalid_reason_) return;
  invalid_reason_ = check_faces(faces, check);
  if (invalid_reason_ || size_ < kHillClimbThreshold) return;

  // The edge graph: each undirected edge once per end (check_faces proved every directed edge
  // has its twin, so the directed edges of the faces list each neighbour exactly once).
  neighbor_begin_.assign(size_ + 1, 0);
  for (const std::vector<int>& face : faces)
    for (const int v : face) ++neighbor_begin_[std::size_t(v) + 1];
  for (std::size_t i = 0; i < size_; ++i) neighbor_begin_[i + 1] += neighbor_begin_[i];
  neighbors_.resize(neighbor_begin_[size_]);
  std::vector<std::uint32_t> fill(neighbor_begin_.begin(), neighbor_begin_.end() - 1);
  for (const std::vector<int>& face : faces)
    for (std::size_t k = 0; k < face.size(); ++k)
      neighbors_[fill[std::size_t(face[k])]++] = std::uint32_t(face[(k + 1) % face.size()]);

  // A climb starts from the extreme vertex along the grid direction nearest its own: within a
  // step or two of the answer for any direction. 728 scans of the vertices, once per polytope
  // (measured: +0.4 ms on the 4.6 ms of building a 1,000-vertex hull, +80 ms on the 1.05 s of a
  // 10⁵-vertex one), for cold climbs much shorter than from the 14 axes and diagonals before
  // (measured: 1,000 vertices cold 1.44 → 1.13 µs, 10,000 3.3 → 2.0 µs). The centre slot,
  // (0, 0, 0), keeps vertex 0.
  seeds_.assign(kSeedSlots, 0);
  for (int x = -kSeedGrid; x <= kSeedGrid; ++x)
    for (int y = -kSeedGrid; y <= kSeedGrid; ++y)
      for (int z = -kSeedGrid; z <= kSeedGrid; ++z) {
        if (x == 0 && y == 0 && z == 0) continue;
        seeds_[seed_code(x, y, z)] =
            std::uint32_t(scan_(xs_.data(), ys_.data(), zs_.data(), xs_.size(), S(x), S(y), S(z)));
      }
}

template <class S>
const char* Polytope<S>::check_faces(std::span<const std::vector<int>> faces,
                                     FacesCheck check) const {
  if (faces.empty()) return "polytope faces: none given";
  // Directed edges (from, to) as 64-bit keys, each with its face and the vertex that follows it
  // in that face; sorted by key, each must occur once, with its twin.
  struct DirectedEdge {
    std::uint64_t key;
    std::uint32_t face;
    std::uint32_t next;  // the face's vertex after the edge's end
  };
  std::vector<DirectedEdge> edges;
  std::vector<bool> used(size_, false);
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const std::vector<int>& face = faces[f];
    if (face.size() < 3) return "polytope faces: a face has fewer than 3 vertices";
    for (const int v : face) {
      if (v < 0 || std::size_t(v) >= size_) return "polytope faces: a vertex index is out of range";
      used[std::size_t(v)] = true;
    }
    for (std::size_t k = 0; k < face.size(); ++k)
      edges.push_back(
          {std::uint64_t(std::uint32_t(face[k])) << 32 | std::uint32_t(face[(k + 1) % face.size()]),
           std::uint32_t(f), std::uint32_t(face[(k + 2) % face.size()])});
  }
  if (std::find(used.begin(), used.end(), false) != used.end())
    return "polytope faces: a vertex lies on no face (pass only the hull's vertices)";
  std::sort(edges.begin(), edges.end(),
            [](const DirectedEdge& x, const DirectedEdge& y) { return x.key < y.key; });
  for (std::size_t e = 1; e < edges.size(); ++e)
    if (edges[e].key == edges[e - 1].key)
      return "polytope faces: an edge is used twice in the same direction (faces not "
             "consistently oriented, or not a closed surface)";
  // The twin (to, from) of each edge, or nullptr when the surface is open there.
  auto twin_of = [&](const DirectedEdge& edge) -> const DirectedEdge* {
    const std::uint64_t key = edge.key << 32 | edge.key >> 32;
    const auto found =
        std::lower_bound(edges.begin(), edges.end(), key,
                         [](const DirectedEdge& x, std::uint64_t k) { return x.key < k; });
    return found != edges.end() && found->key == key ? &*found : nullptr;
  };
  for (const DirectedEdge& edge : edges)
    if (!twin_of(edge))
      return "polytope faces: the surface is not closed (an edge borders only one face)";
  const long long euler =
      (long long)size_ - (long long)(edges.size() / 2) + (long long)faces.size();
  if (euler != 2) return "polytope faces: the surface is not a sphere (V - E + F != 2)";
  if (check == FacesCheck::topology) return nullptr;

  // Geometry: every face planar and every edge convex, up to roundoff. Each face is represented
  // by its largest fan triangle (p, q, r); "d above the plane" is the sign of the orientation
  // determinant D = (q − p)×(r − p)·(d − p) = (u×v)·w, trusted only beyond its rounding-error
  // bound, so sliver triangles of a fine hull pass while a real dent (a vertex above a
  // neighbouring face) fails. Two roundings bound it:
  //  - evaluating D from the stored vertices: 32 ε |u||v||w|;
  //  - the stored vertices themselves, z − z̄ rounded (eq. 34's centring): each coordinate is off
  //    by up to ε/2 |z_k − z̄_k| ≤ ε/2 · extent, so each point moves by δ ≤ 0.87 ε · extent, an
  //    error that does not shrink with the triangle. D's gradient with respect to d, q, r is u×v,
  //    v×w, w×u (and minus their sum for p), so moving the four points by δ changes D by at most
  //    2δ(|u||v| + |v||w| + |w||u|) to first order; 4 ε · extent covers it with a margin for the
  //    higher-order terms. Without this term, exactly convex hulls with slivers next to nearly
  //    coplanar faces (the paper's polytopes with rotated caps) were refused as not convex.
  auto height = [&](const std::array<std::uint32_t, 3>& t, std::uint32_t d, S& bound) {
    const Vec3<S> p = centered_vertex(t[0]);
    const Vec3<S> u = centered_vertex(t[1]) - p, v = centered_vertex(t[2]) - p;
    const Vec3<S> w = centered_vertex(d) - p;
    const S eps = std::numeric_limits<S>::epsilon();
    const S nu = u.norm(), nv = v.norm(), nw = w.norm();
    bound = S(32) * eps * nu * nv * nw + S(4) * eps * extent_ * (nu * nv + nv * nw + nw * nu);
    return u.cross(v).dot(w);
  };
  std::vector<std::array<std::uint32_t, 3>> planes;
  planes.reserve(faces.size());
  S volume6 = 0;
  for (const std::vector<int>& face : faces) {
    std::array<std::uint32_t, 3> best{};
    S best_area = -1;
    const Vec3<S> p = centered_vertex(std::size_t(face[0]));
    for (std::size_t k = 1; k + 1 < face.size(); ++k) {
      const S area = (centered_vertex(std::size_t(face[k])) - p)
                         .cross(centered_vertex(std::size_t(face[k + 1])) - p)
                         .norm();
      if (area > best_area) {
        best_area = area;
        best = {std::uint32_t(face[0]), std::uint32_t(face[k]), std::uint32_t(face[k + 1])};
      }
    }
    if (!(best_area > 0)) return "polytope faces: a face has zero area";
    S bound = 0;
    for (const int v : face)
      if (std::abs(height(best, std::uint32_t(v), bound)) > bound)
        return "polytope faces: a face is not planar";
    // 6 × the volume of the cone from z̄ over the fan triangle; positive when oriented outwards.
    const Vec3<S> a = centered_vertex(best[0]), b = centered_vertex(best[1]),
                  c = centered_vertex(best[2]);
    volume6 += a.dot(b.cross(c)) * S(face.size() - 2);
    planes.push_back(best);
  }
  if (!(volume6 > 0))
    return "polytope faces: faces are oriented inwards (want counter-clockwise seen from outside)";
  // Convexity: every vertex lies below every face's plane is O(V·F); checking it at each edge
  // (the far vertex of the neighbouring face) suffices for a closed oriented sphere surface.
  // For each directed edge (a, b) of face f, the twin (b, a) lies in a face g; g's vertex after a
  // is off the edge and must not rise above f's plane.
  for (const DirectedEdge& edge : edges) {
    S bound = 0;
    if (height(planes[edge.face], twin_of(edge)->next, bound) > bound)
      return "polytope faces: the surface is not convex (use the convex hull's faces)";
  }
  return nullptr;
}

// A climb over the hull's edges as a state object, so that two climbs (A's and B's in one
// support call of K) can run interleaved: each step depends on the one before (which neighbour
// won), and two independent chains side by side hide each other's latency.
template <class S>
struct Climb {
  const S *xs, *ys, *zs;
  const std::uint32_t *begin, *neighbors;
  S dx, dy, dz;
  std::uint32_t at;
  S best;

  [[gnu::always_inline]] S value(std::uint32_t i) const {
    return xs[i] * dx + ys[i] * dy + zs[i] * dz;
  }
  // Start from the better of the hint (GJK's previous answer for this shape: usually close) and
  // the seed along the grid direction nearest d (never far, even when an early GJK direction
  // reverses): d scaled so that its largest component is ±kSeedGrid, rounded. A direction that is
  // zero or not finite keeps the hint (or seed (−1, −1, −1)), and a NaN one never moves.
  [[gnu::always_inline]] Climb(const S* x, const S* y, const S* z, const std::uint32_t* row_begin,
                               const std::uint32_t* adjacency,
                               const std::vector<std::uint32_t>& seeds, std::size_t size,
                               const Vec3<S>& d, std::int32_t hint)
      : xs(x),
        ys(y),
        zs(z),
        begin(row_begin),
        neighbors(adjacency),
        dx(d.x()),
        dy(d.y()),
        dz(d.z()),
        at(hint >= 0 && std::size_t(hint) < size ? std::uint32_t(hint)
                                                 : seeds[seed_code(-1, -1, -1)]),
        best(value(at)) {
    using std::abs;
    const S largest = std::max(abs(dx), std::max(abs(dy), abs(dz)));
    if (!(std::isfinite(dx) && std::isfinite(dy) && std::isfinite(dz) && largest > 0)) return;
    // component / largest ∈ [−1, 1] for any finite direction, subnormal ones included (a
    // reciprocal of a subnormal `largest` would overflow), so each rounded coordinate is in the
    // grid.
    auto grid = [largest](S component) {
      const S scaled = S(kSeedGrid) * (component / largest);
      return int(scaled + (scaled >= 0 ? S(0.5) : S(-0.5)));
    };
    const std::uint32_t seed = seeds[seed_code(grid(dx), grid(dy), grid(dz))];
    if (const S v = value(seed); v > best) {
      best = v;
      at = seed;
    }
  }
  // One step of steepest ascent over the edges; false at the top. On a convex polytope a vertex
  // with no better neighbour is a maximiser (the simplex method's optimality condition), so the
  // climb ends at a support point; each step strictly increases the value, so it ends. A NaN
  // direction never moves.
  [[gnu::always_inline]] bool step() {
    std::uint32_t next = at;
    for (std::uint32_t k = begin[at]; k < begin[at + 1]; ++k)
      if (const S v = value(neighbors[k]); v > best) {
        best = v;
        next = neighbors[k];
      }
    const bool moved = next != at;
    at = next;
    return moved;
  }
};

template <class S>
std::atomic<detail::PairScan::Search<S>> detail::PairScan::chosen{&detail::PairScan::resolve<S>};

template <class S>
detail::IndexPair detail::PairScan::resolve(const Polytope<S>& a, S ax, S ay, S az,
                                            std::int32_t hint_a, const Polytope<S>& b, S bx, S by,
                                            S bz, std::int32_t hint_b) {
  Search<S> search = &search_baseline<S>;
#ifdef NEARPOINT_HAVE_AVX2_CLONE
  if (cpu_has_avx2()) search = &search_avx2<S>;
#endif
  chosen<S>.store(search, std::memory_order_relaxed);
  return search(a, ax, ay, az, hint_a, b, bx, by, bz, hint_b);
}

template <class S>
[[gnu::always_inline]] inline detail::IndexPair detail::PairScan::search(
    const Polytope<S>& a, S ax, S ay, S az, std::int32_t hint_a, const Polytope<S>& b, S bx, S by,
    S bz, std::int32_t hint_b) {
  if (a.climbs() || b.climbs())
    return climb_indices(a, Vec3<S>(ax, ay, az), hint_a, b, Vec3<S>(bx, by, bz), hint_b);
  const S* const coords_a[3] = {a.xs_.data(), a.ys_.data(), a.zs_.data()};
  const S* const coords_b[3] = {b.xs_.data(), b.ys_.data(), b.zs_.data()};
  if (a.size_ <= kScanLanes<S> && b.size_ <= kScanLanes<S>)
    return argmax_dot_pair<S, true>(coords_a, a.xs_.size(), ax, ay, az, coords_b, b.xs_.size(), bx,
                                    by, bz);
  return argmax_dot_pair<S, false>(coords_a, a.xs_.size(), ax, ay, az, coords_b, b.xs_.size(), bx,
                                   by, bz);
}

template <class S>
detail::IndexPair detail::PairScan::search_baseline(const Polytope<S>& a, S ax, S ay, S az,
                                                    std::int32_t hint_a, const Polytope<S>& b, S bx,
                                                    S by, S bz, std::int32_t hint_b) {
  return search(a, ax, ay, az, hint_a, b, bx, by, bz, hint_b);
}

#ifdef NEARPOINT_HAVE_AVX2_CLONE
// The same search with the interleaved scans compiled for AVX2 (see argmax_dot_avx2).
template <class S>
__attribute__((target("avx2"))) detail::IndexPair detail::PairScan::search_avx2(
    const Polytope<S>& a, S ax, S ay, S az, std::int32_t hint_a, const Polytope<S>& b, S bx, S by,
    S bz, std::int32_t hint_b) {
  return search(a, ax, ay, az, hint_a, b, bx, by, bz, hint_b);
}
#endif

template <class S>
detail::IndexPair detail::PairScan::climb_indices(const Polytope<S>& a, const Vec3<S>& direction_a,
                                                  std::int32_t hint_a, const Polytope<S>& b,
                                                  const Vec3<S>& direction_b, std::int32_t hint_b) {
  if (a.climbs() && b.climbs()) {
    Climb<S> climb_a(a.xs_.data(), a.ys_.data(), a.zs_.data(), a.neighbor_begin_.data(),
                     a.neighbors_.data(), a.seeds_, a.size_, direction_a, hint_a);
    Climb<S> climb_b(b.xs_.data(), b.ys_.data(), b.zs_.data(), b.neighbor_begin_.data(),
                     b.neighbors_.data(), b.seeds_, b.size_, direction_b, hint_b);
    bool moving_a = true, moving_b = true;
    while (moving_a & moving_b) {
      moving_a = climb_a.step();
      moving_b = climb_b.step();
    }
    while (moving_a) moving_a = climb_a.step();
    while (moving_b) moving_b = climb_b.step();
    return {climb_a.at, climb_b.at};
  }
  return {a.support_index(direction_a, hint_a), b.support_index(direction_b, hint_b)};
}

template <class S>
typename Polytope<S>::Scan Polytope<S>::best_scan() {
#ifdef NEARPOINT_HAVE_AVX2_CLONE
  if (cpu_has_avx2()) return static_cast<Scan>(&argmax_dot_avx2);
#endif
  return &argmax_dot_baseline<S>;
}

template <class S>
std::size_t Polytope<S>::climb(const Vec3<S>& d, std::int32_t hint) const {
  Climb<S> climb(xs_.data(), ys_.data(), zs_.data(), neighbor_begin_.data(), neighbors_.data(),
                 seeds_, size_, d, hint);
  while (climb.step()) {
  }
  return climb.at;
}

template <class S>
const char* invalid_reason(const Shape<S>& shape) {
  if (!finite_nonnegative(shape.radius))
    return "spherical-extension radius must be finite and >= 0";
  return std::visit(ReasonVisitor<S>{}, shape.geometry);
}

template <class S>
Vec3<S> core_center(const Shape<S>& shape) {
  return std::visit(
      [](const auto& g) -> Vec3<S> {
        return detail::Support<std::decay_t<decltype(g)>, S>{g}.center();
      },
      shape.geometry);
}

template <class S>
S core_extent(const Shape<S>& shape) {
  return std::visit(
      [](const auto& g) -> S { return detail::Support<std::decay_t<decltype(g)>, S>{g}.extent(); },
      shape.geometry);
}

template <class S>
Vec3<S> support(const Shape<S>& shape, const Vec3<S>& direction, int& index) {
  return std::visit(
      [&](const auto& g) -> Vec3<S> {
        const detail::Support<std::decay_t<decltype(g)>, S> s{g};
        std::int32_t i = -1;
        const Vec3<S> p = s.support(direction, i) + s.center();
        index = i;
        return p;
      },
      shape.geometry);
}

#define NEARPOINT_INSTANTIATE(S)                                         \
  template class Polytope<S>;                                            \
  template const char* invalid_reason(const Shape<S>&);                  \
  template Vec3<S> core_center(const Shape<S>&);                         \
  template S core_extent(const Shape<S>&);                               \
  template Vec3<S> support(const Shape<S>&, const Vec3<S>&, int& index); \
  template std::atomic<detail::PairScan::Search<S>> detail::PairScan::chosen<S>;
NEARPOINT_INSTANTIATE(double)
NEARPOINT_INSTANTIATE(float)
#undef NEARPOINT_INSTANTIATE

}  // namespace nearpoint
