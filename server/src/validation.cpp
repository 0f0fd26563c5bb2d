// SPDX-License-Identifier: Apache-2.0
#include "validation.hpp"

#ifdef NEARPOINT_HAVE_HULL
#include "nearpoint/hull.hpp"
#endif

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>

namespace nearpoint::server {
namespace {

/// Coordinates and lengths beyond this are refused: squares and differences of such values stay
/// far from overflow, and no real scene (a site 10⁶ m across) comes near it. Metres.
constexpr double kMaxMagnitude = 1e12;
constexpr std::uint64_t kMaxIterationsCap = 100'000;

constexpr char kAxis[3] = {'x', 'y', 'z'};

/// A finite coordinate within kMaxMagnitude; `field` names the vector, errors name the axis.
std::optional<Error> check_vector(const model::Vec3d& v, const std::string& field) {
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(v[k]))
      return invalid_argument(text(field, '.', kAxis[k]), text("is not finite (got ", v[k], ")"));
    if (std::abs(v[k]) > kMaxMagnitude)
      return invalid_argument(text(field, '.', kAxis[k]),
                              text("magnitude exceeds ", kMaxMagnitude, " m (got ", v[k], ")"));
  }
  return std::nullopt;
}

/// A length: finite, >= 0, within kMaxMagnitude.
std::optional<Error> check_length(double value, const std::string& field) {
  if (!std::isfinite(value) || value < 0 || value > kMaxMagnitude)
    return invalid_argument(
        field, text("must be finite, >= 0 and <= ", kMaxMagnitude, " m (got ", value, ")"));
  return std::nullopt;
}

std::optional<Error> check_lengths(const model::Vec3d& v, const std::string& field) {
  for (int k = 0; k < 3; ++k)
    if (auto error = check_length(v[k], text(field, '.', kAxis[k]))) return error;
  return std::nullopt;
}

/// Validates one piece's shape and converts it to the engine's type.
Expected<Shape<double>> build_shape(const model::PieceInput& piece, const std::string& field) {
  struct Visitor {
    const std::string& field;
    double radius;
    Expected<Shape<double>> operator()(const std::monostate&) const {
      return invalid_argument(field + ".shape",
                              "no shape set (one of polytope, point, segment, box, cylinder, cone, "
                              "ellipsoid)");
    }
    Expected<Shape<double>> operator()(const model::PolytopeInput& polytope) const {
      const std::string vertices = field + ".polytope.vertices";
      if (polytope.vertices.empty())
        return invalid_argument(vertices, "must hold at least one vertex");
      for (std::size_t j = 0; j < polytope.vertices.size(); ++j)
        if (auto error = check_vector(polytope.vertices[j], text(vertices, '[', j, ']')))
          return *error;
#ifdef NEARPOINT_HAVE_HULL
      // Large polytopes are stored as their hull with its faces, so that support queries climb
      // the hull's edges instead of scanning every vertex (the same convex set; vertex indices
      // are internal to the engine).
      if (polytope.vertices.size() >= Polytope<double>::kHillClimbThreshold)
        return Shape<double>(hull_polytope(polytope.vertices), radius);
#endif
      return Shape<double>(Polytope<double>(polytope.vertices), radius);
    }
    Expected<Shape<double>> operator()(const Point& point) const {
      return Shape<double>(point, radius);
    }
    Expected<Shape<double>> operator()(const Segment<double>& segment) const {
      if (auto error = check_vector(segment.a, field + ".segment.a")) return *error;
      if (auto error = check_vector(segment.b, field + ".segment.b")) return *error;
      return Shape<double>(segment, radius);
    }
    Expected<Shape<double>> operator()(const Box<double>& box) const {
      if (auto error = check_lengths(box.half_extents, field + ".box.half_extents")) return *error;
      return Shape<double>(box, radius);
    }
    Expected<Shape<double>> operator()(const Cylinder<double>& cylinder) const {
      if (auto error = check_length(cylinder.radius, field + ".cylinder.radius")) return *error;
      if (auto error = check_length(cylinder.half_height, field + ".cylinder.half_height"))
        return *error;
      return Shape<double>(cylinder, radius);
    }
    Expected<Shape<double>> operator()(const Cone<double>& cone) const {
      if (auto error = check_length(cone.radius, field + ".cone.radius")) return *error;
      if (auto error = check_length(cone.half_height, field + ".cone.half_height")) return *error;
      return Shape<double>(cone, radius);
    }
    Expected<Shape<double>> operator()(const Ellipsoid<double>& ellipsoid) const {
      if (auto error = check_lengths(ellipsoid.radii, field + ".ellipsoid.radii")) return *error;
      return Shape<double>(ellipsoid, radius);
    }
  };
  return std::visit(Visitor{field, piece.radius}, piece.shape);
}

/// Well-formed UTF-8 (no overlong forms, surrogates or code points beyond U+10FFFF) whose code
/// points are no control characters (C0, DEL, C1).
bool is_printable_utf8(std::string_view text) {
  std::size_t i = 0;
  while (i < text.size()) {
    const auto byte = static_cast<unsigned char>(text[i]);
    if (byte < 0x80) {
      if (byte < 0x20 || byte == 0x7F) return false;
      ++i;
      continue;
    }
    std::size_t length = 0;
    std::uint32_t code = 0;
    if ((byte & 0xE0) == 0xC0) {
      length = 2, code = byte & 0x1F;
    } else if ((byte & 0xF0) == 0xE0) {
      length = 3, code = byte & 0x0F;
    } else if ((byte & 0xF8) == 0xF0) {
      length = 4, code = byte & 0x07;
    } else {
      return false;
    }
    if (i + length > text.size()) return false;
    for (std::size_t k = 1; k < length; ++k) {
      const auto next = static_cast<unsigned char>(text[i + k]);
      if ((next & 0xC0) != 0x80) return false;
      code = (code << 6) | (next & 0x3F);
    }
    constexpr std::uint32_t kSmallest[5] = {0, 0, 0x80, 0x800, 0x10000};
    if (code < kSmallest[length] || code > 0x10FFFF || (code >= 0xD800 && code <= 0xDFFF) ||
        (code >= 0x80 && code <= 0x9F))
      return false;
    i += length;
  }
  return true;
}

}  // namespace

std::optional<Error> check_id(std::string_view id, const std::string& field) {
  const bool printable =
      std::all_of(id.begin(), id.end(), [](char c) { return c > ' ' && c < 127; });
  if (id.empty() || id.size() > kMaxIdBytes || !printable)
    return invalid_argument(
        field, text("must be 1-", kMaxIdBytes, " bytes of printable ASCII without spaces (got ",
                    id.empty() ? std::string("an empty id") : quoted(id), ")"));
  return std::nullopt;
}

std::optional<Error> check_name(std::string_view name, const std::string& field) {
  if (name.size() > kMaxNameBytes || !is_printable_utf8(name))
    return invalid_argument(
        field, text("must be at most ", kMaxNameBytes,
                    " bytes of UTF-8 text without control characters (got ", quoted(name), ")"));
  return std::nullopt;
}

Expected<Pose<double>> check_pose(const model::PoseInput& pose, const std::string& field) {
  const auto& q = pose.rotation_wxyz;
  constexpr char kComponent[4] = {'w', 'x', 'y', 'z'};
  for (int i = 0; i < 4; ++i)
    if (!std::isfinite(q[i]))
      return invalid_argument(text(field, ".rotation.", kComponent[i]),
                              text("is not finite (got ", q[i], ")"));
  const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  // NaN-safe on purpose: the negated comparison also rejects what cannot be compared.
  if (!(std::abs(norm - 1.0) <= kQuaternionNormTolerance))
    return invalid_argument(
        field + ".rotation",
        text("quaternion is not of unit length: |q| = ", norm, " (accepted: 1 +- ",
             kQuaternionNormTolerance, "; omit the rotation for the identity)"));
  if (auto error = check_vector(pose.translation, "translation")) {
    error->field = field + "." + error->field;  // spelled only for a refused pose
    return *error;
  }
  Pose<double> out;
  if (const char* why = pose_from_quaternion_checked(q[0], q[1], q[2], q[3], pose.translation, out))
    return invalid_argument(field, why);
  return out;
}

Expected<ResolvedOptions> resolve_options(const ResolvedOptions& base,
                                          const model::QueryOptionsInput& overrides,
                                          const std::string& field) {
  ResolvedOptions out = base;
  if (overrides.epsilon) {
    const double epsilon = *overrides.epsilon;
    if (!is_valid_epsilon(epsilon))  // the rule `nearpoint distance` applies too
      return invalid_argument(field + ".epsilon",
                              text("must be finite and in [0, 1) (got ", epsilon, ")"));
    out.engine.epsilon = epsilon;
  }
  if (overrides.near_points) out.engine.near_points = *overrides.near_points;
  switch (overrides.penetration) {
    case model::PenetrationMode::unspecified:
      break;
    case model::PenetrationMode::none:
      out.engine.penetration_bound = false;
      out.engine.penetration_depth = false;
      break;
    case model::PenetrationMode::bound:
      out.engine.penetration_bound = true;
      out.engine.penetration_depth = false;
      break;
    case model::PenetrationMode::depth:
      // The depth with its interval, and the signed distance; the engine's default tolerance
      // and step cap (what double allows on polytopes, an honest interval on curved shapes).
      out.engine.penetration_bound = false;
      out.engine.penetration_depth = true;
      break;
    case model::PenetrationMode::unknown:
      return invalid_argument(field + ".penetration", "unknown PenetrationMode value");
  }
  if (overrides.gradient) out.engine.gradient = *overrides.gradient;
  if (overrides.distance_cutoff) {
    const double cutoff = *overrides.distance_cutoff;
    if (!(cutoff >= 0))  // NaN-safe: rejects NaN as well as negative values
      return invalid_argument(field + ".distance_cutoff",
                              text("must be >= 0 (+inf for none) (got ", cutoff, ")"));
    out.engine.distance_cutoff = cutoff;
  }
  if (overrides.warm_start) out.warm_start = *overrides.warm_start;
  if (overrides.report_mode == model::ReportMode::unknown)
    return invalid_argument(field + ".report_mode", "unknown ReportMode value");
  if (overrides.report_mode != model::ReportMode::unspecified)
    out.report_mode = overrides.report_mode;
  if (overrides.change_tolerance) {
    const double tolerance = *overrides.change_tolerance;
    if (!(tolerance >= 0))  // NaN-safe
      return invalid_argument(
          field + ".change_tolerance",
          text("must be >= 0 metres (+inf: status changes only) (got ", tolerance, ")"));
    out.change_tolerance = tolerance;
  }
  // Without warm starts every query starts as the paper's Section VI does, from one support
  // point: the comparison of Table I, which the demo reproduces. With them, a pair's first query
  // uses the engine's default start (support point and centroids' point).
  out.engine.cold_start = out.warm_start ? ColdStart::with_centroids : ColdStart::single_point;
  if (overrides.max_iterations) {
    const std::uint64_t cap = *overrides.max_iterations;
    if (cap < 1 || cap > kMaxIterationsCap)
      return invalid_argument(field + ".max_iterations",
                              text("must be in [1, ", kMaxIterationsCap, "] (got ", cap, ")"));
    out.engine.max_iterations = static_cast<int>(cap);
  }
  return out;
}

Expected<std::shared_ptr<StoredGeometry>> build_geometry(const model::GeometryInput& geometry,
                                                         const ServiceLimits& limits) {
  if (auto error = check_name(geometry.name, "geometry.name")) return *error;
  if (geometry.pieces.empty())
    return invalid_argument("geometry.pieces", "must hold at least one piece");
  if (geometry.pieces.size() > limits.max_pieces_per_geometry)
    return resource_exhausted("geometry.pieces",
                              text("has ", geometry.pieces.size(), " pieces; the limit is ",
                                   limits.max_pieces_per_geometry, " (--max-pieces-per-geometry)"));
  std::size_t vertex_count = 0;
  for (const model::PieceInput& piece : geometry.pieces)
    if (const auto* polytope = std::get_if<model::PolytopeInput>(&piece.shape))
      vertex_count += polytope->vertices.size();
  if (vertex_count > limits.max_vertices_per_geometry)
    return resource_exhausted(
        "geometry.pieces",
        text("hold ", vertex_count, " polytope vertices; the limit is ",
             limits.max_vertices_per_geometry, " per geometry (--max-vertices-per-geometry)"));

  std::vector<Piece<double>> pieces;
  pieces.reserve(geometry.pieces.size());
  for (std::size_t i = 0; i < geometry.pieces.size(); ++i) {
    const model::PieceInput& input = geometry.pieces[i];
    const std::string field = text("geometry.pieces[", i, ']');
    if (auto error = check_length(input.radius, field + ".radius")) return *error;
    Expected<Shape<double>> shape = build_shape(input, field);
    if (!shape) return shape.error();
    Expected<Pose<double>> offset = check_pose(input.offset, field + ".offset");
    if (!offset) return offset.error();
    pieces.push_back(Piece<double>{std::move(shape.value()), offset.value()});
  }

  auto stored = std::make_shared<StoredGeometry>();
  stored->compound = Compound<double>(std::move(pieces));
  // The checks above cover everything the engine checks; this is the engine's own word.
  if (const char* why = stored->compound.invalid_reason())
    return invalid_argument("geometry.pieces", why);

  // One sphere around the pieces' spheres: centred in their bounding box, which is tight enough
  // for the broad phase and needs no iterative fitting.
  const Compound<double>& compound = stored->compound;
  model::Vec3d low = model::Vec3d::Constant(std::numeric_limits<double>::infinity());
  model::Vec3d high = -low;
  for (std::size_t i = 0; i < compound.size(); ++i) {
    const model::Vec3d reach = model::Vec3d::Constant(compound.sphere_radius(i));
    low = low.cwiseMin(compound.sphere_center(i) - reach);
    high = high.cwiseMax(compound.sphere_center(i) + reach);
  }
  const model::Vec3d center = 0.5 * (low + high);
  double radius = 0;
  for (std::size_t i = 0; i < compound.size(); ++i)
    radius =
        std::max(radius, (compound.sphere_center(i) - center).norm() + compound.sphere_radius(i));

  model::GeometryInfo& info = stored->info;
  info.name = geometry.name;
  info.piece_count = compound.size();
  info.vertex_count = vertex_count;
  info.bounding_center = center;
  // Rounding in the sum above may leave the sphere a few ulps short; a relative margin keeps it
  // a true bound (the broad phase must never skip a pair that could be within the cutoff).
  info.bounding_radius = radius * (1 + 1e-12) + 1e-12;
  return stored;
}

}  // namespace nearpoint::server
