// SPDX-License-Identifier: Apache-2.0
#include "broad_phase.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace nearpoint::server {

Aabb world_box(const StoredGeometry& geometry, const Pose<double>& pose, double padding) {
  const Compound<double>& compound = geometry.compound;
  Aabb box;
  box.lo.setConstant(std::numeric_limits<double>::infinity());
  box.hi.setConstant(-std::numeric_limits<double>::infinity());
  double magnitude = pose.translation.cwiseAbs().maxCoeff();
  for (std::size_t i = 0; i < compound.size(); ++i) {
    const model::Vec3d center = pose.apply(compound.sphere_center(i));
    const double radius = compound.sphere_radius(i);
    box.lo = box.lo.cwiseMin((center.array() - radius).matrix());
    box.hi = box.hi.cwiseMax((center.array() + radius).matrix());
    magnitude = std::max({magnitude, center.cwiseAbs().maxCoeff(),
                          compound.sphere_center(i).cwiseAbs().maxCoeff() + radius});
  }
  // R·c + t and c ± r round by a few ulps of the largest magnitude involved, and the gaps between
  // two boxes by one more; 1e-12 relative covers both with room to spare (an ulp is 2.2e-16).
  const double margin = 1e-12 * (magnitude + padding) + padding;
  box.lo.array() -= margin;
  box.hi.array() += margin;
  return box;
}

double box_gap(const Aabb& a, const Aabb& b) {
  const model::Vec3d gaps = (b.lo - a.hi).cwiseMax(a.lo - b.hi).cwiseMax(0.0);
  return gaps.norm();
}

void SweepAndPrune::reset(std::size_t count) {
  boxes_.assign(count, Aabb{});
  order_.resize(count);
  for (std::size_t i = 0; i < count; ++i) order_[i] = Entry{0.0, std::uint32_t(i)};
  max_width_x_ = 0;
}

void SweepAndPrune::sort() {
  double widest = 0;
  for (Entry& entry : order_) {
    const Aabb& box = boxes_[entry.object];
    entry.lo_x = box.lo.x();
    widest = std::max(widest, box.hi.x() - box.lo.x());
  }
  max_width_x_ = widest;
  // Insertion sort: after k objects move, the order is nearly sorted and this is O(n + shifts).
  // When the shifts grow past a few per object (the first sort, or everything moved far), a full
  // sort is cheaper: give up and do that.
  const std::size_t budget = 16 * order_.size() + 64;
  std::size_t shifts = 0;
  for (std::size_t i = 1; i < order_.size(); ++i) {
    const Entry entry = order_[i];
    std::size_t j = i;
    for (; j > 0 && order_[j - 1].lo_x > entry.lo_x; --j) order_[j] = order_[j - 1];
    order_[j] = entry;
    shifts += i - j;
    if (shifts > budget) {
      std::sort(order_.begin(), order_.end(),
                [](const Entry& a, const Entry& b) { return a.lo_x < b.lo_x; });
      return;
    }
  }
}

}  // namespace nearpoint::server
