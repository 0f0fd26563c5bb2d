// SPDX-License-Identifier: Apache-2.0
// The 54 inputs an outside fuzzer found on 2026-12-03 whose answers lay outside their own error
// bound (tests/data/engine-findings/, one decoded input per file: shapes, poses, options and the
// answers of that day). Each is replayed as the fuzzer ran it — a cold query, a warm one with the
// cache it wrote, and for the "moved" findings the next pose with that cache — and every answer is
// held to the contract with no slack beyond `error_bound`:
//   - polytope-representable cores (points, segments, boxes, polytopes): |distance − truth| ≤
//     error_bound, the truth being CGAL's exact distance of the shapes posed exactly from the very
//     floats or doubles given (tests/common/exact_distance.hpp), minus the radii (eq. 8); a
//     `beyond_cutoff` answer is a certified lower bound: truth ∈ [distance, distance + bound];
//   - curved shapes: no support plane of the posed shapes (long double) proves more than
//     distance + error_bound;
//   - near points: |point_b − point_a| within the bound (plus 16 ulps of the points' own
//     coordinates) of the distance, and a normal that is unit or zero;
//   - a refused query leaves the warm-start cache it was given as it was, and says why.
// The mechanism each class exercises is in tests/data/engine-findings/README.md.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "common/exact_distance.hpp"
#include "nearpoint/distance.hpp"

namespace nearpoint {
namespace {

using LD = long double;

// ---- the file format ----

struct ShapeText {
  std::string kind;
  double radius = 0;
  std::vector<double> params;  // box half extents; cylinder/cone (r, h, –); radii
  std::vector<std::array<double, 3>> vertices;  // polytope, segment
  double rotation[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  double translation[3] = {0, 0, 0};
};

struct OptionsText {
  bool is_float = false;
  bool johnson = false, single_point = false, near_points = false, penetration_bound = false,
       gradient = false, origin_shift = true;
  double epsilon = 0, cutoff = 0;
  int max_iterations = 256;
};

struct Finding {
  std::string name;
  ShapeText a, b;                 // the first poses (cold, warm)
  ShapeText failed_a, failed_b;   // the failing query's poses (for "moved": the second pose)
  std::vector<OptionsText> runs;  // one per precision the fuzzer ran
  std::string failed_query;       // "cold<double>", "moved<float>", …; empty: the cache check
};

std::vector<double> numbers_in(const std::string& text) {
  std::vector<double> out;
  std::string token;
  for (char c : text + " ") {
    if (std::isdigit(static_cast<unsigned char>(c)) || c == '.' || c == 'e' || c == '-' ||
        c == '+' || c == 'i' || c == 'n' || c == 'f' || c == 'a') {
      token += c;
    } else if (!token.empty()) {
      out.push_back(std::strtod(token.c_str(), nullptr));
      token.clear();
    }
  }
  return out;
}

std::string value_of(const std::string& line, const std::string& key) {
  const std::size_t at = line.find(" " + key + "=");
  if (at == std::string::npos) return {};
  const std::size_t begin = at + key.size() + 2;
  return line.substr(begin, line.find(' ', begin) - begin);
}

Finding read_finding(const std::filesystem::path& path) {
  Finding f;
  f.name = path.filename().string();
  std::ifstream in(path);
  std::string line;
  ShapeText* shape = nullptr;
  bool after_failure = false;
  while (std::getline(in, line)) {
    const std::string trimmed = line.substr(std::min(line.find_first_not_of(' '), line.size()));
    if (trimmed.rfind("A: ", 0) == 0 || trimmed.rfind("B: ", 0) == 0) {
      shape = after_failure ? (trimmed[0] == 'A' ? &f.failed_a : &f.failed_b)
                            : (trimmed[0] == 'A' ? &f.a : &f.b);
      *shape = ShapeText{};
      std::istringstream words(trimmed.substr(3));
      words >> shape->kind;
      shape->radius = std::strtod(value_of(" " + trimmed, "radius").c_str(), nullptr);
      const std::size_t params = trimmed.find("params=");
      if (params != std::string::npos) shape->params = numbers_in(trimmed.substr(params + 7));
    } else if (shape && trimmed.rfind("vertices (", 0) == 0) {
      const std::vector<double> v = numbers_in(trimmed.substr(trimmed.find(':') + 1));
      for (std::size_t i = 0; i + 2 < v.size(); i += 3)
        shape->vertices.push_back({v[i], v[i + 1], v[i + 2]});
    } else if (shape && trimmed.rfind("rotation: ", 0) == 0) {
      const std::string matrix = trimmed.substr(10, trimmed.find("]]") - 10 + 2);
      const std::vector<double> v = numbers_in(matrix);
      for (int i = 0; i < 9; ++i) shape->rotation[i / 3][i % 3] = v.at(std::size_t(i));
    } else if (shape && trimmed.rfind("translation: ", 0) == 0) {
      const std::vector<double> v = numbers_in(trimmed.substr(13));
      for (int i = 0; i < 3; ++i) shape->translation[i] = v.at(std::size_t(i));
    } else if (trimmed.rfind("options<", 0) == 0) {
      OptionsText o;
      o.is_float = trimmed.rfind("options<float>", 0) == 0;
      const std::string l = " " + trimmed;
      o.johnson = value_of(l, "subalgorithm") == "johnson";
      o.single_point = value_of(l, "cold_start") == "single_point";
      o.near_points = value_of(l, "near_points") == "1";
      o.penetration_bound = value_of(l, "penetration_bound") == "1";
      o.gradient = value_of(l, "gradient") == "1";
      o.origin_shift = value_of(l, "origin_shift") == "1";
      o.epsilon = std::strtod(value_of(l, "epsilon").c_str(), nullptr);
      o.cutoff = std::strtod(value_of(l, "cutoff").c_str(), nullptr);
      o.max_iterations = std::atoi(value_of(l, "max_iterations").c_str());
      f.runs.push_back(o);
      shape = nullptr;
    } else if (trimmed.rfind("==== nearpoint invariant violated: ", 0) == 0) {
      after_failure = true;
      const std::string what = trimmed.substr(35);
      f.failed_query = what.find('<') != std::string::npos ? what.substr(0, what.find(':')) : "";
      shape = nullptr;
    } else if (trimmed.rfind("cold<", 0) == 0 || trimmed.rfind("warm<", 0) == 0 ||
               trimmed.rfind("moved<", 0) == 0) {
      shape = nullptr;
    }
  }
  if (!after_failure) {
    f.failed_a = f.a;
    f.failed_b = f.b;
  }
  return f;
}

// ---- shapes and poses in the precision of the run ----

template <class S>
Vec3<S> vec(const std::array<double, 3>& v) {
  return Vec3<S>(S(v[0]), S(v[1]), S(v[2]));
}

template <class S>
Pose<S> pose_of(const ShapeText& t) {
  Pose<S> p;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) p.rotation(i, j) = S(t.rotation[i][j]);
    p.translation[i] = S(t.translation[i]);
  }
  return p;
}

template <class S>
Shape<S> shape_of(const ShapeText& t) {
  const S r = S(t.radius);
  if (t.kind == "point") return Shape<S>(Point{}, r);
  if (t.kind == "segment")
    return Shape<S>(Segment<S>{vec<S>(t.vertices.at(0)), vec<S>(t.vertices.at(1))}, r);
  if (t.kind == "box")
    return Shape<S>(Box<S>{Vec3<S>(S(t.params.at(0)), S(t.params.at(1)), S(t.params.at(2)))}, r);
  if (t.kind == "cylinder") return Shape<S>(Cylinder<S>{S(t.params.at(0)), S(t.params.at(1))}, r);
  if (t.kind == "cone") return Shape<S>(Cone<S>{S(t.params.at(0)), S(t.params.at(1))}, r);
  if (t.kind == "ellipsoid")
    return Shape<S>(Ellipsoid<S>{Vec3<S>(S(t.params.at(0)), S(t.params.at(1)), S(t.params.at(2)))},
                    r);
  std::vector<Vec3<S>> v;
  for (const auto& x : t.vertices) v.push_back(vec<S>(x));
  return Shape<S>(Polytope<S>(v), r);
}

/// The core's vertices in the local frame, when the core is a polytope (point, segment, box,
/// polytope), exactly as the engine is given them.
template <class S>
std::optional<std::vector<Vec3<S>>> core_vertices(const ShapeText& t) {
  std::vector<Vec3<S>> v;
  if (t.kind == "point") {
    v.push_back(Vec3<S>::Zero());
  } else if (t.kind == "segment" || t.kind == "polytope") {
    for (const auto& x : t.vertices) v.push_back(vec<S>(x));
  } else if (t.kind == "box") {
    const Vec3<S> h(S(t.params.at(0)), S(t.params.at(1)), S(t.params.at(2)));
    for (int i = 0; i < 8; ++i)
      v.emplace_back(i & 1 ? h.x() : -h.x(), i & 2 ? h.y() : -h.y(), i & 4 ? h.z() : -h.z());
  } else {
    return std::nullopt;
  }
  return v;
}

/// h(u) = max over the posed shape of u·x, in long double, with a bound on its own rounding
/// (2^-60 of the magnitudes involved): the reference for curved shapes.
template <class S>
LD support_value(const ShapeText& t, const Pose<S>& pose, const Vec3<LD>& u, LD& rounding) {
  const Mat3<LD> r = pose.rotation.template cast<LD>();
  const Vec3<LD> p = pose.translation.template cast<LD>();
  const Vec3<LD> w = r.transpose() * u;  // the direction in the local frame
  LD local = 0, magnitude = 0;
  const auto params = [&](int i) { return LD(S(t.params.at(std::size_t(i)))); };
  if (t.kind == "cylinder") {
    local = params(0) * std::hypot(w.x(), w.y()) + params(1) * std::abs(w.z());
    magnitude = params(0) + params(1);
  } else if (t.kind == "cone") {
    local = std::max(params(1) * w.z(), -params(1) * w.z() + params(0) * std::hypot(w.x(), w.y()));
    magnitude = params(0) + params(1);
  } else if (t.kind == "ellipsoid") {
    local = Vec3<LD>(params(0) * w.x(), params(1) * w.y(), params(2) * w.z()).norm();
    magnitude = params(0) + params(1) + params(2);
  } else {
    local = -std::numeric_limits<LD>::infinity();
    const std::vector<Vec3<S>> vertices = core_vertices<S>(t).value();
    for (const Vec3<S>& v : vertices) {
      local = std::max(local, w.dot(v.template cast<LD>()));
      magnitude = std::max(magnitude, LD(v.template cast<LD>().norm()));
    }
  }
  const LD radius = LD(S(t.radius)) * u.norm();
  rounding = std::ldexp(LD(1), -60) * (magnitude + p.norm() + radius) * u.norm();
  return u.dot(p) + local + radius;
}

// ---- the contract ----

template <class S>
void check_answer(const DistanceResult<S>& r, const ShapeText& ta, const Pose<S>& pose_a,
                  const ShapeText& tb, const Pose<S>& pose_b, const SimplexCache& cache_before,
                  const SimplexCache& cache_after, const std::string& what) {
  if (r.status == Status::invalid_input) {
    ASSERT_NE(r.message, nullptr) << what;
    EXPECT_EQ(std::memcmp(&cache_before, &cache_after, sizeof(SimplexCache)), 0)
        << what << ": a refused query (" << r.message << ") changed the warm-start cache";
    return;
  }
  const LD d = r.distance, e = r.error_bound;
  ASSERT_TRUE(std::isfinite(d) && std::isfinite(e) && std::isfinite(LD(r.diameter_bound)))
      << what << ": distance " << d << ", bound " << e << ", D " << r.diameter_bound;
  ASSERT_GE(e, 0) << what;
  const std::string answer = what + ": " + to_string(r.status) + " by " + to_string(r.termination) +
                             ", distance " + std::to_string(double(d)) + " bound " + [&] {
                               std::ostringstream s;
                               s.precision(17);
                               s << double(d) << " ± " << double(e);
                               return s.str();
                             }();

  const auto va = core_vertices<S>(ta);
  const auto vb = core_vertices<S>(tb);
  const LD radii = LD(S(ta.radius)) + LD(S(tb.radius));
  if (va && vb) {
    const testkit::ExactDistance exact = testkit::exact_distance<S>(*va, pose_a, *vb, pose_b);
    const LD truth = std::max(LD(0), LD(exact.distance) - radii);
    // The exact core distance is rounded once to double: half an ulp of it is the reference's.
    const LD reference = LD(exact.distance) * LD(std::numeric_limits<double>::epsilon());
    std::ostringstream msg;
    msg.precision(17);
    msg << answer << "; truth " << double(truth) << ", off by " << double(std::abs(d - truth))
        << " = " << double(std::abs(d - truth) / e) << " x the bound";
    if (r.beyond_cutoff()) {
      EXPECT_GE(truth + reference, d) << msg.str() << " (beyond cutoff: distance is a lower bound)";
      EXPECT_LE(truth - reference, d + e) << msg.str();
    } else {
      EXPECT_LE(std::abs(d - truth) - reference, e) << msg.str();
    }
  } else {
    // Curved: support planes along the normal, the near points' difference, the axes.
    std::vector<Vec3<LD>> directions = {Vec3<LD>::UnitX(), Vec3<LD>::UnitY(), Vec3<LD>::UnitZ()};
    if (r.has_near_points) {
      directions.push_back(r.normal.template cast<LD>());
      directions.push_back((r.point_b - r.point_a).template cast<LD>());
    }
    for (Vec3<LD> u : directions) {
      for (LD sign : {LD(1), LD(-1)}) {
        const LD n = u.norm();
        if (!(n > 0)) continue;
        const Vec3<LD> unit = sign * u / n;
        LD ra = 0, rb = 0;
        const LD lower =
            -support_value<S>(tb, pose_b, -unit, rb) - support_value<S>(ta, pose_a, unit, ra);
        EXPECT_LE(lower - ra - rb, d + e) << answer << ": a support plane proves " << double(lower);
      }
    }
  }
  if (r.has_near_points) {
    const LD n = r.normal.template cast<LD>().norm();
    const LD unit_tolerance = 4 * LD(std::numeric_limits<S>::epsilon());
    EXPECT_TRUE(n == 0 || std::abs(n - 1) <= unit_tolerance)
        << answer << ": normal of length " << double(n);
    if (r.status == Status::separated) {
      const LD gap = (r.point_b - r.point_a).template cast<LD>().norm();
      const LD coordinates =
          std::max(r.point_a.cwiseAbs().maxCoeff(), r.point_b.cwiseAbs().maxCoeff());
      const LD roundoff = 16 * LD(std::numeric_limits<S>::epsilon()) * coordinates;
      EXPECT_LE(std::abs(gap - d), e + roundoff)
          << answer << ": |point_b - point_a| = " << double(gap);
    }
  }
}

template <class S>
void replay(const Finding& f, const OptionsText& o) {
  const std::string precision = o.is_float ? "<float>" : "<double>";
  DistanceOptions<S> options;
  options.subalgorithm = o.johnson ? Subalgorithm::johnson : Subalgorithm::signed_volumes;
  options.cold_start = o.single_point ? ColdStart::single_point : ColdStart::with_centroids;
  options.near_points = o.near_points;
  options.penetration_bound = o.penetration_bound;
  options.gradient = o.gradient;
  options.origin_shift = o.origin_shift;
  options.epsilon = S(o.epsilon);
  options.distance_cutoff = S(o.cutoff);
  options.max_iterations = o.max_iterations;

  const Shape<S> a = shape_of<S>(f.a), b = shape_of<S>(f.b);
  const Pose<S> pose_a = pose_of<S>(f.a), pose_b = pose_of<S>(f.b);
  SimplexCache cache{};
  for (const char* step : {"cold", "warm"}) {
    const SimplexCache before = cache;
    const DistanceResult<S> r = distance(a, pose_a, b, pose_b, options, &cache);
    check_answer(r, f.a, pose_a, f.b, pose_b, before, cache, f.name + " " + step + precision);
  }
  if (f.failed_query == "moved" + precision) {
    const Pose<S> moved_a = pose_of<S>(f.failed_a), moved_b = pose_of<S>(f.failed_b);
    const SimplexCache before = cache;
    const DistanceResult<S> r = distance(a, moved_a, b, moved_b, options, &cache);
    check_answer(r, f.a, moved_a, f.b, moved_b, before, cache, f.name + " moved" + precision);
    SimplexCache cold{};
    const DistanceResult<S> fresh = distance(a, moved_a, b, moved_b, options, &cold);
    check_answer(fresh, f.a, moved_a, f.b, moved_b, SimplexCache{}, cold,
                 f.name + " moved, cold" + precision);
  }
}

std::vector<std::filesystem::path> finding_files() {
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(NEARPOINT_FINDINGS_DIR))
    if (entry.path().extension() == ".txt") files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

class EngineFinding : public testing::TestWithParam<std::filesystem::path> {};

TEST_P(EngineFinding, EveryAnswerHoldsItsBound) {
  const Finding f = read_finding(GetParam());
  ASSERT_FALSE(f.runs.empty()) << f.name << ": no options line";
  for (const OptionsText& o : f.runs) {
    if (o.is_float)
      replay<float>(f, o);
    else
      replay<double>(f, o);
  }
}

// A sibling of E13: a segment modelled 2^127 from its local origin, 2^75 (one ulp there) long,
// placed back at the world origin by its pose, and a point 2^72 beyond its end along its axis.
// a + b = 2^128 + 2^75 rounds to 2^128, so the rounded centre is the end a itself, and the ends
// ±(b − a)/2 about it were both 2^74 off: the point looked inside the segment, a hundred million
// million times the bound (ulps of the length) away from the truth. Each end is now its own
// difference from the centre.
TEST(EngineFindings, ASegmentFarFromItsLocalOriginKeepsItsEnds) {
  const double end = std::ldexp(1.0, 127), ulp = std::ldexp(1.0, 75);
  const Vec3<double> a(end, 0, 0), b(end + ulp, 0, 0);
  Pose<double> placed;
  placed.translation = Vec3<double>(-end, 0, 0);
  Pose<double> beyond;
  beyond.translation = Vec3<double>(-std::ldexp(1.0, 72), 0, 0);
  for (const bool origin_shift : {true, false}) {
    DistanceOptions<double> options;
    options.origin_shift = origin_shift;
    options.near_points = true;
    SimplexCache cache{};
    const DistanceResult<double> r = distance(Shape<double>(Segment<double>{a, b}), placed,
                                              Shape<double>(Point{}), beyond, options, &cache);
    ShapeText segment, point;
    segment.kind = "segment";
    segment.vertices = {{a.x(), a.y(), a.z()}, {b.x(), b.y(), b.z()}};
    point.kind = "point";
    check_answer(r, segment, placed, point, beyond, SimplexCache{}, cache,
                 origin_shift ? "origin shift on" : "origin shift off");
  }
}

TEST(EngineFindings, AllFiftyFourAreHere) {
  EXPECT_EQ(finding_files().size(), 54u);
}

INSTANTIATE_TEST_SUITE_P(Outside2026_12_03, EngineFinding, testing::ValuesIn(finding_files()),
                         [](const testing::TestParamInfo<std::filesystem::path>& info) {
                           return info.param.stem().string().substr(0, 3);
                         });

}  // namespace
}  // namespace nearpoint
