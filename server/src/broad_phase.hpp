// SPDX-License-Identifier: Apache-2.0
// The broad phase: world-frame boxes around the scene's objects, kept sorted along x as poses
// stream in (sweep and prune), so that the pairs near one object are found without visiting every
// other object. Our own small structure (no maintained Debian library provides an incremental
// AABB structure without pulling in a physics engine; FCL's broad phase is too heavy a dependency
// for the server). Not thread-safe: each pose stream owns one.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "nearpoint/server/scene_service.hpp"

namespace nearpoint::server {

/// An axis-aligned box, world frame, metres.
struct Aabb {
  model::Vec3d lo = model::Vec3d::Zero();
  model::Vec3d hi = model::Vec3d::Zero();
};

/// A box around `geometry` at `pose`: the union of the boxes of its pieces' bounding spheres,
/// widened by a margin that covers the rounding of the world-frame arithmetic (here and in
/// `box_gap`), relative to the magnitudes involved; so the box provably holds the object even
/// 10⁶ m from the origin.
/// `padding`: metres added on every side (the object's larger padding).
Aabb world_box(const StoredGeometry& geometry, const Pose<double>& pose, double padding = 0);

/// A proven lower bound on the distance between anything inside `a` and anything inside `b`
/// (boxes from `world_box`): the Euclidean length of the per-axis gaps; 0 when they overlap.
double box_gap(const Aabb& a, const Aabb& b);

/// Sweep and prune over one box per object: the boxes are kept sorted by their lower x, and a
/// query scans only the x-range a box within the cutoff can start in. After a few objects move,
/// `sort` restores the order by insertion sort, which costs O(n + displacement), not O(n log n).
/// A query costs O(log n + objects in the x-range); one very wide box widens every range (the
/// range is padded by the widest box), which is the structure's known weak case.
class SweepAndPrune {
 public:
  /// `count` objects, each with an empty box at the origin until `set`.
  void reset(std::size_t count);
  std::size_t size() const { return boxes_.size(); }
  void set(std::uint32_t object, const Aabb& box) { boxes_[object] = box; }
  const Aabb& box(std::uint32_t object) const { return boxes_[object]; }
  /// Restores the sweep order after `set` calls; call before `query`.
  void sort();

  /// Calls `visit(j)` for every object j whose box is within `cutoff` (finite, ≥ 0) of `box` on
  /// every axis: a superset of the objects whose `box_gap` to `box` is ≤ cutoff (the test is
  /// widened by a relative 1e-12 so that the rounding of the gaps cannot drop one).
  template <class Visit>
  void query(const Aabb& box, double cutoff, Visit&& visit) const {
    const double reach = cutoff * (1 + 1e-12);
    const double begin_x = box.lo.x() - reach - max_width_x_;
    const double end_x = box.hi.x() + reach;
    // The scan range is padded by its own rounding; the per-box test below decides.
    const double pad = 1e-9 * (std::abs(begin_x) + std::abs(end_x) + max_width_x_ + reach);
    auto it = std::lower_bound(order_.begin(), order_.end(), begin_x - pad,
                               [](const Entry& e, double x) { return e.lo_x < x; });
    for (; it != order_.end() && it->lo_x <= end_x + pad; ++it) {
      const Aabb& other = boxes_[it->object];
      bool near = true;
      for (int axis = 0; axis < 3 && near; ++axis)
        near = other.lo[axis] - box.hi[axis] <= reach && box.lo[axis] - other.hi[axis] <= reach;
      if (near) visit(it->object);
    }
  }

 private:
  struct Entry {
    double lo_x;
    std::uint32_t object;
  };
  std::vector<Aabb> boxes_;
  std::vector<Entry> order_;
  double max_width_x_ = 0;
};

}  // namespace nearpoint::server
