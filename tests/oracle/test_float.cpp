// SPDX-License-Identifier: Apache-2.0
// The paper experiment in single precision: the engine instantiated with float, on a subset of the
// Section VII examples (10 poses per pair and case: 600 examples) converted to float, against the
// exact distance of the float inputs (the CGAL oracle evaluates R·v + t exactly from the float
// entries, so rounding the example to float changes the question, not the answer's exactness).
//
// What it guards: the Scalar = float instantiation of the whole query — the tolerance ε = 100·eps
// of eq. (35), the origin shift, the orthonormality tolerance for float rotations, the error bound.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <vector>

#include "common/checks.hpp"
#include "common/exact_distance.hpp"
#include "common/paper_family.hpp"
#include "nearpoint/distance.hpp"

namespace {

using nearpoint::DistanceOptions;
using nearpoint::DistanceResult;
using nearpoint::Polytope;
using nearpoint::Pose;
using nearpoint::Shape;
using nearpoint::Status;
using nearpoint::Vec3;
using nearpoint::testkit::FailureLog;
using nearpoint::testkit::format;
using nearpoint::testkit::PaperCase;
using nearpoint::testkit::PaperExample;

std::vector<Vec3<float>> to_float(const std::vector<Vec3<double>>& v) {
  std::vector<Vec3<float>> out;
  out.reserve(v.size());
  for (const auto& x : v) out.push_back(x.cast<float>());
  return out;
}

Pose<float> to_float(const Pose<double>& p) {
  Pose<float> out;
  out.rotation = p.rotation.cast<float>();
  out.translation = p.translation.cast<float>();
  return out;
}

// The accuracy asked of float: 1e-4 of the pair's size (the sum of the bounding radii, 2.5–7.5
// here), i.e. about 13 of float's 24 bits. Rounding alone moves support values by ~1e-6 at
// coordinates up to ~15 (1 ulp), so separated pairs should be good to a few 1e-6; near contact
// the distance is only determined to about √(g at its roundoff level), a few 1e-5 here. The
// bound leaves a factor of a few above that; it is the requirement, not an observation.
constexpr double kRelativeAccuracy = 1e-4;

TEST(Float, PaperExperimentSubset) {
  nearpoint::testkit::PaperExperimentConfig config;
  config.poses_per_case = 10;
  const std::vector<PaperExample> examples = nearpoint::testkit::paper_experiment(config);
  ASSERT_EQ(examples.size(), 600u);

  std::map<const void*, std::vector<Vec3<float>>> vertices;
  std::map<const void*, Shape<float>> shapes;
  for (const PaperExample& e : examples)
    for (const auto& v : {e.vertices_a, e.vertices_b})
      if (!vertices.count(v.get())) {
        vertices.emplace(v.get(), to_float(*v));
        shapes.emplace(v.get(), Shape<float>(Polytope<float>(vertices.at(v.get()))));
      }

  DistanceOptions<float> options;
  options.near_points = true;
  FailureLog failures;
  std::array<std::vector<double>, 3> errors, relative_errors, bounds;
  std::array<int, 3> bound_held{0, 0, 0};
  for (const PaperExample& e : examples) {
    const auto& va = vertices.at(e.vertices_a.get());
    const auto& vb = vertices.at(e.vertices_b.get());
    const Pose<float> pa = to_float(e.pose_a), pb = to_float(e.pose_b);
    const auto exact = nearpoint::testkit::exact_distance<float>(va, pa, vb, pb, e.exact.support_a,
                                                                 e.exact.support_b);
    const DistanceResult<float> r = nearpoint::distance(shapes.at(e.vertices_a.get()), pa,
                                                        shapes.at(e.vertices_b.get()), pb, options);
    const std::string where = format("pair %d (%d,%d) %s draw %d", e.pair + 1, e.polytope_a,
                                     e.polytope_b, nearpoint::testkit::to_string(e.kind), e.draw);
    const std::size_t c = std::size_t(e.kind);
    const double size = e.radius_a + e.radius_b;

    // The float examples are still what their case says: the separated gap (≥ 0.05) and the
    // overlap (≥ 10% of a radius) dwarf float rounding; touching stays within ~1e-6 of contact.
    if (e.kind == PaperCase::separated && !(exact.distance > 0))
      failures.add("sample: separated", where);
    if (e.kind == PaperCase::intersecting && !exact.intersecting)
      failures.add("sample: intersecting", where);
    if (e.kind == PaperCase::touching && !(exact.distance < 1e-5))
      failures.add("sample: touching", where);

    if (!nearpoint::testkit::all_finite(r)) failures.add("NaN or infinity", where);
    if (r.status == Status::invalid_input || r.status == Status::iteration_limit) {
      failures.add("status", where + " " + nearpoint::to_string(r.status));
      continue;
    }
    if (e.kind == PaperCase::separated && r.status != Status::separated)
      failures.add("verdict: separated", where);
    if (e.kind == PaperCase::intersecting && r.status != Status::intersecting)
      failures.add("verdict: intersecting", where);

    const double error = std::abs(double(r.distance) - exact.distance);
    errors[c].push_back(error);
    relative_errors[c].push_back(error / size);
    bounds[c].push_back(r.error_bound);
    bound_held[c] += error <= double(r.error_bound);
    // The error bound is certified in float too; 1e-6 (one float ulp at the largest coordinates,
    // ~15) is the floor below which the bound is not asked to account for rounding.
    if (!(error <= std::max(1e-6, double(r.error_bound))))
      failures.add("|d - d_exact| > max(1e-6, error_bound)",
                   format("%s d=%.9g exact=%.9g error=%.3g bound=%.3g", where.c_str(),
                          double(r.distance), exact.distance, error, double(r.error_bound)));
    if (!(error <= kRelativeAccuracy * size))
      failures.add("|d - d_exact| > 1e-4 of the pair's size",
                   format("%s d=%.9g exact=%.9g error=%.3g bound=%.3g", where.c_str(),
                          double(r.distance), exact.distance, error, double(r.error_bound)));

    // Near points in their hulls, to float rounding of coordinates up to ~15 (1e-5).
    if (r.has_near_points && r.status == Status::separated) {
      const double span = double((r.point_b - r.point_a).norm());
      if (!(std::abs(span - double(r.distance)) <= 1e-5))
        failures.add("|point_b - point_a| != d", where);
      const Vec3<long double> n = r.normal.cast<long double>();
      const long double out_a = n.dot(r.point_a.cast<long double>()) -
                                nearpoint::testkit::support_value<float>(va, pa, n);
      const long double out_b =
          -n.dot(r.point_b.cast<long double>()) -
          nearpoint::testkit::support_value<float>(vb, pb, Vec3<long double>(-n));
      if (!(out_a <= 1e-5 && out_b <= 1e-5)) failures.add("near point outside its hull", where);
    } else if (!r.has_near_points) {
      failures.add("no near points", where);
    }
  }

  std::printf("\nFloat (600 examples, bound: |d - d_exact| <= 1e-4 x (r_A + r_B)):\n");
  for (PaperCase kind : nearpoint::testkit::kPaperCases) {
    const std::size_t c = std::size_t(kind);
    std::printf(
        "  %-12s |d-d_exact| max %.3g median %.3g (relative to size: max %.3g)  error_bound "
        "max %.3g, held in %d/%zu\n",
        nearpoint::testkit::to_string(kind), nearpoint::testkit::maximum(errors[c]),
        nearpoint::testkit::median(errors[c]), nearpoint::testkit::maximum(relative_errors[c]),
        nearpoint::testkit::maximum(bounds[c]), bound_held[c], errors[c].size());
  }
  std::fflush(stdout);
  EXPECT_EQ(failures.total(), 0) << failures.report();
}

}  // namespace
