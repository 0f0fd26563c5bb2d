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

template <class S>
V3L ld(const Vec3<S>& v) {
  return v.template cast<LD>();
}

// h_C(u) of the core (radius excluded), local frame.
template <class S>
LD core_support(const Shape<S>& shape, const V3L& u) {
  return std::visit(
      [&](const auto& g) -> LD {
        using G = std::decay_t<decltype(g)>;
        if constexpr (std::is_same_v<G, Point>) {
          return 0;
        } else if constexpr (std::is_same_v<G, Segment<S>>) {
          return std::max(u.dot(ld(g.a)), u.dot(ld(g.b)));
        } else if constexpr (std::is_same_v<G, Box<S>>) {
          const V3L h = ld(g.half_extents);
          return std::abs(u.x()) * h.x() + std::abs(u.y()) * h.y() + std::abs(u.z()) * h.z();
        } else if constexpr (std::is_same_v<G, Polytope<S>>) {
          LD best = -std::numeric_limits<LD>::infinity();
          for (std::size_t i = 0; i < g.size(); ++i) best = std::max(best, u.dot(ld(g.vertex(i))));
          return best;
        } else if constexpr (std::is_same_v<G, Cylinder<S>>) {
          return LD(g.radius) * std::hypot(u.x(), u.y()) + LD(g.half_height) * std::abs(u.z());
        } else if constexpr (std::is_same_v<G, Cone<S>>) {
          const LD apex = LD(g.half_height) * u.z();
          const LD base = -LD(g.half_height) * u.z() + LD(g.radius) * std::hypot(u.x(), u.y());
          return std::max(apex, base);
        } else {
          const V3L r = ld(g.radii);
          return std::sqrt(LD(r.x() * u.x()) * (r.x() * u.x()) + (r.y() * u.y()) * (r.y() * u.y()) +
                           (r.z() * u.z()) * (r.z() * u.z()));
        }
      },
      shape.geometry);
}

// h(u) of a placed, rounded shape, world frame: h_C(Rᵀu) + u·t + r|u|, with R and t the very
// floating-point entries the engine was given.
template <class S>
LD placed_support(const Shape<S>& shape, const Pose<S>& pose, const V3L& u) {
  const V3L local = pose.rotation.template cast<LD>().transpose() * u;
  return core_support(shape, local) + u.dot(ld(pose.translation)) + LD(shape.radius) * u.norm();
}

template <class S>
Pose<S> piece_pose(const Body<S>& body, std::size_t i) {
  return body.pose.compose(body.pieces[i].offset);
}

// h of the union of a body's pieces (of its convex hull, which is what a bracket can see).
template <class S>
LD body_support(const Body<S>& body, const V3L& u) {
  LD best = -std::numeric_limits<LD>::infinity();
  for (std::size_t i = 0; i < body.pieces.size(); ++i)
    best = std::max(best, placed_support(body.pieces[i].shape, piece_pose(body, i), u));
  return best;
}

// A magnitude that bounds every coordinate the engine handled for the body: a few ulps of it is
// the rounding a correct answer may carry beyond its error bound in a world-frame coordinate.
template <class S>
LD body_magnitude(const Body<S>& body) {
  LD m = 0;
  for (std::size_t i = 0; i < body.pieces.size(); ++i) {
    const Pose<S> pose = piece_pose(body, i);
    const Shape<S>& s = body.pieces[i].shape;
    m = std::max(m, LD(pose.translation.template cast<LD>().norm()) +
                        LD(core_center(s).template cast<LD>().norm()) + LD(core_extent(s)) +
                        LD(s.radius));
    m = std::max(m, LD(body.pieces[i].offset.translation.template cast<LD>().norm()) +
                        LD(body.pose.translation.template cast<LD>().norm()));
  }
  return m;
}

template <class S>
std::string describe(const DistanceResult<S>& r) {
  std::ostringstream out;
  out.precision(17);
  out << "status " << to_string(r.status) << ", termination " << to_string(r.termination)
      << ", distance " << r.distance << ", error_bound " << r.error_bound << ", iterations "
      << r.iterations << ", warm " << r.warm_started;
  if (r.has_near_points)
    out << ", point_a (" << r.point_a.transpose() << "), point_b (" << r.point_b.transpose()
        << "), normal (" << r.normal.transpose() << ")";
  if (r.has_penetration_bound) out << ", penetration_bound " << r.penetration_bound;
  if (r.message) out << ", message " << r.message;
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
  if (verbose) std::fprintf(stderr, "%s\n", where().c_str());
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
  const LD magnitude = body_magnitude(a) + body_magnitude(b);
  const LD ulp = LD(std::numeric_limits<S>::epsilon());
  const LD slack = 16 * ulp * magnitude + LD(std::numeric_limits<S>::denorm_min());
  const LD d = r.distance, e = r.error_bound;

  std::vector<V3L> directions = extra_directions;
  directions.push_back(V3L::UnitX());
  directions.push_back(V3L::UnitY());
  directions.push_back(V3L::UnitZ());
  V3L centres = V3L::Zero();
  for (std::size_t i = 0; i < b.pieces.size(); ++i)
    centres += ld(piece_pose(b, i).apply(core_center(b.pieces[i].shape)));
  for (std::size_t i = 0; i < a.pieces.size(); ++i)
    centres -= ld(piece_pose(a, i).apply(core_center(a.pieces[i].shape)));
  directions.push_back(centres);
  if (r.has_near_points) {
    directions.push_back(ld(r.normal));
    directions.push_back(ld(r.point_b) - ld(r.point_a));
  }

  // Single shapes: the hulls are the shapes, so d⁻ ≤ depth ≤ h_A(u) + h_B(−u) holds for every u.
  // Compounds: d⁻ is the largest over intersecting piece pairs, checked against those pieces.
  LD depth_upper = std::numeric_limits<LD>::infinity();
  for (V3L u : directions) {
    const LD n = u.norm();
    if (!(n > 0) || !std::isfinite(n)) continue;
    u /= n;
    const LD ha = body_support(a, u), hb = body_support(b, -u);
    const LD lower = -hb - ha;  // ≤ the distance between the hulls ≤ the distance
    if (!(lower <= d + e + slack)) {
      std::ostringstream msg;
      msg.precision(20);
      msg << "the separating-plane bracket " << lower << " along (" << u.transpose()
          << ") exceeds distance + error_bound = " << d + e << " (slack " << slack << "); ";
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
    const LD gap = (ld(r.point_b) - ld(r.point_a)).norm();
    if (!(std::abs(gap - d) <= e + slack)) {
      std::ostringstream msg;
      msg.precision(20);
      msg << "|point_b - point_a| = " << gap << " differs from distance by more than the bound; ";
      fuzz::fail(__FILE__, __LINE__, msg.str() + where());
    }
    const Shape<S>& sa = a.pieces[std::size_t(piece_a)].shape;
    const Shape<S>& sb = b.pieces[std::size_t(piece_b)].shape;
    const Pose<S> pa = piece_pose(a, std::size_t(piece_a)),
                  pb = piece_pose(b, std::size_t(piece_b));
    for (V3L u : directions) {
      const LD n = u.norm();
      if (!(n > 0) || !std::isfinite(n)) continue;
      u /= n;
      for (const LD sign : {LD(1), LD(-1)}) {
        const V3L v = sign * u;
        NEARPOINT_FUZZ_CHECK(v.dot(ld(r.point_a)) <= placed_support(sa, pa, v) + e + slack,
                             "point_a lies outside its shape; " + where());
        NEARPOINT_FUZZ_CHECK(v.dot(ld(r.point_b)) <= placed_support(sb, pb, v) + e + slack,
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
    directions.push_back(ld(read_vec<S>(in, 0, ignored)));
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
  const CompoundResult<S> cold = distance(ca, a.pose, cb, b.pose, options, caches);
  check_result(cold.nearest, a, b, std::max(cold.piece_a, 0), std::max(cold.piece_b, 0), directions,
               "compound cold");
  const CompoundResult<S> warm = distance(ca, a.pose, cb, b.pose, options, caches);
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
