// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the engine (nearpoint::distance, single shapes and compounds) on arbitrary
// shapes, poses and radii, in double and in float, held to invariants that hold for every correct
// answer rather than to today's numbers. "True" is the distance of the shapes posed EXACTLY
// (world = R·v + t in exact arithmetic from the very Scalars given), and the bound must cover it
// with no slack at all:
//   - a refused query says why and leaves the warm-start cache it was given unchanged; an accepted
//     one has only finite outputs (D(K) included), distance ≥ 0, and distance 0 exactly when it
//     says intersecting; non-finite input is always refused;
//   - pieces with vertices (point, segment, box, polytope, each with a radius): an exact bracket
//     (tests/common/exact_bracket.hpp, CGAL::Gmpzf): the support-plane lower bound along the axes,
//     the centres' difference, the reported normal and near-point difference and fuzzed
//     directions must not exceed distance + error_bound, and the exact distance between the
//     points the reported simplex (indices and weights) stands for must not be below distance −
//     error_bound; on some inputs the exact distance is held to [lo, hi] (`oracle`): proven by
//     an exact support plane above lo and exact shape points within hi where those exist, else
//     by CGAL's exact distance itself. beyond_cutoff answers: see cutoff_interval();
//   - curved pieces (cylinder, cone, ellipsoid): the same lower bracket from support functions in
//     long double, with slack only for that reference's own rounding (2^-59 of the magnitudes);
//   - a penetration bound d⁻ must not exceed h_A(u) + h_B(−u); separated near points lie in their
//     shapes and are `distance` apart to within the error bound and 16 ulps of their own
//     coordinates; a reported normal is zero or unit to within a few ulps;
//   - cold, warm (same poses) and perturbed-warm (poses moved a little, against a cold start
//     there) answers agree: their intervals [distance ± error_bound] overlap.
// Inputs with bit 1 of the first byte and bit 7 of the flags byte set reach the generators of the
// outside fuzzer's findings (tests/fuzz/README.md): origin_shift off, cutoffs 0 and small,
// iteration caps, tiny scales, permutation and near-orthonormal rotations, far local coordinates
// cancelled by the pose, degenerate segments and polytopes. Without that bit the layout is the old
// one. The per-input work is bounded (at most 3 pieces per body, 12 vertices per polytope), so a
// libFuzzer timeout means a real hang.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "common/exact_bracket.hpp"
#include "fuzz_support.hpp"
#include "nearpoint/compound.hpp"
#include "nearpoint/distance.hpp"

namespace {

using namespace nearpoint;
using fuzz::ByteReader;
using LD = long double;
using V3L = Vec3<LD>;

constexpr int kMaxVertices = 12;
constexpr int kMaxPieces = 3;

// The interval a beyond_cutoff answer's true distance must lie in (NEARPOINT_FUZZ_CUTOFF_INTERVAL,
// a macro or an environment variable of that name, the latter winning):
//   1 (default): [distance, distance + error_bound]: `distance` is a certified lower bound above
//     the cutoff (DistanceResult::distance);
//   0: [distance − error_bound, distance + error_bound], the promise of every accepted answer;
//   2: [distance − error_bound, distance]: an upper bound, what the engine promised before.
enum class CutoffInterval { symmetric = 0, lower_bound = 1, upper_bound = 2 };
#ifndef NEARPOINT_FUZZ_CUTOFF_INTERVAL
#define NEARPOINT_FUZZ_CUTOFF_INTERVAL 1
#endif
CutoffInterval cutoff_interval() {
  static const CutoffInterval value = [] {
    const char* env = std::getenv("NEARPOINT_FUZZ_CUTOFF_INTERVAL");
    const int mode = env ? std::atoi(env) : NEARPOINT_FUZZ_CUTOFF_INTERVAL;
    return mode == 1   ? CutoffInterval::lower_bound
           : mode == 2 ? CutoffInterval::upper_bound
                       : CutoffInterval::symmetric;
  }();
  return value;
}

// A refused single-shape query must leave its warm-start cache as it was (checked always). For a
// compound query, whether a refusal may leave the per-pair caches of the pairs it evaluated before
// the refusing one is not settled in compound.hpp, and two saved regressions
// (compound-piece-at-1.8e308-non-finite-gradient, huge-coordinates-compound-infinite-near-point)
// do leave them changed on today's engine: off until core decides, then
// -DNEARPOINT_FUZZ_COMPOUND_CACHE_ON_REFUSAL=1.
#ifndef NEARPOINT_FUZZ_COMPOUND_CACHE_ON_REFUSAL
#define NEARPOINT_FUZZ_COMPOUND_CACHE_ON_REFUSAL 1
#endif
constexpr bool kCompoundRefusalKeepsCaches = NEARPOINT_FUZZ_COMPOUND_CACHE_ON_REFUSAL != 0;

// The curved-shape reference's own rounding: its long double evaluation of R·l + t and of the
// support functions errs by a few units of 2^-64 of the magnitudes involved (RefBody::magnitude);
// 32 units is what a check of curved pieces allows beyond the error bound, and nothing else.
constexpr long double kReferenceUlps = 32.0L / 18446744073709551616.0L;  // 32·2^-64
// A near point is rounded to Scalar by the engine: 16 ulps of its own coordinates (not of the
// scene's) is the slack of the near-point checks, as in the outside fuzzer.
constexpr int kNearPointUlps = 16;
// A unit normal rounded to Scalar: |‖n‖ − 1| stays within 3 ulps; 6 is "a few".
constexpr int kNormalUlps = 6;

template <class S>
struct Body {
  std::vector<Piece<S>> pieces;  // offset: piece frame → body frame
  Pose<S> pose;                  // body frame → world
  bool inputs_finite = true;
  // Every piece's core vertices as given (a polytope's as passed to its constructor, not as it
  // stores them), with radius and offset: the exact bracket's input. `vertex_only`: no curved
  // piece, so the exact bracket applies.
  std::vector<testkit::BracketPiece<S>> exact_pieces;
  bool vertex_only = true;
  bool far = false;        // generated with far local coordinates (for the survey's kinds)
  int rotation_kinds = 0;  // permutation/perturbed rotations (idem)
};

// How one body is generated beyond the plain layout (all off for inputs without flag bit 7).
template <class S>
struct Placement {
  int rotation = 0;  // 0: quaternion; 1: signed permutation; 2, 3: those, perturbed
  bool far = false;  // local coordinates offset by `far_offset`, cancelled by the pose
  Vec3<S> far_offset = Vec3<S>::Zero();
  int degenerate = -1;  // ≥ 0: repeat vertices (bit 0: all equal to the first)
};

template <class S>
bool finite(S x) {
  return std::isfinite(x);
}

template <class S>
Vec3<S> read_vec(ByteReader& in, int scale, bool& finite_flag) {
  Vec3<S> v(in.value<S>(scale), in.value<S>(scale), in.value<S>(scale));
  if (!v.allFinite()) finite_flag = false;
  return v;
}

// A non-negative parameter (extent, radius): most inputs should be usable, so take |x| unless the
// byte asks for the raw (possibly negative) value, which must then be refused.
template <class S>
S read_extent(ByteReader& in, int scale, bool& finite_flag) {
  const bool raw = (in.byte() & 15) == 0;
  const S x = in.value<S>(scale);
  if (!std::isfinite(x)) finite_flag = false;
  return raw ? x : std::abs(x);
}

// A signed permutation matrix of determinant +1 from one byte: the exact rotations (R·c is exact,
// so a far offset cancels exactly).
template <class S>
Mat3<S> permutation(std::uint8_t code) {
  static constexpr int perms[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1},
                                      {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
  const int p = (code >> 3) % 6;
  S sign[3] = {(code & 1) ? S(-1) : S(1), (code & 2) ? S(-1) : S(1), (code & 4) ? S(-1) : S(1)};
  const bool odd = p >= 3;
  if ((sign[0] * sign[1] * sign[2] < 0) != odd) sign[2] = -sign[2];
  Mat3<S> r = Mat3<S>::Zero();
  for (int i = 0; i < 3; ++i) r(i, perms[p][i]) = sign[i];
  return r;
}

template <class S>
Pose<S> read_pose(ByteReader& in, int scale, bool& finite_flag, const Placement<S>& place) {
  Pose<S> pose;
  if (place.rotation & 1) {
    pose.rotation = permutation<S>(in.byte());
  } else {
    // A rotation from a small-integer quaternion, normalised here in double (a zero one is the
    // identity): what a client's unit quaternion becomes.
    double q[4];
    for (double& c : q) c = double(std::int8_t(in.byte()));
    const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (n > 0)
      pose.rotation = Eigen::Quaternion<S>(S(q[0] / n), S(q[1] / n), S(q[2] / n), S(q[3] / n))
                          .normalized()
                          .toRotationMatrix();
  }
  if (place.rotation & 2) {
    // Near-orthonormal: + δ·M, M's entries in [-1, 1), δ = 2^-20 … 2^-30 in double (about the
    // accepted defect 1e-6 and below), 2^-14 … 2^-30 in float (1.2e-4 accepted).
    const int lo = std::is_same_v<S, float> ? 14 : 20;
    const S delta = std::ldexp(S(1), -(lo + in.byte() % (31 - lo)));
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) pose.rotation(i, j) += delta * S(std::int8_t(in.byte())) / S(128);
  }
  // Some translations on their own (far) scale: the far-from-origin cases. The full value range.
  const int t_scale = (in.byte() & 3) == 0 ? in.exponent<S>() : scale;
  pose.translation = read_vec<S>(in, t_scale, finite_flag);
  return pose;
}

// Local vertices offset by the body's far offset (rounded in Scalar: vertices much smaller than
// the offset collapse onto it, which is a degenerate shape of its own).
template <class S>
Vec3<S> local_vertex(ByteReader& in, int scale, bool& finite_flag, const Placement<S>& place) {
  const Vec3<S> v = read_vec<S>(in, scale, finite_flag);
  if (!place.far) return v;
  const Vec3<S> w = v + place.far_offset;
  if (!w.allFinite()) finite_flag = false;
  return w;
}

template <class S>
Shape<S> read_shape(ByteReader& in, int scale, bool& finite_flag, const Placement<S>& place,
                    std::vector<Vec3<S>>& given) {
  Shape<S> shape;
  given.clear();
  switch (in.byte() % 7) {
    case 0:
      shape.geometry = Point{};
      break;
    // Finiteness is judged on the final parameters: a degenerate shape overwrites some of those
    // read (`ignored`: the reads' own verdict).
    case 1: {
      bool ignored = true;
      Segment<S> segment;
      segment.a = local_vertex(in, scale, ignored, place);
      segment.b = local_vertex(in, scale, ignored, place);
      if (place.degenerate >= 0) segment.b = segment.a;
      if (!segment.a.allFinite() || !segment.b.allFinite()) finite_flag = false;
      shape.geometry = segment;
      break;
    }
    case 2: {
      bool ignored = true;
      Box<S> box;
      for (int k = 0; k < 3; ++k) box.half_extents[k] = read_extent<S>(in, scale, ignored);
      if (place.degenerate >= 0)  // flat boxes: the bits say which extents are 0
        for (int k = 0; k < 3; ++k)
          if (place.degenerate & (2 << k)) box.half_extents[k] = 0;
      if (!box.half_extents.allFinite()) finite_flag = false;
      shape.geometry = box;
      break;
    }
    case 3: {
      bool ignored = true;
      const int n = in.byte() % (kMaxVertices + 1);  // 0: an empty polytope, to be refused
      for (int i = 0; i < n; ++i) given.push_back(local_vertex(in, scale, ignored, place));
      if (place.degenerate >= 0)  // repeated vertices, or all equal
        for (int i = 1; i < n; ++i)
          if ((place.degenerate & 1) || (place.degenerate & (2 << (i % 7))))
            given[std::size_t(i)] = given[std::size_t((place.degenerate & 1) ? 0 : i - 1)];
      for (const Vec3<S>& v : given)
        if (!v.allFinite()) finite_flag = false;
      if (n == 0) finite_flag = false;  // not finite input, but equally must be refused
      shape.geometry = Polytope<S>(given);
      break;
    }
    case 4:
      shape.geometry = Cylinder<S>{read_extent<S>(in, scale, finite_flag),
                                   read_extent<S>(in, scale, finite_flag)};
      break;
    case 5:
      shape.geometry =
          Cone<S>{read_extent<S>(in, scale, finite_flag), read_extent<S>(in, scale, finite_flag)};
      break;
    default: {
      Ellipsoid<S> e;
      for (int k = 0; k < 3; ++k) e.radii[k] = read_extent<S>(in, scale, finite_flag);
      shape.geometry = e;
      break;
    }
  }
  shape.radius = (in.byte() & 1) ? read_extent<S>(in, scale, finite_flag) : S(0);
  return shape;
}

// ---- the reference: support functions in long double, from the shapes' definitions ----
// Plain scalar code rather than Eigen expressions: it runs for every input, and in a coverage-
// instrumented build each of Eigen's small loops costs a comparison callback.

struct P3 {
  LD x = 0, y = 0, z = 0;
};
inline LD dot(const P3& a, const P3& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
inline LD norm(const P3& a) {
  return std::sqrt(dot(a, a));
}
inline P3 operator-(const P3& a, const P3& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
inline P3 operator*(LD k, const P3& a) {
  return {k * a.x, k * a.y, k * a.z};
}
template <class S>
P3 p3(const Vec3<S>& v) {
  return {LD(v.x()), LD(v.y()), LD(v.z())};
}

// One piece placed in the world by its object's pose and its offset, composed in long double
// (not in Scalar: the engine composes piece poses relative to A's frame, so pieces whose world
// coordinates overflow Scalar are answered, and a world-frame composition in Scalar would give
// this reference infinities; fuzz_engine found float pieces at ±2·FLT_MAX that are 0.0017
// apart): vertex shapes as their world vertices, smooth ones by their parameters and frame.
// h(u) = h_core(u) + r|u|.
struct RefPiece {
  enum Kind { vertices, cylinder, cone, ellipsoid } kind = vertices;
  std::vector<P3> world;  // vertex shapes: R·v + t
  LD rot[9] = {};         // smooth shapes: R (row-major) and t
  P3 t;
  LD p0 = 0, p1 = 0, p2 = 0;  // cylinder/cone: radius, half height; ellipsoid: radii
  LD radius = 0;

  /// R·l + t: a point of the piece's frame in the world.
  P3 to_world(const P3& l) const {
    return {rot[0] * l.x + rot[1] * l.y + rot[2] * l.z + t.x,
            rot[3] * l.x + rot[4] * l.y + rot[5] * l.z + t.y,
            rot[6] * l.x + rot[7] * l.y + rot[8] * l.z + t.z};
  }

  LD support(const P3& u) const {
    LD h;
    if (kind == vertices) {
      h = -std::numeric_limits<LD>::infinity();
      for (const P3& w : world) h = std::max(h, dot(u, w));
    } else {
      const P3 l{rot[0] * u.x + rot[3] * u.y + rot[6] * u.z,
                 rot[1] * u.x + rot[4] * u.y + rot[7] * u.z,
                 rot[2] * u.x + rot[5] * u.y + rot[8] * u.z};  // Rᵀu
      const LD radial = std::sqrt(l.x * l.x + l.y * l.y);
      if (kind == cylinder)
        h = p0 * radial + p1 * std::abs(l.z);
      else if (kind == cone)
        h = std::max(p1 * l.z, -p1 * l.z + p0 * radial);
      else
        h = std::sqrt((p0 * l.x) * (p0 * l.x) + (p1 * l.y) * (p1 * l.y) + (p2 * l.z) * (p2 * l.z));
      h += dot(u, t);
    }
    return h + radius * norm(u);
  }
};

// `vertices`: the core's vertices as given (empty for a curved shape).
template <class S>
RefPiece reference_piece(const Shape<S>& shape, const std::vector<Vec3<S>>& vertices,
                         const Pose<S>& pose, const Pose<S>& offset) {
  RefPiece out;
  out.radius = shape.radius;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k)
        out.rot[3 * r + c] += LD(pose.rotation(r, k)) * LD(offset.rotation(k, c));
  const P3 o = p3(offset.translation);
  const auto moved = [&](int r) {  // row r of R_pose·o + t_pose
    return LD(pose.rotation(r, 0)) * o.x + LD(pose.rotation(r, 1)) * o.y +
           LD(pose.rotation(r, 2)) * o.z + LD(pose.translation(r));
  };
  out.t = {moved(0), moved(1), moved(2)};
  for (const Vec3<S>& v : vertices) out.world.push_back(out.to_world(p3(v)));
  std::visit(
      [&](const auto& g) {
        using G = std::decay_t<decltype(g)>;
        if constexpr (std::is_same_v<G, Cylinder<S>>) {
          out.kind = RefPiece::cylinder;
          out.p0 = g.radius;
          out.p1 = g.half_height;
        } else if constexpr (std::is_same_v<G, Cone<S>>) {
          out.kind = RefPiece::cone;
          out.p0 = g.radius;
          out.p1 = g.half_height;
        } else if constexpr (std::is_same_v<G, Ellipsoid<S>>) {
          out.kind = RefPiece::ellipsoid;
          out.p0 = g.radii.x();
          out.p1 = g.radii.y();
          out.p2 = g.radii.z();
        }
      },
      shape.geometry);
  return out;
}

template <class S>
Pose<S> piece_pose(const Body<S>& body, std::size_t i) {
  return body.pose.compose(body.pieces[i].offset);
}

// A body's pieces for the reference, and h of their union (of its convex hull: what a bracket
// can see), and a magnitude bounding every coordinate the engine handled for the body: a few ulps
// of it is the rounding a correct answer may carry beyond its error bound in world coordinates.
struct RefBody {
  std::vector<RefPiece> pieces;
  LD magnitude = 0;
  P3 centre_sum;

  LD support(const P3& u) const {
    LD best = -std::numeric_limits<LD>::infinity();
    for (const RefPiece& p : pieces) best = std::max(best, p.support(u));
    return best;
  }
};

template <class S>
RefBody reference_body(const Body<S>& body) {
  RefBody out;
  for (std::size_t i = 0; i < body.pieces.size(); ++i) {
    const Shape<S>& s = body.pieces[i].shape;
    const RefPiece& piece = out.pieces.emplace_back(
        reference_piece(s, body.exact_pieces[i].vertices, body.pose, body.pieces[i].offset));
    const P3 z = p3(core_center(s));
    const P3 c = piece.to_world(z);
    out.centre_sum = {out.centre_sum.x + c.x, out.centre_sum.y + c.y, out.centre_sum.z + c.z};
    out.magnitude =
        std::max(out.magnitude, norm(piece.t) + norm(z) + LD(core_extent(s)) + LD(s.radius));
    for (const Vec3<S>& v : body.exact_pieces[i].vertices)  // as given (see Body)
      out.magnitude = std::max(out.magnitude, norm(piece.t) + norm(p3(v)) + LD(s.radius));
    out.magnitude = std::max(out.magnitude, norm(p3(body.pieces[i].offset.translation)) +
                                                norm(p3(body.pose.translation)));
  }
  return out;
}

template <class S>
std::string describe(const DistanceResult<S>& r) {
  std::ostringstream out;
  out.precision(17);
  out << "status " << to_string(r.status) << ", termination " << to_string(r.termination)
      << ", distance " << r.distance << ", error_bound " << r.error_bound << ", iterations "
      << r.iterations << ", warm " << r.warm_started << ", gap " << r.gap << ", diameter_bound "
      << r.diameter_bound;
  if (r.has_near_points)
    out << ", point_a (" << r.point_a.transpose() << "), point_b (" << r.point_b.transpose()
        << "), normal (" << r.normal.transpose() << ")";
  if (r.has_penetration_bound) out << ", penetration_bound " << r.penetration_bound;
  if (r.message) out << ", message " << r.message;
  return out.str();
}

// The input as read, for NEARPOINT_FUZZ_VERBOSE: enough to rebuild a finding as a unit test.
template <class S>
std::string describe(const Body<S>& body) {
  std::ostringstream out;
  out.precision(17);
  const auto vec = [&](const Vec3<S>& v) { out << '(' << v.transpose() << ')'; };
  for (std::size_t p = 0; p < body.pieces.size(); ++p) {
    const Piece<S>& piece = body.pieces[p];
    std::visit(
        [&](const auto& g) {
          using G = std::decay_t<decltype(g)>;
          if constexpr (std::is_same_v<G, Point>) {
            out << "point";
          } else if constexpr (std::is_same_v<G, Segment<S>>) {
            out << "segment ";
            vec(g.a);
            vec(g.b);
          } else if constexpr (std::is_same_v<G, Box<S>>) {
            out << "box ";
            vec(g.half_extents);
          } else if constexpr (std::is_same_v<G, Polytope<S>>) {
            out << "polytope";
            for (const Vec3<S>& v : body.exact_pieces[p].vertices) {  // as given
              out << ' ';
              vec(v);
            }
          } else if constexpr (std::is_same_v<G, Cylinder<S>>) {
            out << "cylinder r " << g.radius << " h " << g.half_height;
          } else if constexpr (std::is_same_v<G, Cone<S>>) {
            out << "cone r " << g.radius << " h " << g.half_height;
          } else {
            out << "ellipsoid ";
            vec(g.radii);
          }
        },
        piece.shape.geometry);
    out << " radius " << piece.shape.radius << " offset R ("
        << piece.offset.rotation.reshaped().transpose() << ") t ";
    vec(piece.offset.translation);
    out << "; ";
  }
  out << "pose R (" << body.pose.rotation.reshaped().transpose() << ") t ";
  vec(body.pose.translation);
  return out.str();
}

template <class S>
bool result_finite(const DistanceResult<S>& r) {
  return finite(r.distance) && finite(r.error_bound) && finite(r.gap) && finite(r.diameter_bound) &&
         r.point_a.allFinite() && r.point_b.allFinite() && r.normal.allFinite() &&
         finite(r.penetration_bound) && r.gradient_a.allFinite() && r.gradient_b.allFinite() &&
         std::all_of(r.weights, r.weights + 4, finite<S>);
}

// The exact bracket of a pair of bodies, built on first use (only for accepted answers: its
// input must be finite) and shared by the answers for the same poses.
template <class S>
struct ExactPair {
  const Body<S>& a;
  const Body<S>& b;
  std::unique_ptr<testkit::ExactBracket> bracket;
  const testkit::ExactBracket* get() {
    if (!bracket && a.vertex_only && b.vertex_only)
      bracket =
          std::make_unique<testkit::ExactBracket>(a.exact_pieces, a.pose, b.exact_pieces, b.pose);
    return bracket.get();
  }
};

// How often the oracle needed CGAL's QP (NEARPOINT_FUZZ_ORACLE_STATS=1 prints it at exit): the
// witnesses should settle nearly every answer, and a QP on long exact coordinates is what can
// run past a timeout.
struct OracleStats {
  long answers = 0, qp_answers = 0, qp_pairs = 0;
  void record(int pairs) {
    ++answers;
    qp_answers += pairs > 0;
    qp_pairs += pairs;
  }
};
OracleStats& oracle_stats() {
  static OracleStats* s = [] {
    auto* out = new OracleStats;
    if (std::getenv("NEARPOINT_FUZZ_ORACLE_STATS"))
      std::atexit([] {
        const OracleStats& o = oracle_stats();
        std::fprintf(stderr,
                     "oracle: %ld answers past both witnesses' first try, %ld settled per piece "
                     "pair, %ld needed the QP (%ld piece pairs)\n",
                     o.answers, o.answers - o.qp_answers, o.qp_answers, o.qp_pairs);
      });
    return out;
  }();
  return *s;
}

std::string number(long double x) {
  std::ostringstream out;
  out.precision(20);
  out << x;
  return out.str();
}

// Checks one answer for bodies a and b against the invariants above. `piece_a`/`piece_b`: the
// pieces the near points and the simplex are on (compounds; −1: none named), 0 for single shapes.
// `oracle`: also compare with CGAL's exact distance (vertex pieces only; about a millisecond per
// piece pair).
template <class S>
void check_result(const DistanceResult<S>& r, ExactPair<S>& pair, int piece_a, int piece_b,
                  const std::vector<V3L>& extra_directions, bool oracle, const char* what) {
  const Body<S>& a = pair.a;
  const Body<S>& b = pair.b;
  // Built only for a message: the checks run millions of times.
  const auto where = [&] { return std::string(what) + ": " + describe(r); };
  // NEARPOINT_FUZZ_VERBOSE=1: print every answer (to see what a seed or a finding does).
  static const bool verbose = std::getenv("NEARPOINT_FUZZ_VERBOSE") != nullptr;
  if (verbose)
    std::fprintf(stderr, "%s\n  A: %s\n  B: %s\n", where().c_str(), describe(a).c_str(),
                 describe(b).c_str());
  const bool inputs_finite = a.inputs_finite && b.inputs_finite;
  if (r.status == Status::invalid_input) {
    NEARPOINT_FUZZ_CHECK(r.message != nullptr && *r.message != '\0',
                         "a refused query must say why; " + where());
    return;
  }
  NEARPOINT_FUZZ_CHECK(inputs_finite,
                       "non-finite (or empty) input accepted instead of refused; " + where());
  NEARPOINT_FUZZ_CHECK(
      result_finite(r),
      "non-finite output of an accepted query (diameter_bound included); " + where());
  NEARPOINT_FUZZ_CHECK(r.distance >= 0 && r.error_bound >= 0 && r.gap >= 0,
                       "negative distance, error bound or gap; " + where());
  NEARPOINT_FUZZ_CHECK(r.in_contact() == (r.distance == 0) || r.status == Status::iteration_limit,
                       "distance 0 if and only if intersecting or touching; " + where());
  const LD eps = LD(std::numeric_limits<S>::epsilon());
  if (r.has_near_points) {
    const LD n = norm(p3(r.normal));
    NEARPOINT_FUZZ_CHECK(n == 0 || std::abs(n - 1) <= kNormalUlps * eps,
                         "normal neither zero nor unit (|n| = " + number(n) + "); " + where());
  }

  // Where the true distance must lie: [lo, hi], as exact sums of the answer's own numbers.
  const double d = r.distance, e = r.error_bound;
  const bool beyond = r.beyond_cutoff();
  const CutoffInterval mode = beyond ? cutoff_interval() : CutoffInterval::symmetric;
  const testkit::ExactSum lo =
      mode == CutoffInterval::lower_bound ? testkit::ExactSum{d} : testkit::ExactSum{d, -e};
  const testkit::ExactSum hi =
      mode == CutoffInterval::upper_bound ? testkit::ExactSum{d} : testkit::ExactSum{d, e};
  const char* interval =
      mode == CutoffInterval::lower_bound   ? "[distance, distance + error_bound] (beyond_cutoff)"
      : mode == CutoffInterval::upper_bound ? "[distance - error_bound, distance] (beyond_cutoff)"
                                            : "[distance - error_bound, distance + error_bound]";

  const RefBody ra = reference_body(a), rb = reference_body(b);
  // The curved reference's own rounding (long double), nothing of Scalar's.
  const LD ref_slack = kReferenceUlps * (ra.magnitude + rb.magnitude);
  const testkit::ExactBracket* exact = pair.get();
  if (verbose && exact)  // the truth, for reading a finding (CGAL's QP: slow, verbose runs only)
    std::fprintf(stderr, "  exact distance (CGAL): %s\n",
                 number(exact->truth({0}, {0}).approx).c_str());

  // The bracket's own closest point on the reported simplex (weights and direction computed
  // without the engine's subalgorithm): a near-optimal direction for the lower witness and
  // weights for the upper one, where the answer's own are too coarse (float weights, a normal
  // from an early stop) to prove a tight interval.
  double own_weights[4] = {0, 0, 0, 0}, own_direction[3] = {0, 0, 0};
  const bool own_simplex = exact && r.simplex_size > 0 && piece_a >= 0 && piece_b >= 0 &&
                           exact->closest_on_simplex(piece_a, piece_b, r.simplex_size, r.index_a,
                                                     r.index_b, own_weights, own_direction);

  std::vector<P3> directions;
  if (own_simplex) directions.push_back({own_direction[0], own_direction[1], own_direction[2]});
  for (const V3L& u : extra_directions) directions.push_back({u.x(), u.y(), u.z()});
  directions.push_back({1, 0, 0});
  directions.push_back({0, 1, 0});
  directions.push_back({0, 0, 1});
  directions.push_back(rb.centre_sum - ra.centre_sum);
  if (r.has_near_points) {
    directions.push_back(p3(r.normal));
    directions.push_back(p3(r.point_b) - p3(r.point_a));
  }
  if (r.has_penetration_depth) directions.push_back(p3(r.depth_direction));
  for (P3& u : directions) {  // unit length, or dropped
    const LD n = norm(u);
    u = (n > 0 && std::isfinite(n)) ? (1 / n) * u : P3{};
  }
  const auto as_double = [](const P3& u, double out[3]) {
    out[0] = double(u.x);
    out[1] = double(u.y);
    out[2] = double(u.z);
  };

  // Single shapes: the hulls are the shapes, so d⁻ ≤ depth ≤ h_A(u) + h_B(−u) holds for every u.
  // (Compounds: d⁻ is the largest over intersecting piece pairs; not checked here.)
  LD depth_upper = std::numeric_limits<LD>::infinity();
  // The oracle's lower half, witnessed without the QP: a direction whose exact support-plane
  // bound is above lo proves the true distance is too (see the oracle below).
  bool lo_witnessed = false;
  for (const P3& u : directions) {
    if (dot(u, u) == 0) continue;
    const LD ha = ra.support(u), hb = rb.support(-1 * u);
    if (exact) {
      // The true distance is at least the exact support-plane bound: it must not exceed hi.
      double ud[3], bound = 0;
      as_double(u, ud);
      if (!exact->lower_at_most(ud, hi, &bound))
        fuzz::fail(__FILE__, __LINE__,
                   "the exact separating-plane bound " + number(bound) + " along (" +
                       number(ud[0]) + " " + number(ud[1]) + " " + number(ud[2]) + ") is above " +
                       interval + ", no slack; " + where());
      if (oracle && !lo_witnessed) lo_witnessed = !exact->lower_at_most(ud, lo);
    } else {
      const LD lower = std::max(LD(0), -hb - ha);  // ≤ the distance between the hulls
      const LD top = hi.count == 2 ? LD(d) + LD(e) : LD(d);
      if (!(lower <= top + ref_slack))
        fuzz::fail(__FILE__, __LINE__,
                   "the separating-plane bracket " + number(lower) + " along (" + number(u.x) +
                       " " + number(u.y) + " " + number(u.z) + ") is above " + interval +
                       " (reference slack " + number(ref_slack) + "); " + where());
    }
    if (a.pieces.size() == 1 && b.pieces.size() == 1) depth_upper = std::min(depth_upper, ha + hb);
  }
  // d⁻ is not part of the distance's promise and is rounded in Scalar: its check keeps the old
  // slack of 16 ulps of the scene's magnitudes.
  const LD depth_slack =
      16 * eps * (ra.magnitude + rb.magnitude) + LD(std::numeric_limits<S>::denorm_min());
  if (r.has_penetration_bound && r.in_contact() && std::isfinite(depth_upper)) {
    if (!(LD(r.penetration_bound) >= 0 &&
          LD(r.penetration_bound) <= depth_upper + LD(e) + depth_slack + ref_slack))
      fuzz::fail(__FILE__, __LINE__,
                 "penetration bound " + number(r.penetration_bound) +
                     " exceeds the depth upper bound " + number(depth_upper) + "; " + where());
  }

  // The signed distance and depth (penetration_depth): ordered intervals holding their
  // estimates, the verdict the interval's sign, and the depth's lower end against an independent
  // upper bracket: for single shapes the true depth is at most h_A(u) + h_B(−u) for every unit u
  // (moving B that far along u separates them; below 0 the shapes are apart and the depth is 0),
  // the answer's own direction among the u tried.
  if (r.has_signed_distance) {
    NEARPOINT_FUZZ_CHECK(r.signed_distance_lower <= r.signed_distance &&
                             r.signed_distance <= r.signed_distance_upper &&
                             r.depth_lower <= r.depth && r.depth <= r.depth_upper &&
                             r.depth_lower >= 0,
                         "signed distance or depth outside its own interval; " + where());
    NEARPOINT_FUZZ_CHECK(r.status != Status::separated || r.signed_distance_lower >= 0,
                         "separated with a signed-distance interval reaching below 0; " + where());
    NEARPOINT_FUZZ_CHECK(r.status != Status::touching ||
                             (r.signed_distance_lower <= 0 && r.signed_distance_upper >= 0),
                         "touching with a signed-distance interval off 0; " + where());
    NEARPOINT_FUZZ_CHECK(r.status != Status::intersecting || r.depth_upper > 0,
                         "intersecting with no depth; " + where());
    const LD unit = r.has_penetration_depth ? norm(p3(r.depth_direction)) : LD(1);
    NEARPOINT_FUZZ_CHECK(unit == 0 || std::abs(unit - 1) <= kNormalUlps * eps,
                         "depth direction neither zero nor unit; " + where());
    if (r.in_contact() && std::isfinite(depth_upper) &&
        !(LD(r.depth_lower) <=
          std::max(LD(0), depth_upper) + ref_slack + LD(std::numeric_limits<S>::denorm_min())))
      fuzz::fail(__FILE__, __LINE__,
                 "depth lower end " + number(r.depth_lower) +
                     " above the support bracket of the true depth " + number(depth_upper) + "; " +
                     where());
  }

  // The oracle's upper half, witnessed without the QP: points of the shapes less than hi apart.
  bool hi_witnessed = false;
  if (exact && r.simplex_size > 0 && piece_a >= 0 && piece_b >= 0) {
    // The points the final simplex stands for lie in the shapes, so their exact distance (radii
    // off) is at least the true distance: it must not be below lo.
    double w[4];
    for (int k = 0; k < 4; ++k) w[k] = double(r.weights[k]);
    double upper = 0;
    const auto verdict = exact->upper_at_least(piece_a, piece_b, r.simplex_size, r.index_a,
                                               r.index_b, w, lo, &upper);
    NEARPOINT_FUZZ_CHECK(verdict != testkit::ExactBracket::Upper::out_of_range,
                         "a simplex index is not a vertex of its shape; " + where());
    if (verdict == testkit::ExactBracket::Upper::fails)
      fuzz::fail(__FILE__, __LINE__,
                 "the exact distance " + number(upper) + " between the simplex's points is below " +
                     interval + ", no slack; " + where());
    if (oracle)
      hi_witnessed = exact->upper_at_least(piece_a, piece_b, r.simplex_size, r.index_a, r.index_b,
                                           w, hi) == testkit::ExactBracket::Upper::fails;
    if (oracle && !hi_witnessed && own_simplex)
      hi_witnessed = exact->upper_at_least(piece_a, piece_b, r.simplex_size, r.index_a, r.index_b,
                                           own_weights, hi) == testkit::ExactBracket::Upper::fails;
  }
  // CGAL's exact distance, unless both halves are already witnessed exactly: then lo ≤ truth ≤ hi
  // is proven and the QP could add nothing. Its cost grows with the bit length of the exact
  // world coordinates (far local coordinates cancelled by the pose make them thousands of bits
  // long, and one such QP ran for over ten minutes), so it runs only where a witness is missing.
  if (exact && oracle && !(lo_witnessed && hi_witnessed)) {
    // Piece pair by piece pair: a pair whose own support plane is above lo needs no QP either.
    std::vector<std::array<double, 3>> tried;
    for (const P3& u : directions)
      if (dot(u, u) != 0) tried.push_back({double(u.x), double(u.y), double(u.z)});
    const testkit::ExactBracket::Truth t =
        exact->truth_where_needed(lo, hi, tried, hi_witnessed, piece_a, piece_b);
    oracle_stats().record(t.qp_pairs);
    if (!(t.at_least_lo && t.at_most_hi))
      fuzz::fail(__FILE__, __LINE__,
                 "CGAL's exact distance " + number(t.approx) + " is outside " + interval +
                     ", no slack; " + where());
  }

  if (r.has_near_points && r.status == Status::separated) {
    // The near points are `distance` apart and each lies in (the rounded surface of) its piece,
    // to within the error bound and 16 ulps of their own coordinates.
    const LD np_slack = kNearPointUlps * eps * (norm(p3(r.point_a)) + norm(p3(r.point_b))) +
                        LD(std::numeric_limits<S>::denorm_min());
    const LD gap = norm(p3(r.point_b) - p3(r.point_a));
    if (mode == CutoffInterval::lower_bound) {
      // Points of the shapes are at least the true distance ≥ distance apart.
      if (!(gap >= LD(d) - np_slack))
        fuzz::fail(__FILE__, __LINE__,
                   "|point_b - point_a| = " + number(gap) +
                       " is below a beyond_cutoff distance (a lower bound); " + where());
    } else if (!(std::abs(gap - LD(d)) <= LD(e) + np_slack)) {
      fuzz::fail(__FILE__, __LINE__,
                 "|point_b - point_a| = " + number(gap) +
                     " differs from distance by more than the bound + 16 ulps of the points; " +
                     where());
    }
    piece_a = std::max(piece_a, 0);  // a compound answer names its pair (−1 only if none)
    piece_b = std::max(piece_b, 0);
    const RefPiece& pa = ra.pieces[std::size_t(piece_a)];
    const RefPiece& pb = rb.pieces[std::size_t(piece_b)];
    const double pad[3] = {double(r.point_a.x()), double(r.point_a.y()), double(r.point_a.z())};
    const double pbd[3] = {double(r.point_b.x()), double(r.point_b.y()), double(r.point_b.z())};
    const testkit::ExactSum slack{e, double(np_slack)};  // np_slack rounded: it is slack anyway
    for (const P3& u : directions) {
      if (dot(u, u) == 0) continue;
      for (const LD sign : {LD(1), LD(-1)}) {
        const P3 v = sign * u;
        if (exact) {
          double vd[3];
          as_double(v, vd);
          NEARPOINT_FUZZ_CHECK(exact->within_along(0, piece_a, pad, vd, slack),
                               "point_a lies outside its shape (exact); " + where());
          NEARPOINT_FUZZ_CHECK(exact->within_along(1, piece_b, pbd, vd, slack),
                               "point_b lies outside its shape (exact); " + where());
        } else {
          const LD allowed = LD(e) + np_slack + ref_slack;
          NEARPOINT_FUZZ_CHECK(dot(v, p3(r.point_a)) <= pa.support(v) + allowed,
                               "point_a lies outside its shape; " + where());
          NEARPOINT_FUZZ_CHECK(dot(v, p3(r.point_b)) <= pb.support(v) + allowed,
                               "point_b lies outside its shape; " + where());
        }
      }
    }
  }
}

// Two answers for the same poses are both certified, so their intervals must overlap.
template <class S>
void check_agree(const DistanceResult<S>& x, const DistanceResult<S>& y, const char* what) {
  if (x.status == Status::invalid_input || y.status == Status::invalid_input) {
    NEARPOINT_FUZZ_CHECK(
        x.status == y.status,
        std::string(what) + ": refused once, accepted once; " + describe(x) + " | " + describe(y));
    return;
  }
  const LD tolerance = 4 * LD(std::numeric_limits<S>::epsilon()) * (LD(x.distance) + y.distance) +
                       LD(std::numeric_limits<S>::denorm_min());
  NEARPOINT_FUZZ_CHECK(
      std::abs(LD(x.distance) - y.distance) <= LD(x.error_bound) + y.error_bound + tolerance,
      std::string(what) + ": the answers' intervals do not overlap; " + describe(x) + " | " +
          describe(y));
}

// The far offset cancelled by a pose: translation − R·c (in Scalar: exact for permutations, within
// an ulp of the offset otherwise, so the shape comes back near where the plain layout puts it).
template <class S>
void cancel_far_offset(Pose<S>& pose, const Placement<S>& place, bool& finite_flag) {
  if (!place.far) return;
  pose.translation = pose.translation - pose.rotation * place.far_offset;
  if (!pose.translation.allFinite()) finite_flag = false;
}

// `placed`: read a placement byte (and its parameters) first: rotation kind, far local
// coordinates, degenerate vertices. See Placement.
template <class S>
Body<S> read_body(ByteReader& in, int scale, bool compound, bool placed) {
  Body<S> body;
  Placement<S> place;
  if (placed) {
    const std::uint8_t mode = in.byte();
    place.rotation = mode & 3;
    if (mode & 4) {
      // Far: vertices at 2^k from the local origin, k from a byte. double: 2^10 … 2^73 (ordinary
      // CAD offsets) or 2^127 … 2^1000 (1e38 … 1e300); float: 2^10 … 2^125, or 2^20 … 2^24 (the
      // moderate offsets, 1e6 … 1.6e7, where float keeps only a few bits below the unit).
      place.far = true;
      const int f = in.byte(), low = f & 127;
      int k;
      if constexpr (std::is_same_v<S, float>)
        k = (f & 128) ? 20 + low % 5 : 10 + low * 115 / 127;
      else
        k = (f & 128) ? 127 + low * 873 / 127 : 10 + low / 2;
      for (int i = 0; i < 3; ++i)
        place.far_offset[i] = std::ldexp(S(std::int8_t(in.byte())), k - 7);  // (int8/128)·2^k
    }
    if (mode & 8) place.degenerate = in.byte();
    body.far = place.far;
    body.rotation_kinds = place.rotation;
  }
  const int pieces = compound ? 1 + in.byte() % kMaxPieces : 1;
  for (int i = 0; i < pieces; ++i) {
    Piece<S> piece;
    std::vector<Vec3<S>> given;
    piece.shape = read_shape<S>(in, scale, body.inputs_finite, place, given);
    if (compound) {
      piece.offset = read_pose<S>(in, scale, body.inputs_finite, place);
      cancel_far_offset(piece.offset, place, body.inputs_finite);
    }
    testkit::BracketPiece<S> exact;
    const bool has_vertices = testkit::core_vertices(piece.shape, exact.vertices);
    if (std::holds_alternative<Polytope<S>>(piece.shape.geometry)) exact.vertices = given;
    if (!has_vertices || exact.vertices.empty()) body.vertex_only = false;
    exact.radius = piece.shape.radius;
    exact.offset = piece.offset;
    body.exact_pieces.push_back(std::move(exact));
    body.pieces.push_back(std::move(piece));
  }
  body.pose = read_pose<S>(in, scale, body.inputs_finite, place);
  if (!compound) cancel_far_offset(body.pose, place, body.inputs_finite);
  return body;
}

// ---- survey mode (NEARPOINT_FUZZ_SURVEY=DIR): broken invariants counted by kind, not crashes ----
// For measuring what a run finds on an engine known to fail: the first input of each kind (the
// check's line, the answer's status and termination, the precision and the options that matter)
// is written to DIR with the number of inputs and seconds it took, and fuzzing goes on. Off by
// default: then every broken invariant aborts, as libFuzzer needs.
struct SurveyHit {
  int line;
  std::string what;
};
struct Survey {
  std::string dir;
  std::string kind;                  // set by run() before the checks: precision and options
  std::map<std::string, long> seen;  // by check, precision and verdict
  std::map<std::string, long> tags;  // the same with the options and generators
  long inputs = 0;
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
};
Survey* survey() {
  static Survey* s = [] {
    const char* dir = std::getenv("NEARPOINT_FUZZ_SURVEY");
    if (!dir) return static_cast<Survey*>(nullptr);
    Survey* out = new Survey;
    out->dir = dir;
    fuzz::on_failure = [](const char*, int line, const std::string& what) {
      throw SurveyHit{line, what};
    };
    std::atexit([] {  // libFuzzer exits at -max_total_time / -runs: the counts
      Survey& s = *survey();
      std::fprintf(stderr, "SURVEY summary after %ld inputs:\n", s.inputs);
      for (const auto& [key, count] : s.seen)
        std::fprintf(stderr, "  %8ld  %s\n", count, key.c_str());
      std::fprintf(stderr, "SURVEY by options and generators:\n");
      for (const auto& [key, count] : s.tags)
        std::fprintf(stderr, "  %8ld  %s\n", count, key.c_str());
    });
    return out;
  }();
  return s;
}

bool same_cache(const SimplexCache& x, const SimplexCache& y) {
  if (x.count != y.count) return false;
  for (int i = 0; i < 4; ++i)
    if (x.index_a[i] != y.index_a[i] || x.index_b[i] != y.index_b[i]) return false;
  return true;
}

template <class S>
void run(ByteReader& in, bool sampled, bool extended) {
  int scale = in.exponent<S>();
  const std::uint8_t flags = in.byte();
  const bool compound = flags & 1;
  DistanceOptions<S> options;
  options.near_points = (flags & 2) != 0;
  options.penetration_bound = (flags & 4) != 0;
  options.gradient = (flags & 8) != 0;
  // The depth with near points and d⁻ together: no bit is free, and inputs saved before keep
  // their shapes (they now also check the depth).
  options.penetration_depth = (flags & 6) == 6;
  options.subalgorithm = (flags & 16) ? Subalgorithm::johnson : Subalgorithm::signed_volumes;
  options.cold_start = (flags & 32) ? ColdStart::single_point : ColdStart::with_centroids;
  if (flags & 64) options.epsilon = kPaperEpsilon<S>;
  // Flag bit 7 with bit 1 of the first byte: one more byte of options and generators (the
  // outside fuzzer's findings). Two bits, so that every input saved before keeps its meaning.
  bool placed = false, oracle = sampled, tiny = false;
  if (extended && (flags & 128)) {
    const std::uint8_t ext = in.byte();
    if (ext & 1) options.origin_shift = false;
    switch ((ext >> 1) & 3) {
      case 1:  // a yes/no query
        options.distance_cutoff = 0;
        break;
      case 2: {  // any cutoff on the input's scale (non-finite: none)
        const S c = std::abs(in.value<S>(scale));
        options.distance_cutoff = std::isfinite(c) ? c : std::numeric_limits<S>::infinity();
        break;
      }
      case 3:  // a small positive one: byte/256 of the scale
        options.distance_cutoff = std::ldexp(S(in.byte()), scale - 8);
        break;
      default:
        break;
    }
    if (ext & 8) options.max_iterations = std::int8_t(in.byte());
    placed = (ext & 16) != 0;
    switch ((ext >> 5) & 3) {
      case 1:  // tiny shapes: 2^-50 … 2^-611 in double (1e-15 … 1e-184), 2^-50 … 2^-140 in float
        scale = -(50 + in.byte() * (std::is_same_v<S, float> ? 90 : 561) / 255);
        tiny = true;
        break;
      case 2:
        options.epsilon = 0;
        break;
      case 3:
        options.epsilon = S(1e-3);
        break;
      default:
        break;
    }
    oracle = oracle || (ext & 128) != 0;
  }

  Body<S> a = read_body<S>(in, scale, compound, placed);
  Body<S> b = read_body<S>(in, scale, compound, placed);
  if (Survey* s = survey())
    s->kind = std::string(std::is_same_v<S, float> ? "float" : "double") +
              (compound ? " compound" : "") + (options.origin_shift ? "" : " origin_shift=0") +
              (options.subalgorithm == Subalgorithm::johnson ? " johnson" : "") +
              (options.cold_start == ColdStart::single_point ? " single_point" : "") +
              (std::isfinite(options.distance_cutoff) ? " cutoff" : "") +
              (a.far || b.far ? " far" : "") + (a.rotation_kinds || b.rotation_kinds ? " R*" : "") +
              (tiny ? " tiny" : "") + (options.epsilon == 0 ? " eps0" : "");
  std::vector<V3L> directions;
  for (int i = 0; i < 2; ++i) {
    bool ignored = true;
    directions.push_back(read_vec<S>(in, 0, ignored).template cast<LD>());
  }
  // The perturbation for the perturbed-warm check: a small rotation and translation of B.
  const S angle = S(std::int8_t(in.byte())) * S(1e-3);
  const int axis = in.byte() % 3;
  bool perturbation_finite = true;
  const Vec3<S> shift = read_vec<S>(in, scale - 8, perturbation_finite);
  if (!perturbation_finite) return;

  if (!compound) {
    const Shape<S>& sa = a.pieces[0].shape;
    const Shape<S>& sb = b.pieces[0].shape;
    // Every query with a cache: a refused one must leave the cache as it was.
    const auto query = [&](const Pose<S>& pose_b, SimplexCache* cache, const char* what) {
      SimplexCache before{};
      if (cache) before = *cache;
      const DistanceResult<S> r = distance(sa, a.pose, sb, pose_b, options, cache);
      if (cache && r.status == Status::invalid_input)
        NEARPOINT_FUZZ_CHECK(
            same_cache(before, *cache),
            std::string(what) + ": a refused query changed the warm-start cache; " + describe(r));
      return r;
    };
    ExactPair<S> same{a, b, nullptr};
    SimplexCache cache{};
    const DistanceResult<S> cold = query(b.pose, &cache, "cold");
    check_result(cold, same, 0, 0, directions, oracle, "cold");
    const DistanceResult<S> warm = query(b.pose, &cache, "warm");
    check_result(warm, same, 0, 0, directions, false, "warm");
    check_agree(cold, warm, "cold vs warm");

    Body<S> moved = b;
    moved.pose.rotation =
        Eigen::AngleAxis<S>(angle, Vec3<S>::Unit(axis)).toRotationMatrix() * b.pose.rotation;
    moved.pose.translation += shift;
    moved.inputs_finite = b.inputs_finite && moved.pose.translation.allFinite();
    ExactPair<S> there{a, moved, nullptr};
    const DistanceResult<S> perturbed = query(moved.pose, &cache, "perturbed warm");
    check_result(perturbed, there, 0, 0, directions, false, "perturbed warm");
    const DistanceResult<S> fresh = distance(sa, a.pose, sb, moved.pose, options);
    check_result(fresh, there, 0, 0, directions, false, "perturbed cold");
    check_agree(perturbed, fresh, "perturbed warm vs cold");
    return;
  }

  const Compound<S> ca(a.pieces), cb(b.pieces);
  std::vector<SimplexCache> caches(a.pieces.size() * b.pieces.size());
  static const bool verbose = std::getenv("NEARPOINT_FUZZ_VERBOSE") != nullptr;
  if (verbose)  // every piece pair on its own, as single shapes at their composed world poses
    for (std::size_t i = 0; i < a.pieces.size(); ++i)
      for (std::size_t j = 0; j < b.pieces.size(); ++j)
        std::fprintf(stderr, "pieces %zu-%zu alone: %s\n", i, j,
                     describe(distance(a.pieces[i].shape, piece_pose(a, i), b.pieces[j].shape,
                                       piece_pose(b, j), options))
                         .c_str());
  const auto query = [&](const char* what) {
    const std::vector<SimplexCache> before = caches;
    CompoundResult<S> r = distance(ca, a.pose, cb, b.pose, options, caches);
    if (kCompoundRefusalKeepsCaches && r.nearest.status == Status::invalid_input)
      for (std::size_t i = 0; i < caches.size(); ++i)
        NEARPOINT_FUZZ_CHECK(same_cache(before[i], caches[i]),
                             std::string(what) + ": a refused query changed a warm-start cache; " +
                                 describe(r.nearest));
    if (verbose)
      std::fprintf(stderr, "%s: pieces %d-%d, evaluated %d, pruned %d, stopped %d\n", what,
                   r.piece_a, r.piece_b, r.pairs_evaluated, r.pairs_pruned,
                   r.pairs_stopped_at_best);
    return r;
  };
  ExactPair<S> same{a, b, nullptr};
  // The full oracle costs a millisecond per piece pair: compounds of at most 4 pairs.
  const bool compound_oracle = oracle && a.pieces.size() * b.pieces.size() <= 4;
  const CompoundResult<S> cold = query("compound cold");
  check_result(cold.nearest, same, cold.piece_a, cold.piece_b, directions, compound_oracle,
               "compound cold");
  const CompoundResult<S> warm = query("compound warm");
  check_result(warm.nearest, same, warm.piece_a, warm.piece_b, directions, false, "compound warm");
  check_agree(cold.nearest, warm.nearest, "compound cold vs warm");
}

void survey_record(Survey& s, const SurveyHit& hit, const std::uint8_t* data, std::size_t size) {
  // The answer's status and termination, from the message ("status X, termination Y").
  std::string verdict;
  const std::size_t at = hit.what.find("status ");
  if (at != std::string::npos) {
    const std::size_t end = hit.what.find(',', hit.what.find("termination ", at));
    verdict = hit.what.substr(at, end == std::string::npos ? std::string::npos : end - at);
  }
  const std::string precision = s.kind.substr(0, s.kind.find(' '));
  const std::string key = "line " + std::to_string(hit.line) + " | " + precision + " | " + verdict;
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - s.start).count();
  if (s.tags[key + " | " + s.kind]++ == 0)  // one line per new combination, for classifying
    std::fprintf(stderr, "SURVEY first after %ld inputs, %.1f s: %s | %s\n", s.inputs, seconds,
                 key.c_str(), s.kind.c_str());
  if (s.seen[key]++ > 0) return;
  const std::string name = s.dir + "/kind-" + std::to_string(s.seen.size());
  if (FILE* f = std::fopen(name.c_str(), "wb")) {
    std::fwrite(data, 1, size, f);
    std::fclose(f);
  }
  std::fprintf(stderr, "SURVEY new kind %zu after %ld inputs, %.1f s: %s | %s\n  %s\n  -> %s\n",
               s.seen.size(), s.inputs, seconds, key.c_str(), s.kind.c_str(),
               hit.what.substr(0, 400).c_str(), name.c_str());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // CGAL's full exact distance on one input in 64 (by content, so a replay repeats it), or on
  // every one with NEARPOINT_FUZZ_ORACLE=1.
  static const bool always = std::getenv("NEARPOINT_FUZZ_ORACLE") != nullptr;
  std::uint32_t hash = 2166136261u;
  for (std::size_t i = 0; i < size; ++i) hash = (hash ^ data[i]) * 16777619u;
  const bool sampled = always || hash % 64 == 0;
  ByteReader in(data, size);
  const std::uint8_t kind = in.byte();  // bit 0: float; bit 1: the extended layout (see run)
  const auto go = [&] {
    if (kind & 1)
      run<float>(in, sampled, (kind & 2) != 0);
    else
      run<double>(in, sampled, (kind & 2) != 0);
  };
  Survey* s = survey();
  if (!s) {
    go();
    return 0;
  }
  ++s->inputs;
  s->kind.clear();
  try {  // thrown only by survey mode's fuzz::on_failure, caught here: nothing leaves the entry
    go();
  } catch (const SurveyHit& hit) {
    survey_record(*s, hit, data, size);
  }
  return 0;
}
