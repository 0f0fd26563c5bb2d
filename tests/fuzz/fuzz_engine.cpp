// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the engine (nearpoint::distance, single shapes and compounds) on arbitrary
// shapes, poses and radii, in double and in float, held to invariants that hold for every correct
// answer rather than to today's numbers:
//   - a refused query says why; an accepted one has only finite outputs, distance ≥ 0, and
//     distance 0 exactly when it says intersecting; non-finite input is always refused;
//   - the bound covers an independent reference: for directions u (axes, the centres' difference,
//     the reported normal and near-point difference, fuzzed ones) the separating-plane bracket
//     (−h_B(−u) − h_A(u)) / |u| ≤ true distance must not exceed distance + error_bound, with the
//     support functions h evaluated here in long double from the shapes' own definitions (not the
//     engine's support code); a penetration bound d⁻ must not exceed h_A(u) + h_B(−u) (the
//     translation along u that separates them), and separated near points lie in their shapes
//     and are `distance` apart, both to within the error bound and a few ulps of the coordinates;
//   - cold, warm (same poses) and perturbed-warm (poses moved a little, against a cold start
//     there) answers agree: their intervals [distance ± error_bound] overlap.
// The per-input work is bounded (at most 3 pieces per body, 12 vertices per polytope), so a
// libFuzzer timeout means a real hang.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

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

template <class S>
struct Body {
  std::vector<Piece<S>> pieces;  // offset: piece frame → body frame
  Pose<S> pose;                  // body frame → world
  bool inputs_finite = true;
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

template <class S>
Pose<S> read_pose(ByteReader& in, int scale, bool& finite_flag) {
  // A rotation from a small-integer quaternion, normalised here in double (a zero one is the
  // identity): what a client's unit quaternion becomes. The translation has the full value range.
  double q[4];
  for (double& c : q) c = double(std::int8_t(in.byte()));
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  Pose<S> pose;
  if (n > 0)
    pose.rotation = Eigen::Quaternion<S>(S(q[0] / n), S(q[1] / n), S(q[2] / n), S(q[3] / n))
                        .normalized()
                        .toRotationMatrix();
  // Some translations on their own (far) scale: the far-from-origin cases.
  const int t_scale = (in.byte() & 3) == 0 ? in.exponent<S>() : scale;
  pose.translation = read_vec<S>(in, t_scale, finite_flag);
  return pose;
}

template <class S>
Shape<S> read_shape(ByteReader& in, int scale, bool& finite_flag) {
  Shape<S> shape;
  switch (in.byte() % 7) {
    case 0:
      shape.geometry = Point{};
      break;
    case 1:
      shape.geometry =
          Segment<S>{read_vec<S>(in, scale, finite_flag), read_vec<S>(in, scale, finite_flag)};
      break;
    case 2: {
      Box<S> box;
      for (int k = 0; k < 3; ++k) box.half_extents[k] = read_extent<S>(in, scale, finite_flag);
      shape.geometry = box;
      break;
    }
    case 3: {
      const int n = in.byte() % (kMaxVertices + 1);  // 0: an empty polytope, to be refused
      std::vector<Vec3<S>> vertices;
      for (int i = 0; i < n; ++i) vertices.push_back(read_vec<S>(in, scale, finite_flag));
      if (n == 0) finite_flag = false;  // not finite input, but equally must be refused
      shape.geometry = Polytope<S>(vertices);
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

template <class S>
RefPiece reference_piece(const Shape<S>& shape, const Pose<S>& pose, const Pose<S>& offset) {
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
  const auto place = [&](const Vec3<S>& v) { out.world.push_back(out.to_world(p3(v))); };
  std::visit(
      [&](const auto& g) {
        using G = std::decay_t<decltype(g)>;
        if constexpr (std::is_same_v<G, Point>) {
          place(Vec3<S>::Zero());
        } else if constexpr (std::is_same_v<G, Segment<S>>) {
          place(g.a);
          place(g.b);
        } else if constexpr (std::is_same_v<G, Box<S>>) {
          for (int c = 0; c < 8; ++c)
            place(Vec3<S>((c & 1) ? g.half_extents.x() : -g.half_extents.x(),
                          (c & 2) ? g.half_extents.y() : -g.half_extents.y(),
                          (c & 4) ? g.half_extents.z() : -g.half_extents.z()));
        } else if constexpr (std::is_same_v<G, Polytope<S>>) {
          for (std::size_t i = 0; i < g.size(); ++i) place(g.vertex(i));
        } else if constexpr (std::is_same_v<G, Cylinder<S>>) {
          out.kind = RefPiece::cylinder;
          out.p0 = g.radius;
          out.p1 = g.half_height;
        } else if constexpr (std::is_same_v<G, Cone<S>>) {
          out.kind = RefPiece::cone;
          out.p0 = g.radius;
          out.p1 = g.half_height;
        } else {
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
    const RefPiece& piece =
        out.pieces.emplace_back(reference_piece(s, body.pose, body.pieces[i].offset));
    const P3 z = p3(core_center(s));
    const P3 c = piece.to_world(z);
    out.centre_sum = {out.centre_sum.x + c.x, out.centre_sum.y + c.y, out.centre_sum.z + c.z};
    out.magnitude =
        std::max(out.magnitude, norm(piece.t) + norm(z) + LD(core_extent(s)) + LD(s.radius));
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
  for (const Piece<S>& piece : body.pieces) {
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
            for (std::size_t i = 0; i < g.size(); ++i) {
              out << ' ';
              vec(g.vertex(i));
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

// Checks one answer for bodies a and b against the invariants above. `piece_a`/`piece_b`: the
// pieces the near points are on (compounds), 0 for single shapes.
template <class S>
void check_result(const DistanceResult<S>& r, const Body<S>& a, const Body<S>& b, int piece_a,
                  int piece_b, const std::vector<V3L>& extra_directions, const char* what) {
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
  NEARPOINT_FUZZ_CHECK(result_finite(r), "non-finite output of an accepted query; " + where());
  NEARPOINT_FUZZ_CHECK(r.distance >= 0 && r.error_bound >= 0 && r.gap >= 0,
                       "negative distance, error bound or gap; " + where());
  NEARPOINT_FUZZ_CHECK((r.status == Status::intersecting) == (r.distance == 0) ||
                           r.status == Status::iteration_limit,
                       "distance 0 if and only if intersecting; " + where());

  // Roundoff a correct answer may carry in world coordinates beyond its certified bound: a few
  // ulps of the coordinates involved (in Scalar), plus this reference's own long double error.
  const RefBody ra = reference_body(a), rb = reference_body(b);
  const LD ulp = LD(std::numeric_limits<S>::epsilon());
  const LD slack =
      16 * ulp * (ra.magnitude + rb.magnitude) + LD(std::numeric_limits<S>::denorm_min());
  const LD d = r.distance, e = r.error_bound;

  std::vector<P3> directions;
  for (const V3L& u : extra_directions) directions.push_back({u.x(), u.y(), u.z()});
  directions.push_back({1, 0, 0});
  directions.push_back({0, 1, 0});
  directions.push_back({0, 0, 1});
  directions.push_back(rb.centre_sum - ra.centre_sum);
  if (r.has_near_points) {
    directions.push_back(p3(r.normal));
    directions.push_back(p3(r.point_b) - p3(r.point_a));
  }
  for (P3& u : directions) {  // unit length, or dropped
    const LD n = norm(u);
    u = (n > 0 && std::isfinite(n)) ? (1 / n) * u : P3{};
  }

  // Single shapes: the hulls are the shapes, so d⁻ ≤ depth ≤ h_A(u) + h_B(−u) holds for every u.
  // (Compounds: d⁻ is the largest over intersecting piece pairs; not checked here.)
  LD depth_upper = std::numeric_limits<LD>::infinity();
  for (const P3& u : directions) {
    if (dot(u, u) == 0) continue;
    const LD ha = ra.support(u), hb = rb.support(-1 * u);
    const LD lower = -hb - ha;  // ≤ the distance between the hulls ≤ the distance
    if (!(lower <= d + e + slack)) {
      std::ostringstream msg;
      msg.precision(20);
      msg << "the separating-plane bracket " << lower << " along (" << u.x << " " << u.y << " "
          << u.z << ") exceeds distance + error_bound = " << d + e << " (slack " << slack << "); ";
      fuzz::fail(__FILE__, __LINE__, msg.str() + where());
    }
    if (a.pieces.size() == 1 && b.pieces.size() == 1) depth_upper = std::min(depth_upper, ha + hb);
  }
  if (r.has_penetration_bound && r.status == Status::intersecting && std::isfinite(depth_upper)) {
    if (!(LD(r.penetration_bound) >= 0 && LD(r.penetration_bound) <= depth_upper + e + slack)) {
      std::ostringstream msg;
      msg.precision(20);
      msg << "penetration bound " << r.penetration_bound << " exceeds the depth upper bound "
          << depth_upper << "; ";
      fuzz::fail(__FILE__, __LINE__, msg.str() + where());
    }
  }

  if (r.has_near_points && r.status == Status::separated) {
    // The near points are `distance` apart and each lies in (the rounded surface of) its piece.
    const LD gap = norm(p3(r.point_b) - p3(r.point_a));
    if (!(std::abs(gap - d) <= e + slack)) {
      std::ostringstream msg;
      msg.precision(20);
      msg << "|point_b - point_a| = " << gap << " differs from distance by more than the bound; ";
      fuzz::fail(__FILE__, __LINE__, msg.str() + where());
    }
    const RefPiece& pa = ra.pieces[std::size_t(piece_a)];
    const RefPiece& pb = rb.pieces[std::size_t(piece_b)];
    for (const P3& u : directions) {
      if (dot(u, u) == 0) continue;
      for (const LD sign : {LD(1), LD(-1)}) {
        const P3 v = sign * u;
        NEARPOINT_FUZZ_CHECK(dot(v, p3(r.point_a)) <= pa.support(v) + e + slack,
                             "point_a lies outside its shape; " + where());
        NEARPOINT_FUZZ_CHECK(dot(v, p3(r.point_b)) <= pb.support(v) + e + slack,
                             "point_b lies outside its shape; " + where());
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

template <class S>
Body<S> read_body(ByteReader& in, int scale, bool compound) {
  Body<S> body;
  const int pieces = compound ? 1 + in.byte() % kMaxPieces : 1;
  for (int i = 0; i < pieces; ++i) {
    Piece<S> piece;
    piece.shape = read_shape<S>(in, scale, body.inputs_finite);
    if (compound) piece.offset = read_pose<S>(in, scale, body.inputs_finite);
    body.pieces.push_back(std::move(piece));
  }
  body.pose = read_pose<S>(in, scale, body.inputs_finite);
  return body;
}

template <class S>
void run(ByteReader& in) {
  const int scale = in.exponent<S>();
  const std::uint8_t flags = in.byte();
  const bool compound = flags & 1;
  DistanceOptions<S> options;
  options.near_points = (flags & 2) != 0;
  options.penetration_bound = (flags & 4) != 0;
  options.gradient = (flags & 8) != 0;
  options.subalgorithm = (flags & 16) ? Subalgorithm::johnson : Subalgorithm::signed_volumes;
  options.cold_start = (flags & 32) ? ColdStart::single_point : ColdStart::with_centroids;
  if (flags & 64) options.epsilon = kPaperEpsilon<S>;

  Body<S> a = read_body<S>(in, scale, compound);
  Body<S> b = read_body<S>(in, scale, compound);
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
    SimplexCache cache{};
    const DistanceResult<S> cold = distance(sa, a.pose, sb, b.pose, options, &cache);
    check_result(cold, a, b, 0, 0, directions, "cold");
    const DistanceResult<S> warm = distance(sa, a.pose, sb, b.pose, options, &cache);
    check_result(warm, a, b, 0, 0, directions, "warm");
    check_agree(cold, warm, "cold vs warm");

    Body<S> moved = b;
    moved.pose.rotation =
        Eigen::AngleAxis<S>(angle, Vec3<S>::Unit(axis)).toRotationMatrix() * b.pose.rotation;
    moved.pose.translation += shift;
    moved.inputs_finite = b.inputs_finite && moved.pose.translation.allFinite();
    const DistanceResult<S> perturbed = distance(sa, a.pose, sb, moved.pose, options, &cache);
    check_result(perturbed, a, moved, 0, 0, directions, "perturbed warm");
    const DistanceResult<S> fresh = distance(sa, a.pose, sb, moved.pose, options);
    check_result(fresh, a, moved, 0, 0, directions, "perturbed cold");
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
  const CompoundResult<S> cold = distance(ca, a.pose, cb, b.pose, options, caches);
  if (verbose)
    std::fprintf(stderr, "compound cold: pieces %d-%d, evaluated %d, pruned %d, stopped %d\n",
                 cold.piece_a, cold.piece_b, cold.pairs_evaluated, cold.pairs_pruned,
                 cold.pairs_stopped_at_best);
  check_result(cold.nearest, a, b, std::max(cold.piece_a, 0), std::max(cold.piece_b, 0), directions,
               "compound cold");
  const CompoundResult<S> warm = distance(ca, a.pose, cb, b.pose, options, caches);
  if (verbose)
    std::fprintf(stderr, "compound warm: pieces %d-%d, evaluated %d, pruned %d, stopped %d\n",
                 warm.piece_a, warm.piece_b, warm.pairs_evaluated, warm.pairs_pruned,
                 warm.pairs_stopped_at_best);
  check_result(warm.nearest, a, b, std::max(warm.piece_a, 0), std::max(warm.piece_b, 0), directions,
               "compound warm");
  check_agree(cold.nearest, warm.nearest, "compound cold vs warm");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  ByteReader in(data, size);
  if (in.byte() & 1)
    run<float>(in);
  else
    run<double>(in);
  return 0;
}
