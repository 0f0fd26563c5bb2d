// SPDX-License-Identifier: Apache-2.0
// The stiff and extreme suite: every named case × {Johnson, signed volumes} × {double, float},
// against CGAL's exact distance on the very inputs. Guards the promises of the numerical design:
// the right verdict, |d − d_exact| within the reported error bound and within a stated figure
// relative to the shapes' size (never to their distance from the origin), valid near points,
// finite outputs, and termination within the iteration cap with a truthful status.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <set>

#include "common/checks.hpp"
#include "common/exact_distance.hpp"
#include "nearpoint/distance.hpp"
#include "stiff/stiff_cases.hpp"

namespace nearpoint::stiff {
namespace {

const std::vector<StiffCase<double>>& cases_double() {
  static const std::vector<StiffCase<double>> cases = make_stiff_cases();
  return cases;
}
const std::vector<StiffCase<float>>& cases_float() {
  static const std::vector<StiffCase<float>> cases = to_float(cases_double());
  return cases;
}

/// The stated accuracy, relative to the shapes' size: the error must be below this × size as well
/// as below the reported bound. Double: 1e-14, about 50 ulps of the size (measured worst: 1.1e-15
/// on unit-size contacts, 7e-17 relative on the 1e4-size pair). Float: 5e-5, about 400 ulps
/// (measured worst: 3e-5 with Johnson's Δ's on a touching contact, 1e-6 with signed volumes).
template <class S>
double stated_relative_accuracy();
template <>
double stated_relative_accuracy<double>() {
  return 1e-14;
}
template <>
double stated_relative_accuracy<float>() {
  return 5e-5;
}

template <class S>
void check_case(const StiffCase<S>& c, Subalgorithm method) {
  const testkit::ExactDistance exact = testkit::exact_distance<S>(c.a, c.pose_a, c.b, c.pose_b);
  const double radii = double(c.radius_a) + double(c.radius_b);
  const double truth = std::max(0.0, exact.distance - radii);
  const bool truth_intersecting = exact.intersecting || exact.distance <= radii;

  DistanceOptions<S> options;
  options.subalgorithm = method;
  options.near_points = true;
  options.penetration_bound = true;
  const Shape<S> a(Polytope<S>(c.a), c.radius_a), b(Polytope<S>(c.b), c.radius_b);
  const DistanceResult<S> r = distance(a, c.pose_a, b, c.pose_b, options);

  // Finite outputs and a truthful, terminating run.
  ASSERT_NE(r.status, Status::invalid_input) << (r.message ? r.message : "");
  ASSERT_TRUE(std::isfinite(r.distance) && std::isfinite(r.error_bound) && std::isfinite(r.gap));
  ASSERT_TRUE(r.point_a.allFinite() && r.point_b.allFinite() && r.normal.allFinite());
  EXPECT_GE(r.distance, 0);
  EXPECT_LE(r.iterations, kDefaultMaxIterations);
  EXPECT_NE(r.status, Status::iteration_limit) << "polytopes end in finitely many steps";
  if (const char* why = testkit::cost_counters_violation(r, false))
    ADD_FAILURE() << why << ": " << r.support_calls << " support calls, " << r.subalgorithm_runs
                  << " subalgorithm runs, " << r.iterations << " iterations";

  const double error = std::abs(double(r.distance) - truth);
  const double bound = double(r.error_bound);
  const double stated = stated_relative_accuracy<S>() * c.size;
  std::printf("%-55s %-7s %-6s d=%-12.6g err=%-9.2e bound=%-9.2e it=%-3d %s %s\n", c.name.c_str(),
              method == Subalgorithm::johnson ? "johnson" : "sv",
              sizeof(S) == 8 ? "double" : "float", truth, error, bound, r.iterations,
              r.finished_by == FinishedBy::backup_procedure ? "BP" : "DS",
              to_string(r.termination));
  EXPECT_LE(error, bound) << "the certified bound must hold";
  EXPECT_LE(error, stated) << "the stated accuracy, relative to the shapes' size";

  // The verdict, wherever the truth is farther than the error bound from touching.
  if (truth > bound) {
    EXPECT_EQ(r.status, Status::separated);
  }
  if (c.deep_overlap) {
    EXPECT_TRUE(truth_intersecting) << "the generator meant this pair to overlap";
    EXPECT_EQ(r.status, Status::intersecting);
  }

  // Near points: each core point lies in its shape (support-value test in several directions),
  // and when separated |p_B − p_A| = d.
  const S eps = std::numeric_limits<S>::epsilon();
  const double slack =
      bound + 8.0 * double(eps) *
                  (c.pose_a.translation.norm() + c.pose_b.translation.norm() + c.size + radii);
  Vec3<S> core_a = r.point_a, core_b = r.point_b;
  // The near points sit on the rounded surfaces along the normal whenever the cores are apart.
  core_a -= c.radius_a * r.normal;
  core_b += c.radius_b * r.normal;
  if (r.status == Status::separated) {
    EXPECT_NEAR(double((r.point_b - r.point_a).norm()), double(r.distance), slack);
    EXPECT_NEAR(double(r.normal.norm()), 1.0, 1e-5);
  }
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<Vec3<long double>> directions = {{1, 0, 0},  {-1, 0, 0}, {0, 1, 0},
                                               {0, -1, 0}, {0, 0, 1},  {0, 0, -1}};
  if (r.normal.norm() > 0) {
    directions.push_back(r.normal.template cast<long double>());
    directions.push_back(-r.normal.template cast<long double>());
  }
  for (int i = 0; i < 8; ++i)
    directions.push_back(Vec3<long double>(normal(rng), normal(rng), normal(rng)).normalized());
  for (const Vec3<long double>& u : directions) {
    EXPECT_LE(double(u.dot(core_a.template cast<long double>()) -
                     testkit::support_value<S>(c.a, c.pose_a, u)),
              slack);
    EXPECT_LE(double(u.dot(core_b.template cast<long double>()) -
                     testkit::support_value<S>(c.b, c.pose_b, u)),
              slack);
  }

  // Penetration: d⁻ is a lower bound, so never negative; for rounded shapes whose cores are
  // apart it is the exact overlap r_A + r_B − d_core.
  if (r.status == Status::intersecting) {
    ASSERT_TRUE(r.has_penetration_bound);
    EXPECT_GE(r.penetration_bound, 0);
    if (!exact.intersecting) {
      EXPECT_NEAR(double(r.penetration_bound), radii - exact.distance, bound + stated);
    }
  }
}

struct Variant {
  std::size_t index;
  bool single;
  Subalgorithm method;
};

class Stiff : public ::testing::TestWithParam<Variant> {};

TEST_P(Stiff, Case) {
  const Variant v = GetParam();
  if (v.single)
    check_case(cases_float()[v.index], v.method);
  else
    check_case(cases_double()[v.index], v.method);
}

std::vector<Variant> all_variants() {
  std::vector<Variant> out;
  for (std::size_t i = 0; i < cases_double().size(); ++i)
    for (bool single : {false, true})
      for (Subalgorithm m : {Subalgorithm::johnson, Subalgorithm::signed_volumes})
        out.push_back({i, single, m});
  return out;
}

std::string variant_name(const ::testing::TestParamInfo<Variant>& info) {
  std::string name = cases_double()[info.param.index].name;
  for (char& ch : name)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  name += info.param.single ? "_float" : "_double";
  name += info.param.method == Subalgorithm::johnson ? "_johnson" : "_sv";
  return name;
}

INSTANTIATE_TEST_SUITE_P(Families, Stiff, ::testing::ValuesIn(all_variants()), variant_name);

// The suite must cover every family the issue names.
TEST(StiffSuite, CoversEveryFamily) {
  std::set<std::string> families;
  for (const auto& c : cases_double()) families.insert(c.family);
  for (const char* f : {"far", "scale", "thin", "contact", "degenerate", "large", "rounded"})
    EXPECT_TRUE(families.count(f)) << f;
}

}  // namespace
}  // namespace nearpoint::stiff
