#include "nearpoint/shapes.hpp"

#include <cmath>

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
  centered_.reserve(vertices.size());
  S extent2 = 0;
  for (const Vec3<S>& v : vertices) {
    centered_.push_back(v - centroid_);
    extent2 = std::max(extent2, centered_.back().squaredNorm());
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
