// SPDX-License-Identifier: Apache-2.0
// nearpoint behind the common Runner interface.
#include <map>
#include <utility>

#include "nearpoint/hull.hpp"
#include "runners.hpp"

namespace nearpoint::bench {
namespace {

// With `Depth`, the depth experiment's answer (depth, its interval, D(K)) is copied out too; the
// other experiments' runners do not pay for those stores.
template <bool Depth>
class NearpointRunner final : public Runner {
 public:
  NearpointRunner(std::span<const PairInput> inputs, const DistanceOptions<double>& options,
                  bool warm, bool climb)
      : options_(options), warm_(warm) {
    // One Shape per distinct (vertex list, radius): the Polytope's one-time work (centroid,
    // extent, centred copy) is done here, outside the timed region, as a user would.
    auto shape_of = [&](const std::shared_ptr<const std::vector<Vec3<double>>>& v, double r) {
      auto [it, inserted] = shapes_.try_emplace({v.get(), r});
      if (inserted) it->second = Shape<double>(climb ? hull_polytope(*v) : Polytope<double>(*v), r);
      return &it->second;
    };
    queries_.reserve(inputs.size());
    for (const PairInput& in : inputs)
      queries_.push_back(
          {shape_of(in.a, in.radius_a), in.pose_a, shape_of(in.b, in.radius_b), in.pose_b});
  }

  void run(std::size_t i, Outcome& out) override {
    const Query& q = queries_[i];
    const DistanceResult<double> r =
        distance(*q.a, q.pose_a, *q.b, q.pose_b, options_, warm_ ? &cache_ : nullptr);
    out.distance = r.distance;
    out.intersecting = r.status == Status::intersecting;
    out.iterations = r.iterations;
    out.error_bound = r.error_bound;
    out.exit = exit_of(r);
    out.termination = to_string(r.termination);
    if constexpr (Depth) {
      // No depth answer (no verdict: the iteration cap, invalid input): NaN, counted.
      out.depth = r.has_penetration_depth ? r.depth : kNaN;
      out.depth_lower = r.has_penetration_depth ? r.depth_lower : kNaN;
      out.depth_upper = r.has_penetration_depth ? r.depth_upper : kNaN;
      out.diameter_bound = r.diameter_bound;
      out.signed_lower = r.has_signed_distance ? r.signed_distance_lower : kNaN;
      out.signed_upper = r.has_signed_distance ? r.signed_distance_upper : kNaN;
      out.code_a = int(r.depth_termination);
      out.code_b = r.depth_iterations;
    }
  }

  void reset() override { cache_ = SimplexCache{}; }

 private:
  struct Query {
    const Shape<double>* a;
    Pose<double> pose_a;
    const Shape<double>* b;
    Pose<double> pose_b;
  };
  DistanceOptions<double> options_;
  bool warm_;
  SimplexCache cache_;
  std::map<std::pair<const void*, double>, Shape<double>> shapes_;
  std::vector<Query> queries_;
};

}  // namespace

std::unique_ptr<Runner> make_nearpoint_runner(std::span<const PairInput> inputs,
                                              const DistanceOptions<double>& options, bool warm,
                                              bool climb) {
  if (options.penetration_depth)
    return std::make_unique<NearpointRunner<true>>(inputs, options, warm, climb);
  return std::make_unique<NearpointRunner<false>>(inputs, options, warm, climb);
}

const char* to_string(Peer peer) {
  switch (peer) {
    case Peer::fcl_libccd:
      return "fcl_libccd";
    case Peer::fcl_indep:
      return "fcl_indep";
    case Peer::bullet:
      return "bullet";
    case Peer::ccd_intersect:
      return "ccd_intersect";
    case Peer::opengjk:
      return "opengjk";
    case Peer::coal:
      return "coal";
  }
  return "?";
}

const char* to_string(DepthPeer peer) {
  switch (peer) {
    case DepthPeer::coal:
      return "coal_epa";
    case DepthPeer::fcl_epa:
      return "fcl_libccd_epa";
    case DepthPeer::fcl_mpr:
      return "fcl_libccd_mpr";
    case DepthPeer::libccd_epa:
      return "libccd_epa";
    case DepthPeer::bullet:
      return "bullet_gjkepa2";
  }
  return "?";
}

const char* to_string(PrimitivePeer peer) {
  switch (peer) {
    case PrimitivePeer::fcl_libccd:
      return "fcl_libccd";
    case PrimitivePeer::fcl_indep:
      return "fcl_indep";
    case PrimitivePeer::coal_1e12:
      return "coal_1e-12";
    case PrimitivePeer::coal_1e6:
      return "coal_1e-6";
  }
  return "?";
}

}  // namespace nearpoint::bench
