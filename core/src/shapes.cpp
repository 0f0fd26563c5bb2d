#include "nearpoint/shapes.hpp"

#include <cmath>
#include <cstring>
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
  const std::size_t padded = (size_ + 15) / 16 * 16;  // two vectors of 8 floats or 4 doubles
  xs_.resize(padded);
  ys_.resize(padded);
  zs_.resize(padded);
  S extent2 = 0;
  for (std::size_t i = 0; i < padded; ++i) {
    const Vec3<S> c = vertices[i < size_ ? i : 0] - centroid_;
    xs_[i] = c.x();
    ys_[i] = c.y();
    zs_[i] = c.z();
    extent2 = std::max(extent2, c.squaredNorm());
  }
  using std::sqrt;
  extent_ = sqrt(extent2);
  if (!std::isfinite(extent_)) {
    invalid_reason_ = "polytope coordinates are too large to represent differences";
    return;
  }
  invalid_reason_ = nullptr;
}

namespace {

// The support scan of eq. (17): argmax of x·dx + y·dy + z·dz over n vertices (n a multiple of 8),
// first index on ties. Written with GCC vector types so that it is SIMD whatever the optimiser
// decides: running maxima and their indices per lane, then a reduction that prefers the lowest
// index among equal values. '>' is false for NaN, so a NaN product is never selected. Compiled
// for AVX2 and for the baseline (where each vector becomes SSE2 pairs), chosen at load time.
template <class V, class I, class S, int kLanes>
__attribute__((always_inline)) inline std::size_t argmax_dot_simd(const S* xs, const S* ys,
                                                                  const S* zs, std::size_t n, S dx,
                                                                  S dy, S dz) {
  using Index = std::remove_reference_t<decltype(std::declval<I>()[0])>;
  const V vx = V{} + dx, vy = V{} + dy, vz = V{} + dz;
  V best[2];
  I where[2];
  I lane_index;
  for (int l = 0; l < kLanes; ++l) lane_index[l] = Index(l);
  for (int h = 0; h < 2; ++h) {
    V x, y, z;
    std::memcpy(&x, xs + h * kLanes, sizeof x);
    std::memcpy(&y, ys + h * kLanes, sizeof y);
    std::memcpy(&z, zs + h * kLanes, sizeof z);
    best[h] = x * vx + y * vy + z * vz;
    where[h] = lane_index + Index(h * kLanes);
  }
  for (std::size_t i = 2 * kLanes; i < n; i += 2 * kLanes) {
    for (int h = 0; h < 2; ++h) {
      V x, y, z;
      std::memcpy(&x, xs + i + h * kLanes, sizeof x);
      std::memcpy(&y, ys + i + h * kLanes, sizeof y);
      std::memcpy(&z, zs + i + h * kLanes, sizeof z);
      const V value = x * vx + y * vy + z * vz;
      const auto better = value > best[h];
      best[h] = better ? value : best[h];
      where[h] = better ? lane_index + Index(i + h * kLanes) : where[h];
    }
  }
  S best_value = best[0][0];
  std::size_t best_index = std::size_t(where[0][0]);
  bool found = best_value == best_value;
  for (int h = 0; h < 2; ++h) {
    for (int l = 0; l < kLanes; ++l) {
      const S value = best[h][l];
      const std::size_t index = std::size_t(where[h][l]);
      if (!(value == value)) continue;  // NaN-safe on purpose: a NaN lane never wins
      if (!found || value > best_value || (value == best_value && index < best_index)) {
        best_value = value;
        best_index = index;
        found = true;
      }
    }
  }
  return best_index;
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
std::size_t argmax_dot_dispatch(const S* xs, const S* ys, const S* zs, std::size_t n, S dx, S dy,
                                S dz) {
#ifdef NEARPOINT_HAVE_AVX2_CLONE
  if (cpu_has_avx2()) return argmax_dot_avx2(xs, ys, zs, n, dx, dy, dz);
#endif
  return argmax_dot(xs, ys, zs, n, dx, dy, dz);
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
std::size_t Polytope<S>::support_index(const Vec3<S>& d) const {
  return argmax_dot_dispatch(xs_.data(), ys_.data(), zs_.data(), xs_.size(), d.x(), d.y(), d.z());
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

#define NEARPOINT_INSTANTIATE(S)                        \
  template class Polytope<S>;                           \
  template const char* invalid_reason(const Shape<S>&); \
  template Vec3<S> core_center(const Shape<S>&);        \
  template S core_extent(const Shape<S>&);              \
  template Vec3<S> support(const Shape<S>&, const Vec3<S>&, int& index);
NEARPOINT_INSTANTIATE(double)
NEARPOINT_INSTANTIATE(float)
#undef NEARPOINT_INSTANTIATE

}  // namespace nearpoint
