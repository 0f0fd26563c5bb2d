// SPDX-License-Identifier: Apache-2.0
// The C++ side of the Python engine tests and benchmark (issue 34): the engine called directly on
// the very inputs the Python bindings get, so that Python results can be compared bit for bit.
//
//   engine_reference results CASES   every pair of CASES, all result fields, one line each (%a)
//   engine_reference time CASES REPS the engine's time per pair over CASES, REPS passes (ns)
//   engine_reference paper DRAWS     the paper's Section VII experiment (DRAWS poses per pair and
//                                    case) with CGAL's exact distances, for the oracle test
//
// CASES is text written by tests/python/engine_cases.py: an `options` line (keywords of
// nearpoint.distance that are on, and `cache K`: pair j warm-starts from cache j mod K — K = 1
// is one cache carried through the pairs in order, K = N the rows of a batch over calls), `shape`
// lines, then `pair A B POSE POSE` lines; a POSE is `m` and 16 numbers (a 4×4 matrix, row-major) or
// `q` and 7 (tx ty tz qw qx qy qz). Numbers are C99 hex floats (exact).
#include <algorithm>
#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "common/paper_family.hpp"
#include "nearpoint/distance.hpp"

namespace {

using nearpoint::DistanceOptions;
using nearpoint::DistanceResult;
using nearpoint::Pose;
using nearpoint::Shape;
using V3 = nearpoint::Vec3<double>;

struct Pair {
  int a = 0, b = 0;
  Pose<double> pose_a, pose_b;
};
struct Cases {
  DistanceOptions<double> options;
  std::size_t cache_rows = 0;  // 0: cold starts; K: pair j warm-starts from cache j mod K
  std::vector<Shape<double>> shapes;
  std::vector<Pair> pairs;
};

[[noreturn]] void fail(const std::string& why) {
  std::cerr << "engine_reference: " << why << "\n";
  std::exit(2);
}

double number(std::istream& in) {
  std::string token;
  if (!(in >> token)) fail("a number is missing");
  char* end = nullptr;
  const double v = std::strtod(token.c_str(), &end);  // reads hex floats exactly
  if (*end != '\0') fail("not a number: " + token);
  return v;
}
V3 vec(std::istream& in) {
  const double x = number(in), y = number(in);
  return V3(x, y, number(in));
}

// The same conversions as the bindings (client/python/src/engine.cpp): a matrix's rows as they
// are, a (7,) row through the engine's checked quaternion constructor.
Pose<double> pose(std::istream& in) {
  std::string kind;
  in >> kind;
  Pose<double> p;
  if (kind == "m") {
    double m[16];
    for (double& v : m) v = number(in);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) p.rotation(r, c) = m[4 * r + c];
      p.translation[r] = m[4 * r + 3];
    }
  } else if (kind == "q") {
    double v[7];
    for (double& x : v) x = number(in);
    if (const char* why = nearpoint::pose_from_quaternion_checked<double>(v[3], v[4], v[5], v[6],
                                                                          V3(v[0], v[1], v[2]), p))
      fail(why);
  } else {
    fail("unknown pose kind " + kind);
  }
  return p;
}

Shape<double> shape(std::istream& in) {
  std::string kind;
  in >> kind;
  if (kind == "box") {
    const V3 h = vec(in);
    return Shape<double>(nearpoint::Box<double>{h}, number(in));
  }
  if (kind == "sphere") return Shape<double>::sphere(number(in));
  if (kind == "capsule") {
    const V3 a = vec(in), b = vec(in);
    return Shape<double>::capsule(a, b, number(in));
  }
  if (kind == "cylinder" || kind == "cone") {
    const double r = number(in), h = number(in), rounding = number(in);
    if (kind == "cone") return Shape<double>(nearpoint::Cone<double>{r, h}, rounding);
    return Shape<double>(nearpoint::Cylinder<double>{r, h}, rounding);
  }
  if (kind == "ellipsoid") {
    const V3 radii = vec(in);
    return Shape<double>(nearpoint::Ellipsoid<double>{radii}, number(in));
  }
  if (kind == "polytope") {
    const double rounding = number(in);
    const int n = static_cast<int>(number(in));
    std::vector<V3> v(static_cast<std::size_t>(n));
    for (auto& p : v) p = vec(in);
    return Shape<double>(nearpoint::Polytope<double>(v), rounding);
  }
  fail("unknown shape kind " + kind);
}

Cases read_cases(const char* path) {
  std::ifstream file(path);
  if (!file) fail(std::string("cannot read ") + path);
  Cases cases;
  std::string line;
  while (std::getline(file, line)) {
    std::istringstream in(line);
    std::string head;
    if (!(in >> head)) continue;
    if (head == "options") {
      std::string word;
      auto& o = cases.options;
      while (in >> word) {
        if (word == "near_points")
          o.near_points = true;
        else if (word == "gradient")
          o.gradient = true;
        else if (word == "penetration_bound")
          o.penetration_bound = true;
        else if (word == "penetration_depth")
          o.penetration_depth = true;
        else if (word == "cache")
          in >> cases.cache_rows;
        else
          fail("unknown option " + word);
      }
    } else if (head == "shape") {
      cases.shapes.push_back(shape(in));
    } else if (head == "pair") {
      Pair p;
      in >> p.a >> p.b;
      p.pose_a = pose(in);
      p.pose_b = pose(in);
      cases.pairs.push_back(p);
    } else {
      fail("unknown line " + head);
    }
  }
  return cases;
}

// One result, every field, in the order tests/python/engine_cases.py writes the bindings' result.
void print(const DistanceResult<double>& r) {
  auto num = [](double v) { std::printf(" %a", v); };
  auto vec3 = [&](bool has, const V3& v) {
    if (!has) return (void)std::printf(" - - -");
    for (int k = 0; k < 3; ++k) num(v[k]);
  };
  auto opt = [&](bool has, double v) { has ? num(v) : (void)std::printf(" -"); };
  std::printf("%d", int(r.status));
  num(r.distance);
  num(r.error_bound);
  num(r.gap);
  num(r.diameter_bound);
  std::printf(" %d %d %d %d %d %d %d", r.iterations, r.support_calls, r.subalgorithm_runs,
              int(r.termination), int(r.warm_started), int(r.finished_by), r.simplex_size);
  for (int k = 0; k < r.simplex_size; ++k) {
    std::printf(" %d %d", int(r.index_a[k]), int(r.index_b[k]));
    num(r.weights[k]);
  }
  vec3(r.has_near_points, r.point_a);
  vec3(r.has_near_points, r.point_b);
  vec3(r.has_near_points, r.normal);
  opt(r.has_penetration_bound, r.penetration_bound);
  opt(r.has_signed_distance, r.signed_distance);
  opt(r.has_signed_distance, r.signed_distance_lower);
  opt(r.has_signed_distance, r.signed_distance_upper);
  const bool pd = r.has_penetration_depth;
  opt(pd, r.depth);
  opt(pd, r.depth_lower);
  opt(pd, r.depth_upper);
  vec3(pd, r.depth_point_a);
  vec3(pd, r.depth_point_b);
  vec3(pd, r.depth_direction);
  pd ? (void)std::printf(" %d", int(r.depth_termination)) : (void)std::printf(" -");
  std::printf(" %d", r.depth_iterations);
  for (int k = 0; k < 6; ++k) opt(r.has_gradient, r.gradient_a[k]);
  for (int k = 0; k < 6; ++k) opt(r.has_gradient, r.gradient_b[k]);
  std::printf("\n");
}

int results(const char* path) {
  const Cases cases = read_cases(path);
  std::vector<nearpoint::SimplexCache> caches(std::max<std::size_t>(cases.cache_rows, 1));
  for (std::size_t j = 0; j < cases.pairs.size(); ++j) {
    const Pair& p = cases.pairs[j];
    nearpoint::SimplexCache* cache = cases.cache_rows ? &caches[j % cases.cache_rows] : nullptr;
    print(nearpoint::distance(cases.shapes.at(p.a), p.pose_a, cases.shapes.at(p.b), p.pose_b,
                              cases.options, cache));
  }
  return 0;
}

// The engine alone on the same pairs the Python benchmark times: poses built beforehand (the
// bindings convert them in the loop, which is part of what the benchmark measures), no cache.
int time_pairs(const char* path, int reps) {
  const Cases cases = read_cases(path);
  double sink = 0;
  // One untimed pass: the scan dispatch, the caches and the face buffer warmed up.
  for (const Pair& p : cases.pairs)
    sink +=
        nearpoint::distance(cases.shapes[p.a], p.pose_a, cases.shapes[p.b], p.pose_b, cases.options)
            .distance;
  const auto start = std::chrono::steady_clock::now();
  for (int rep = 0; rep < reps; ++rep)
    for (const Pair& p : cases.pairs)
      sink += nearpoint::distance(cases.shapes[p.a], p.pose_a, cases.shapes[p.b], p.pose_b,
                                  cases.options)
                  .distance;
  const double ns =
      std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start).count();
  std::printf("%.3f %g\n", ns / (double(reps) * double(cases.pairs.size())), sink);
  return 0;
}

int paper(int draws) {
  using namespace nearpoint::testkit;
  PaperExperimentConfig config;
  config.poses_per_case = draws;
  for (const auto& poly : paper_polytopes()) {
    std::printf("polytope %d %zu", poly.number, poly.vertices->size());
    for (const auto& v : *poly.vertices) std::printf(" %a %a %a", v[0], v[1], v[2]);
    std::printf("\n");
  }
  for (const auto& e : paper_experiment(config)) {
    std::printf("example %s %d %d", to_string(e.kind), e.polytope_a, e.polytope_b);
    for (const auto* p : {&e.pose_a, &e.pose_b}) {
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) std::printf(" %a", p->rotation(r, c));
      for (int r = 0; r < 3; ++r) std::printf(" %a", p->translation[r]);
    }
    std::printf(" %a %d\n", e.exact.distance, int(e.exact.intersecting));
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "";
  if (mode == "results" && argc == 3) return results(argv[2]);
  if (mode == "time" && argc == 4) return time_pairs(argv[2], std::atoi(argv[3]));
  if (mode == "paper" && argc == 3) return paper(std::atoi(argv[2]));
  std::cerr << "usage: engine_reference results CASES | time CASES REPS | paper DRAWS\n";
  return 2;
}
