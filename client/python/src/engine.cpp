// SPDX-License-Identifier: Apache-2.0
// nearpoint._engine: the distance engine (core/) in-process, for Python with numpy (issue 34).
//
// What crosses the boundary and how:
//  - Shapes, compounds, poses and warm-start caches are C++ objects owned by Python; a query
//    reads them without copying.
//  - Arrays in are float64 and C-contiguous numpy arrays, or plain sequences (converted). A numpy
//    array of another dtype or layout is refused with TypeError/ValueError rather than silently
//    copied: a batch caller should know when each call would copy its poses.
//  - A query the engine refuses (Status::invalid_input) raises ValueError with the engine's own
//    message; an iteration limit is a result (its status says so), not an error.
//  - The batch call converts nothing per pair into Python objects: it reads the pose arrays and
//    writes the result arrays with the GIL released, optionally on several threads.
#include <pybind11/eval.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <deque>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "nearpoint/compound.hpp"
#include "nearpoint/distance.hpp"
#if NEARPOINT_PY_HULL
#include "nearpoint/hull.hpp"
#endif

namespace py = pybind11;

namespace {

using nearpoint::Compound;
using nearpoint::DistanceOptions;
using nearpoint::DistanceResult;
using nearpoint::Piece;
using nearpoint::Pose;
using nearpoint::Shape;
using nearpoint::SimplexCache;
using nearpoint::Status;
using V3 = nearpoint::Vec3<double>;
using M3 = nearpoint::Mat3<double>;
using Array = py::array_t<double, py::array::c_style>;

// ---------------------------------------------------------------------------------------------
// Arrays

std::string dtype_name(const py::array& a) {
  return py::str(a.dtype()).cast<std::string>();
}

// A float64, C-contiguous array view of `obj`. numpy arrays must already be so (no silent copy);
// other objects (lists, tuples, scalars) are converted.
Array as_array(py::handle obj, const char* what) {
  if (py::isinstance<py::array>(obj)) {
    auto a = py::reinterpret_borrow<py::array>(obj);
    if (!py::isinstance<py::array_t<double>>(a))
      throw py::type_error(std::string(what) + ": expected a float64 array, got dtype " +
                           dtype_name(a) + " (convert with .astype(numpy.float64))");
    if (!(a.flags() & py::array::c_style))
      throw py::value_error(std::string(what) +
                            ": the array is not C-contiguous (pass numpy.ascontiguousarray(...))");
    return py::reinterpret_borrow<Array>(a);
  }
  // Plain sequences: numbers only (integers and floats), converted to float64. numpy's own
  // conversion would also take booleans and drop imaginary parts.
  py::array raw = py::array::ensure(obj);
  if (!raw) {
    PyErr_Clear();
    throw py::type_error(std::string(what) + ": expected an array of numbers, got " +
                         py::str(py::type::of(obj)).cast<std::string>());
  }
  const char kind = raw.dtype().kind();
  if (kind != 'i' && kind != 'u' && kind != 'f')
    throw py::type_error(std::string(what) + ": expected numbers, got elements of dtype " +
                         dtype_name(raw));
  Array converted = Array::ensure(raw);
  if (!converted) {
    PyErr_Clear();
    throw py::type_error(std::string(what) + ": cannot convert to float64");
  }
  return converted;
}

std::string shape_text(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t k = 0; k < a.ndim(); ++k) {
    if (k) s += ", ";
    s += std::to_string(a.shape(k));
  }
  if (a.ndim() == 1) s += ",";
  return s + ")";
}

bool all_finite(const double* p, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i)
    if (!std::isfinite(p[i])) return false;
  return true;
}

V3 vec3(py::handle obj, const char* what) {
  Array a = as_array(obj, what);
  if (a.ndim() != 1 || a.shape(0) != 3)
    throw py::value_error(std::string(what) + ": expected 3 numbers, got an array of shape " +
                          shape_text(a));
  const double* p = a.data();
  if (!all_finite(p, 3)) throw py::value_error(std::string(what) + ": a coordinate is not finite");
  return V3(p[0], p[1], p[2]);
}

double finite_scalar(double value, const char* what) {
  if (!std::isfinite(value)) throw py::value_error(std::string(what) + " is not finite");
  return value;
}

std::vector<V3> points(py::handle obj, const char* what) {
  Array a = as_array(obj, what);
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw py::value_error(std::string(what) + ": expected an (N, 3) array, got shape " +
                          shape_text(a));
  std::vector<V3> out(static_cast<std::size_t>(a.shape(0)));
  const double* p = a.data();
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = V3(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
  return out;
}

py::array_t<double> vector_out(const double* p, py::ssize_t n) {
  py::array_t<double> out(n);
  std::memcpy(out.mutable_data(), p, sizeof(double) * static_cast<std::size_t>(n));
  return out;
}
py::array_t<double> vec_out(const V3& v) {
  return vector_out(v.data(), 3);
}

// ---------------------------------------------------------------------------------------------
// Poses

// Rows of a 4×4 homogeneous matrix (row-major) into a Pose; nullptr or why not.
const char* pose_from_matrix(const double* m, Pose<double>& out) {
  if (!all_finite(m, 16)) return "pose matrix has a non-finite entry";
  if (m[12] != 0 || m[13] != 0 || m[14] != 0 || m[15] != 1)
    return "pose matrix's last row is not (0, 0, 0, 1)";
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.rotation(r, c) = m[4 * r + c];
    out.translation[r] = m[4 * r + 3];
  }
  return nullptr;
}

// (tx, ty, tz, qw, qx, qy, qz) into a Pose, through the engine's own checked constructor.
const char* pose_from_row7(const double* v, Pose<double>& out) {
  return nearpoint::pose_from_quaternion_checked<double>(v[3], v[4], v[5], v[6],
                                                         V3(v[0], v[1], v[2]), out);
}

Pose<double> pose_from_rotation(py::handle rotation, py::handle translation) {
  Array r = as_array(rotation, "rotation");
  if (r.ndim() != 2 || r.shape(0) != 3 || r.shape(1) != 3)
    throw py::value_error("rotation: expected a (3, 3) matrix, got shape " + shape_text(r));
  if (!all_finite(r.data(), 9)) throw py::value_error("rotation has a non-finite entry");
  Pose<double> pose;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) pose.rotation(i, j) = r.data()[3 * i + j];
  pose.translation = vec3(translation, "translation");
  return pose;
}

Pose<double> pose_from_quaternion(py::handle quaternion, py::handle translation) {
  Array q = as_array(quaternion, "quaternion");
  if (q.ndim() != 1 || q.shape(0) != 4)
    throw py::value_error("quaternion: expected 4 numbers (w, x, y, z), got shape " +
                          shape_text(q));
  Array t = as_array(translation, "translation");
  if (t.ndim() != 1 || t.shape(0) != 3)
    throw py::value_error("translation: expected 3 numbers, got shape " + shape_text(t));
  const double row[7] = {t.data()[0], t.data()[1], t.data()[2], q.data()[0],
                         q.data()[1], q.data()[2], q.data()[3]};
  Pose<double> pose;
  if (const char* why = pose_from_row7(row, pose)) throw py::value_error(why);
  return pose;
}

// A pose argument: a Pose, a 4×4 matrix or a (7,) row (tx, ty, tz, qw, qx, qy, qz).
Pose<double> pose_arg(py::handle obj, const char* what) {
  if (py::isinstance<Pose<double>>(obj)) return obj.cast<const Pose<double>&>();
  if (obj.is_none()) return Pose<double>{};
  Array a = as_array(obj, what);
  Pose<double> pose;
  const char* why = nullptr;
  if (a.ndim() == 2 && a.shape(0) == 4 && a.shape(1) == 4)
    why = pose_from_matrix(a.data(), pose);
  else if (a.ndim() == 1 && a.shape(0) == 7)
    why = pose_from_row7(a.data(), pose);
  else
    throw py::value_error(std::string(what) +
                          ": expected a Pose, a (4, 4) matrix or (tx, ty, tz, qw, qx, qy, qz), "
                          "got shape " +
                          shape_text(a));
  if (why) throw py::value_error(std::string(what) + ": " + why);
  return pose;
}

// ---------------------------------------------------------------------------------------------
// Shapes, compounds, caches

struct PyShape {
  Shape<double> shape;
  const char* kind = "";
};
using ShapePtr = std::shared_ptr<PyShape>;

ShapePtr make_shape(Shape<double> shape, const char* kind) {
  if (const char* why = nearpoint::invalid_reason(shape)) throw py::value_error(why);
  return std::make_shared<PyShape>(PyShape{std::move(shape), kind});
}

double rounding_arg(double r) {
  if (!(r >= 0) || !std::isfinite(r))
    throw py::value_error("rounding must be finite and non-negative");
  return r;
}

struct PyCompound {
  Compound<double> compound;
};
using CompoundPtr = std::shared_ptr<PyCompound>;

CompoundPtr make_compound(py::iterable pieces) {
  std::vector<Piece<double>> list;
  for (py::handle item : pieces) {
    if (py::isinstance<PyShape>(item)) {
      list.push_back({item.cast<const PyShape&>().shape, Pose<double>{}});
      continue;
    }
    if (!py::isinstance<py::tuple>(item) || py::len(item) != 2)
      throw py::type_error("compound: each piece is a Shape or a (Shape, pose) pair");
    auto pair = py::reinterpret_borrow<py::tuple>(item);
    if (!py::isinstance<PyShape>(pair[0]))
      throw py::type_error("compound: a piece's first element must be a Shape");
    list.push_back({pair[0].cast<const PyShape&>().shape, pose_arg(pair[1], "compound offset")});
  }
  auto out = std::make_shared<PyCompound>(PyCompound{Compound<double>(std::move(list))});
  if (const char* why = out->compound.invalid_reason()) throw py::value_error(why);
  return out;
}

// Warm-start state: one SimplexCache per piece pair (1 for two single shapes) and per row (1 for
// a single call, N for a batch). A call whose layout differs from the stored one starts cold.
struct PyCache {
  std::vector<SimplexCache> entries;
  std::size_t rows = 0;
  std::size_t stride = 0;
  SimplexCache* prepare(std::size_t n_rows, std::size_t n_stride) {
    if (n_rows != rows || n_stride != stride) {
      entries.assign(n_rows * n_stride, SimplexCache{});
      rows = n_rows;
      stride = n_stride;
    }
    return entries.data();
  }
};

// ---------------------------------------------------------------------------------------------
// Options

nearpoint::Subalgorithm subalgorithm_arg(py::handle v) {
  const auto s = py::str(v).cast<std::string>();
  if (s == "signed_volumes") return nearpoint::Subalgorithm::signed_volumes;
  if (s == "johnson") return nearpoint::Subalgorithm::johnson;
  throw py::value_error("subalgorithm: expected 'signed_volumes' or 'johnson', got '" + s + "'");
}
nearpoint::ColdStart cold_start_arg(py::handle v) {
  const auto s = py::str(v).cast<std::string>();
  if (s == "with_centroids") return nearpoint::ColdStart::with_centroids;
  if (s == "single_point") return nearpoint::ColdStart::single_point;
  throw py::value_error("cold_start: expected 'with_centroids' or 'single_point', got '" + s + "'");
}

// The keyword arguments a query takes besides its options.
struct CallArgs {
  DistanceOptions<double> options;
  py::object cache = py::none();
  int threads = 1;
  bool raise_invalid = true;
};

CallArgs parse_kwargs(const py::kwargs& kwargs, bool batch) {
  CallArgs args;
  auto& o = args.options;
  for (auto item : kwargs) {
    const auto key = item.first.cast<std::string>();
    py::handle v = item.second;
    if (key == "cache") {
      if (!v.is_none() && !py::isinstance<PyCache>(v))
        throw py::type_error("cache: expected a nearpoint.Cache or None");
      args.cache = py::reinterpret_borrow<py::object>(v);
    } else if (key == "near_points") {
      o.near_points = v.cast<bool>();
    } else if (key == "gradient") {
      o.gradient = v.cast<bool>();
    } else if (key == "penetration_bound") {
      o.penetration_bound = v.cast<bool>();
    } else if (key == "penetration_depth") {
      o.penetration_depth = v.cast<bool>();
    } else if (key == "epsilon") {
      o.epsilon = v.cast<double>();
      if (!nearpoint::is_valid_epsilon(o.epsilon))
        throw py::value_error("epsilon must be finite and in [0, 1)");
    } else if (key == "max_iterations") {
      o.max_iterations = v.cast<int>();
      if (o.max_iterations < 1) throw py::value_error("max_iterations must be at least 1");
    } else if (key == "distance_cutoff") {
      o.distance_cutoff = v.cast<double>();
      if (!(o.distance_cutoff >= 0)) throw py::value_error("distance_cutoff must be >= 0");
    } else if (key == "depth_tolerance") {
      o.depth_tolerance = v.cast<double>();
      if (!(o.depth_tolerance >= 0) || !std::isfinite(o.depth_tolerance))
        throw py::value_error("depth_tolerance must be finite and >= 0");
    } else if (key == "depth_max_iterations") {
      o.depth_max_iterations = v.cast<int>();
      if (o.depth_max_iterations < 0) throw py::value_error("depth_max_iterations must be >= 0");
    } else if (key == "origin_shift") {
      o.origin_shift = v.cast<bool>();
    } else if (key == "subalgorithm") {
      o.subalgorithm = subalgorithm_arg(v);
    } else if (key == "cold_start") {
      o.cold_start = cold_start_arg(v);
    } else if (batch && key == "threads") {
      args.threads = v.cast<int>();
      if (args.threads < 0) throw py::value_error("threads must be >= 0 (0: one per core)");
    } else if (batch && key == "errors") {
      const auto s = py::str(v).cast<std::string>();
      if (s != "raise" && s != "status")
        throw py::value_error("errors: expected 'raise' or 'status', got '" + s + "'");
      args.raise_invalid = s == "raise";
    } else {
      throw py::type_error(std::string(batch ? "distance_batch" : "distance") +
                           "() got an unexpected keyword argument '" + key + "'");
    }
  }
  return args;
}

// ---------------------------------------------------------------------------------------------
// Results

// The Python-side enums (IntEnum, so that numpy status columns compare with them directly),
// made once at import.
py::object g_status, g_termination, g_depth_termination, g_finished_by;

struct PyResult {
  DistanceResult<double> r;
  bool compound = false;
  int piece_a = -1, piece_b = -1, pairs_evaluated = 0, pairs_pruned = 0, pairs_stopped_at_best = 0,
      total_support_calls = 0, total_subalgorithm_runs = 0;
};

py::object optional_vec(bool has, const V3& v) {
  return has ? py::object(vec_out(v)) : py::object(py::none());
}
py::object optional_scalar(bool has, double v) {
  return has ? py::object(py::float_(v)) : py::object(py::none());
}

// ---------------------------------------------------------------------------------------------
// Queries

// Either side of a query: a single shape or a compound.
struct Side {
  const Shape<double>* shape = nullptr;
  const Compound<double>* compound = nullptr;
};

Side side_arg(py::handle obj, const char* what) {
  if (py::isinstance<PyShape>(obj)) return {&obj.cast<const PyShape&>().shape, nullptr};
  if (py::isinstance<PyCompound>(obj)) return {nullptr, &obj.cast<const PyCompound&>().compound};
  throw py::type_error(std::string(what) +
                       ": expected a nearpoint.Shape or nearpoint.Compound, got " +
                       py::str(py::type::of(obj)).cast<std::string>());
}

// One piece at the origin: how a single shape meets a compound.
Compound<double> as_compound(const Shape<double>& s) {
  return Compound<double>(std::vector<Piece<double>>{{s, Pose<double>{}}});
}

// Runs one query, single or compound; `caches` holds 1 or size_a·size_b entries (or is null).
// Never throws (the engine does not; a Compound wrapper is built only for mixed pairs).
void run_query(const Side& a, const Pose<double>& pa, const Side& b, const Pose<double>& pb,
               const DistanceOptions<double>& options, SimplexCache* caches, PyResult& out) {
  if (a.shape && b.shape) {
    out.r = nearpoint::distance(*a.shape, pa, *b.shape, pb, options, caches);
    return;
  }
  Compound<double> wrapped_a, wrapped_b;
  const Compound<double>& ca = a.compound ? *a.compound : (wrapped_a = as_compound(*a.shape));
  const Compound<double>& cb = b.compound ? *b.compound : (wrapped_b = as_compound(*b.shape));
  std::span<SimplexCache> span;
  if (caches) span = std::span<SimplexCache>(caches, ca.size() * cb.size());
  const auto c = nearpoint::distance(ca, pa, cb, pb, options, span);
  out.r = c.nearest;
  out.compound = true;
  out.piece_a = c.piece_a;
  out.piece_b = c.piece_b;
  out.pairs_evaluated = c.pairs_evaluated;
  out.pairs_pruned = c.pairs_pruned;
  out.pairs_stopped_at_best = c.pairs_stopped_at_best;
  out.total_support_calls = c.support_calls;
  out.total_subalgorithm_runs = c.subalgorithm_runs;
}

std::size_t side_size(const Side& s) {
  return s.compound ? s.compound->size() : 1;
}

PyResult distance(py::handle a, py::handle pose_a, py::handle b, py::handle pose_b,
                  const py::kwargs& kwargs) {
  const Side sa = side_arg(a, "a"), sb = side_arg(b, "b");
  const Pose<double> pa = pose_arg(pose_a, "pose_a"), pb = pose_arg(pose_b, "pose_b");
  CallArgs args = kwargs.empty() ? CallArgs{} : parse_kwargs(kwargs, false);
  SimplexCache* caches = nullptr;
  if (!args.cache.is_none())
    caches = args.cache.cast<PyCache&>().prepare(1, side_size(sa) * side_size(sb));
  PyResult out;
  if (sa.shape && sb.shape) {
    run_query(sa, pa, sb, pb, args.options, caches, out);
  } else {
    py::gil_scoped_release release;  // compound queries may run many pairs
    run_query(sa, pa, sb, pb, args.options, caches, out);
  }
  if (out.r.status == Status::invalid_input)
    throw py::value_error(out.r.message ? out.r.message : "invalid input");
  return out;
}

// ---------------------------------------------------------------------------------------------
// The batch call

// Poses for N rows: one pose for all, or an (N, 4, 4) / (N, 7) array read row by row.
struct PoseColumn {
  Pose<double> single;
  const double* data = nullptr;  // null: `single` for every row
  int width = 0;                 // 16 or 7
  py::ssize_t rows = 1;
  py::object keep;
  const char* get(py::ssize_t i, Pose<double>& out) const {
    if (!data) {
      out = single;
      return nullptr;
    }
    const double* row = data + i * width;
    return width == 16 ? pose_from_matrix(row, out) : pose_from_row7(row, out);
  }
};

PoseColumn pose_column(py::handle obj, const char* what) {
  PoseColumn col;
  if (obj.is_none() || py::isinstance<Pose<double>>(obj)) {
    col.single = pose_arg(obj, what);
    return col;
  }
  Array a = as_array(obj, what);
  if ((a.ndim() == 2 && a.shape(0) == 4 && a.shape(1) == 4) || (a.ndim() == 1 && a.shape(0) == 7)) {
    col.single = pose_arg(a, what);
    return col;
  }
  if (a.ndim() == 3 && a.shape(1) == 4 && a.shape(2) == 4)
    col.width = 16;
  else if (a.ndim() == 2 && a.shape(1) == 7)
    col.width = 7;
  else
    throw py::value_error(std::string(what) +
                          ": expected a Pose, an (N, 4, 4) array of matrices or an (N, 7) array "
                          "of (tx, ty, tz, qw, qx, qy, qz), got shape " +
                          shape_text(a));
  col.rows = a.shape(0);
  col.data = a.data();
  col.keep = a;
  return col;
}

struct ShapeColumn {
  std::vector<Side> sides;  // 1 (broadcast) or N
  std::vector<py::object> keep;
  // Single shapes meeting compounds, wrapped once here rather than per row on the hot path.
  std::deque<Compound<double>> wrapped;
  void wrap_singles() {
    for (Side& side : sides) {
      if (side.compound) continue;
      wrapped.push_back(as_compound(*side.shape));
      side = {nullptr, &wrapped.back()};
    }
  }
  bool any_compound = false;
  std::size_t max_pieces = 1;
};

ShapeColumn shape_column(py::handle obj, const char* what) {
  ShapeColumn col;
  auto add = [&](py::handle item) {
    col.sides.push_back(side_arg(item, what));
    col.keep.push_back(py::reinterpret_borrow<py::object>(item));
    if (col.sides.back().compound) {
      col.any_compound = true;
      col.max_pieces = std::max(col.max_pieces, col.sides.back().compound->size());
    }
  };
  if (py::isinstance<PyShape>(obj) || py::isinstance<PyCompound>(obj)) {
    add(obj);
  } else if (py::isinstance<py::sequence>(obj) && !py::isinstance<py::str>(obj)) {
    for (py::handle item : py::reinterpret_borrow<py::sequence>(obj)) add(item);
  } else {
    throw py::type_error(std::string(what) +
                         ": expected a Shape, a Compound or a sequence of them");
  }
  return col;
}

// Output columns, allocated with the GIL held; workers write through raw pointers.
struct Columns {
  py::dict arrays;
  std::uint8_t* status = nullptr;
  double *distance = nullptr, *error_bound = nullptr;
  std::int32_t* iterations = nullptr;
  std::uint8_t *termination = nullptr, *warm_started = nullptr;
  double *point_a = nullptr, *point_b = nullptr, *normal = nullptr;
  double* penetration_bound = nullptr;
  double *signed_distance = nullptr, *signed_distance_lower = nullptr,
         *signed_distance_upper = nullptr, *depth = nullptr, *depth_lower = nullptr,
         *depth_upper = nullptr, *depth_direction = nullptr, *depth_point_a = nullptr,
         *depth_point_b = nullptr;
  double *gradient_a = nullptr, *gradient_b = nullptr;
  std::int32_t *piece_a = nullptr, *piece_b = nullptr;

  template <class T>
  T* add(const char* name, py::ssize_t n, py::ssize_t width = 0) {
    py::array_t<T> a = width ? py::array_t<T>({n, width}) : py::array_t<T>(n);
    arrays[name] = a;
    return a.mutable_data();
  }
};

Columns make_columns(py::ssize_t n, const DistanceOptions<double>& o, bool compound) {
  Columns c;
  c.status = c.add<std::uint8_t>("status", n);
  c.distance = c.add<double>("distance", n);
  c.error_bound = c.add<double>("error_bound", n);
  c.iterations = c.add<std::int32_t>("iterations", n);
  c.termination = c.add<std::uint8_t>("termination", n);
  c.warm_started = c.add<std::uint8_t>("warm_started", n);
  if (o.near_points) {
    c.point_a = c.add<double>("point_a", n, 3);
    c.point_b = c.add<double>("point_b", n, 3);
    c.normal = c.add<double>("normal", n, 3);
  }
  if (o.penetration_bound) c.penetration_bound = c.add<double>("penetration_bound", n);
  if (o.penetration_depth) {
    c.signed_distance = c.add<double>("signed_distance", n);
    c.signed_distance_lower = c.add<double>("signed_distance_lower", n);
    c.signed_distance_upper = c.add<double>("signed_distance_upper", n);
    c.depth = c.add<double>("depth", n);
    c.depth_lower = c.add<double>("depth_lower", n);
    c.depth_upper = c.add<double>("depth_upper", n);
    c.depth_direction = c.add<double>("depth_direction", n, 3);
    c.depth_point_a = c.add<double>("depth_point_a", n, 3);
    c.depth_point_b = c.add<double>("depth_point_b", n, 3);
  }
  if (o.gradient) {
    c.gradient_a = c.add<double>("gradient_a", n, 6);
    c.gradient_b = c.add<double>("gradient_b", n, 6);
  }
  if (compound) {
    c.piece_a = c.add<std::int32_t>("piece_a", n);
    c.piece_b = c.add<std::int32_t>("piece_b", n);
  }
  return c;
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void put3(double* col, py::ssize_t i, bool has, const V3& v) {
  double* p = col + 3 * i;
  if (has) {
    p[0] = v[0], p[1] = v[1], p[2] = v[2];
  } else {
    p[0] = p[1] = p[2] = kNaN;
  }
}

// Fields a result does not have (near points of an invalid row, depth when not asked) are NaN.
void write_row(const Columns& c, py::ssize_t i, const PyResult& q) {
  const auto& r = q.r;
  c.status[i] = static_cast<std::uint8_t>(r.status);
  c.distance[i] = r.distance;
  c.error_bound[i] = r.error_bound;
  c.iterations[i] = r.iterations;
  c.termination[i] = static_cast<std::uint8_t>(r.termination);
  c.warm_started[i] = r.warm_started;
  if (c.point_a) {
    put3(c.point_a, i, r.has_near_points, r.point_a);
    put3(c.point_b, i, r.has_near_points, r.point_b);
    put3(c.normal, i, r.has_near_points, r.normal);
  }
  if (c.penetration_bound)
    c.penetration_bound[i] = r.has_penetration_bound ? r.penetration_bound : kNaN;
  if (c.signed_distance) {
    const bool sd = r.has_signed_distance, pd = r.has_penetration_depth;
    c.signed_distance[i] = sd ? r.signed_distance : kNaN;
    c.signed_distance_lower[i] = sd ? r.signed_distance_lower : kNaN;
    c.signed_distance_upper[i] = sd ? r.signed_distance_upper : kNaN;
    c.depth[i] = pd ? r.depth : kNaN;
    c.depth_lower[i] = pd ? r.depth_lower : kNaN;
    c.depth_upper[i] = pd ? r.depth_upper : kNaN;
    put3(c.depth_direction, i, pd, r.depth_direction);
    put3(c.depth_point_a, i, pd, r.depth_point_a);
    put3(c.depth_point_b, i, pd, r.depth_point_b);
  }
  if (c.gradient_a) {
    for (int k = 0; k < 6; ++k) {
      c.gradient_a[6 * i + k] = r.has_gradient ? r.gradient_a[k] : kNaN;
      c.gradient_b[6 * i + k] = r.has_gradient ? r.gradient_b[k] : kNaN;
    }
  }
  if (c.piece_a) {
    c.piece_a[i] = q.piece_a;
    c.piece_b[i] = q.piece_b;
  }
}

py::dict distance_batch(py::handle a, py::handle poses_a, py::handle b, py::handle poses_b,
                        const py::kwargs& kwargs) {
  CallArgs args = parse_kwargs(kwargs, true);
  ShapeColumn ca = shape_column(a, "a"), cb = shape_column(b, "b");
  const PoseColumn pa = pose_column(poses_a, "poses_a"), pb = pose_column(poses_b, "poses_b");
  if (ca.sides.empty() || cb.sides.empty())
    throw py::value_error("distance_batch: a shape sequence is empty");
  // N: the common row count of the inputs that carry rows (pose arrays, shape sequences); those
  // with one row are broadcast. A single Pose or Shape is one row.
  py::ssize_t n = -1;
  auto take = [&](bool carries, py::ssize_t rows, const char* what) {
    if (!carries || rows == 1) return;
    if (n < 0) n = rows;
    if (rows != n)
      throw py::value_error(std::string("distance_batch: ") + what + " has " +
                            std::to_string(rows) + " rows where another input has " +
                            std::to_string(n) + " (each input has one row or N)");
  };
  take(pa.data != nullptr, pa.rows, "poses_a");
  take(pb.data != nullptr, pb.rows, "poses_b");
  take(true, static_cast<py::ssize_t>(ca.sides.size()), "a");
  take(true, static_cast<py::ssize_t>(cb.sides.size()), "b");
  if (n < 0) n = 1;
  const bool compound = ca.any_compound || cb.any_compound;
  if (compound) {
    ca.wrap_singles();
    cb.wrap_singles();
  }
  Columns cols = make_columns(n, args.options, compound);

  // Caches: one row each; a row holds one entry per piece pair (the largest pair count if the
  // compounds differ by row, each row using its own prefix).
  SimplexCache* caches = nullptr;
  std::size_t stride = 1;
  if (!args.cache.is_none()) {
    stride = compound ? ca.max_pieces * cb.max_pieces : 1;
    caches = args.cache.cast<PyCache&>().prepare(static_cast<std::size_t>(n), stride);
  }

  int threads = args.threads;
  if (threads == 0) threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  // A thread costs tens of microseconds to start: each gets at least kRowsPerThread rows.
  constexpr py::ssize_t kRowsPerThread = 64;
  threads = static_cast<int>(
      std::min<py::ssize_t>(threads, std::max<py::ssize_t>(1, n / kRowsPerThread)));

  // Each worker records its first invalid row, so the caller hears of the first one overall.
  struct Invalid {
    py::ssize_t row = -1;
    const char* message = nullptr;
    bool failed = false;  // an exception (out of memory) stopped the worker
  };
  std::vector<Invalid> invalid(static_cast<std::size_t>(threads));
  auto work = [&](int t, py::ssize_t begin, py::ssize_t end) noexcept {
    const DistanceOptions<double>& options = args.options;
    PyResult q;
    try {
      for (py::ssize_t i = begin; i < end; ++i) {
        const Side& sa = ca.sides[ca.sides.size() == 1 ? 0 : static_cast<std::size_t>(i)];
        const Side& sb = cb.sides[cb.sides.size() == 1 ? 0 : static_cast<std::size_t>(i)];
        Pose<double> posa, posb;
        const char* why = pa.get(pa.data ? i : 0, posa);
        if (!why) why = pb.get(pb.data ? i : 0, posb);
        if (why) {
          q = PyResult{};
          q.r.status = Status::invalid_input;
          q.r.message = why;
        } else {
          run_query(sa, posa, sb, posb, options, caches ? caches + i * stride : nullptr, q);
        }
        write_row(cols, i, q);
        if (q.r.status == Status::invalid_input && invalid[t].row < 0)
          invalid[t] = {i, q.r.message ? q.r.message : "invalid input", false};
      }
    } catch (...) {
      invalid[t].failed = true;
    }
  };
  {
    py::gil_scoped_release release;
    if (threads <= 1) {
      work(0, 0, n);
    } else {
      std::vector<std::thread> pool;
      const py::ssize_t chunk = (n + threads - 1) / threads;
      for (int t = 1; t < threads; ++t)
        pool.emplace_back(work, t, std::min(n, t * chunk), std::min(n, (t + 1) * chunk));
      work(0, 0, std::min(n, chunk));
      for (auto& th : pool) th.join();
    }
  }
  for (const auto& inv : invalid)
    if (inv.failed) throw std::runtime_error("distance_batch: a worker failed (out of memory?)");
  if (args.raise_invalid) {
    for (const auto& inv : invalid)
      if (inv.row >= 0)
        throw py::value_error("row " + std::to_string(inv.row) + ": " + inv.message);
  }
  return cols.arrays;
}

// ---------------------------------------------------------------------------------------------

py::object make_enum(const char* name, std::vector<std::pair<const char*, int>> members,
                     py::module_& m) {
  py::list items;
  for (auto& [k, v] : members) items.append(py::make_tuple(k, v));
  py::object e = py::module_::import("enum").attr("IntEnum")(name, items);
  e.attr("__module__") = "nearpoint";
  // print(result.status) says "separated", not "0" (IntEnum prints its number since 3.11).
  e.attr("__str__") = py::eval("lambda self: self.name");
  e.attr("__format__") = py::eval("lambda self, spec: format(self.name, spec)");
  m.attr(name) = e;
  return e;
}

py::array_t<double> pose_matrix(const Pose<double>& p) {
  py::array_t<double> out({4, 4});
  double* m = out.mutable_data();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m[4 * r + c] = p.rotation(r, c);
    m[4 * r + 3] = p.translation[r];
  }
  m[12] = m[13] = m[14] = 0;
  m[15] = 1;
  return out;
}

}  // namespace

PYBIND11_MODULE(_engine, m) {
  m.doc() = "The nearpoint distance engine (C++), bound for Python: see the nearpoint package.";

  g_status = make_enum("Status",
                       {{"separated", 0},
                        {"intersecting", 1},
                        {"iteration_limit", 2},
                        {"invalid_input", 3},
                        {"touching", 4}},
                       m);
  g_termination = make_enum("Termination",
                            {{"origin_enclosed", 0},
                             {"tolerance", 1},
                             {"repeated_support", 2},
                             {"roundoff_floor", 3},
                             {"numerical_limit", 4},
                             {"beyond_cutoff", 5},
                             {"iteration_limit", 6},
                             {"contact", 7}},
                            m);
  g_depth_termination = make_enum(
      "DepthTermination",
      {{"closed_form", 0}, {"tolerance", 1}, {"iteration_limit", 2}, {"degenerate", 3}}, m);
  g_finished_by =
      make_enum("FinishedBy", {{"distance_subalgorithm", 0}, {"backup_procedure", 1}}, m);

  // ---- Pose
  py::class_<Pose<double>>(m, "Pose", R"(A rigid transformation: a point x of a shape's own frame
sits at rotation @ x + translation in the world.

Pose() is the identity; Pose(matrix) takes a 4x4 homogeneous matrix. See also from_quaternion,
from_rotation and from_translation. Rotations are used as given: the engine refuses one whose
defect max|R^T R - I| exceeds 1e-6 (ValueError at query time) and covers a smaller defect in the
result's error_bound.)")
      .def(py::init<>())
      .def(py::init([](py::handle matrix) {
             Array a = as_array(matrix, "matrix");
             if (a.ndim() != 2 || a.shape(0) != 4 || a.shape(1) != 4)
               throw py::value_error("matrix: expected a (4, 4) array, got shape " + shape_text(a));
             Pose<double> p;
             if (const char* why = pose_from_matrix(a.data(), p)) throw py::value_error(why);
             return p;
           }),
           py::arg("matrix"))
      .def_static("identity", [] { return Pose<double>{}; })
      .def_static(
          "from_matrix", [](py::handle m4) { return pose_arg(m4, "matrix"); }, py::arg("matrix"),
          "From a 4x4 homogeneous matrix (last row 0, 0, 0, 1).")
      .def_static("from_quaternion", &pose_from_quaternion, py::arg("quaternion"),
                  py::arg("translation") = py::make_tuple(0.0, 0.0, 0.0),
                  "From a unit quaternion (w, x, y, z), normalised here (refused when |q| differs "
                  "from 1 by more than 1e-4), and a translation.")
      .def_static("from_rotation", &pose_from_rotation, py::arg("rotation"),
                  py::arg("translation") = py::make_tuple(0.0, 0.0, 0.0),
                  "From a 3x3 rotation matrix (local to world) and a translation.")
      .def_static(
          "from_translation",
          [](py::handle t) {
            Pose<double> p;
            p.translation = vec3(t, "translation");
            return p;
          },
          py::arg("translation"))
      .def_property_readonly("rotation",
                             [](const Pose<double>& p) {
                               py::array_t<double> out({3, 3});
                               Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(
                                   out.mutable_data()) = p.rotation;
                               return out;
                             })
      .def_property_readonly("translation",
                             [](const Pose<double>& p) { return vec_out(p.translation); })
      .def_property_readonly("matrix", &pose_matrix, "The 4x4 homogeneous matrix.")
      .def("inverse", &Pose<double>::inverse)
      .def("__matmul__", &Pose<double>::compose, "self @ child: child's frame seen from the world.")
      .def(
          "apply",
          [](const Pose<double>& p, py::handle pts) -> py::object {
            Array a = as_array(pts, "points");
            if (a.ndim() == 1) return vec_out(p.apply(vec3(a, "point")));
            const auto v = points(a, "points");
            py::array_t<double> out({static_cast<py::ssize_t>(v.size()), py::ssize_t(3)});
            double* o = out.mutable_data();
            for (std::size_t i = 0; i < v.size(); ++i) {
              const V3 w = p.apply(v[i]);
              o[3 * i] = w[0], o[3 * i + 1] = w[1], o[3 * i + 2] = w[2];
            }
            return out;
          },
          py::arg("points"),
          "Maps a point (3,) or points (N, 3) from the local frame to the world.")
      .def("__repr__", [](const Pose<double>& p) {
        return "Pose(translation=" + py::repr(vec_out(p.translation)).cast<std::string>() + ")";
      });

  // ---- Shape
  py::class_<PyShape, ShapePtr>(m, "Shape", R"(A convex shape of the engine, with its rounding
radius (the shape is every point within `rounding` of its core). Made by box, sphere, capsule,
cylinder, cone, ellipsoid, polytope, hull ...; immutable.)")
      .def_property_readonly("kind", [](const PyShape& s) { return s.kind; })
      .def_property_readonly(
          "rounding", [](const PyShape& s) { return s.shape.radius; },
          "The spherical-extension radius (0: not rounded).")
      .def_property_readonly(
          "center", [](const PyShape& s) { return vec_out(nearpoint::core_center(s.shape)); },
          "The core's centre z (local frame): the vertex mean of a polytope.")
      .def_property_readonly(
          "extent", [](const PyShape& s) { return nearpoint::core_extent(s.shape); },
          "max |z - center| over the core.")
      .def_property_readonly(
          "vertices",
          [](const PyShape& s) -> py::object {
            const auto* poly = std::get_if<nearpoint::Polytope<double>>(&s.shape.geometry);
            if (!poly) return py::none();
            py::array_t<double> out({static_cast<py::ssize_t>(poly->size()), py::ssize_t(3)});
            double* o = out.mutable_data();
            for (std::size_t i = 0; i < poly->size(); ++i) {
              const V3 v = poly->vertex(i);
              o[3 * i] = v[0], o[3 * i + 1] = v[1], o[3 * i + 2] = v[2];
            }
            return out;
          },
          "A polytope's vertices (N, 3) as given; None for other shapes.")
      .def(
          "support",
          [](const PyShape& s, py::handle direction) {
            int index = -1;
            const V3 p = nearpoint::support(s.shape, vec3(direction, "direction"), index);
            return py::make_tuple(vec_out(p), index);
          },
          py::arg("direction"),
          "(point, vertex index or -1): the core's support point along `direction`, local frame.")
      .def("__repr__", [](const PyShape& s) {
        std::string r = std::string("Shape(") + s.kind;
        if (s.shape.radius != 0) r += ", rounding=" + std::to_string(s.shape.radius);
        return r + ")";
      });

  m.def(
      "box",
      [](py::handle half_extents, double rounding) {
        return make_shape(Shape<double>(nearpoint::Box<double>{vec3(half_extents, "half_extents")},
                                        rounding_arg(rounding)),
                          "box");
      },
      py::arg("half_extents"), py::arg("rounding") = 0.0,
      "The box [-h, h] (local frame), h = half_extents; rounding > 0 rounds its edges.");
  m.def(
      "sphere",
      [](double radius) {
        return make_shape(Shape<double>::sphere(finite_scalar(radius, "radius")), "sphere");
      },
      py::arg("radius"), "The sphere of `radius` about the local origin.");
  m.def(
      "point", [] { return make_shape(Shape<double>(nearpoint::Point{}), "point"); },
      "A single point at the local origin.");
  m.def(
      "capsule",
      [](py::handle a, py::handle b, double radius) {
        return make_shape(
            Shape<double>::capsule(vec3(a, "a"), vec3(b, "b"), finite_scalar(radius, "radius")),
            "capsule");
      },
      py::arg("a"), py::arg("b"), py::arg("radius"),
      "Every point within `radius` of the segment a-b (local frame).");
  m.def(
      "segment",
      [](py::handle a, py::handle b) {
        return make_shape(Shape<double>(nearpoint::Segment<double>{vec3(a, "a"), vec3(b, "b")}),
                          "segment");
      },
      py::arg("a"), py::arg("b"), "The segment a-b (local frame).");
  m.def(
      "cylinder",
      [](double radius, double half_height, double rounding) {
        return make_shape(
            Shape<double>(nearpoint::Cylinder<double>{radius, half_height}, rounding_arg(rounding)),
            "cylinder");
      },
      py::arg("radius"), py::arg("half_height"), py::arg("rounding") = 0.0,
      "The solid cylinder about the local z axis, z in [-half_height, half_height].");
  m.def(
      "cone",
      [](double radius, double half_height, double rounding) {
        return make_shape(
            Shape<double>(nearpoint::Cone<double>{radius, half_height}, rounding_arg(rounding)),
            "cone");
      },
      py::arg("radius"), py::arg("half_height"), py::arg("rounding") = 0.0,
      "The solid cone about the local z axis: base of `radius` at z = -half_height, apex at "
      "+half_height.");
  m.def(
      "ellipsoid",
      [](py::handle radii, double rounding) {
        return make_shape(Shape<double>(nearpoint::Ellipsoid<double>{vec3(radii, "radii")},
                                        rounding_arg(rounding)),
                          "ellipsoid");
      },
      py::arg("radii"), py::arg("rounding") = 0.0,
      "The solid ellipsoid x^2/rx^2 + y^2/ry^2 + z^2/rz^2 <= 1, radii = (rx, ry, rz).");
  m.def(
      "polytope",
      [](py::handle vertices, double rounding, py::object faces) {
        const auto v = points(vertices, "vertices");
        if (faces.is_none())
          return make_shape(Shape<double>(nearpoint::Polytope<double>(v), rounding_arg(rounding)),
                            "polytope");
        std::vector<std::vector<int>> f;
        for (py::handle face : faces) {
          std::vector<int> cycle;
          for (py::handle index : face) cycle.push_back(index.cast<int>());
          f.push_back(std::move(cycle));
        }
        nearpoint::Polytope<double> poly(std::span<const V3>(v.data(), v.size()),
                                         std::span<const std::vector<int>>(f.data(), f.size()));
        if (const char* why = poly.invalid_reason()) throw py::value_error(why);
        return make_shape(Shape<double>(std::move(poly), rounding_arg(rounding)), "polytope");
      },
      py::arg("vertices"), py::arg("rounding") = 0.0, py::arg("faces") = py::none(),
      "The convex hull of `vertices` (N, 3) float64. With `faces` (the hull's faces as vertex "
      "cycles, counter-clockwise from outside; checked) large polytopes climb their edges "
      "instead of scanning.");
#if NEARPOINT_PY_HULL
  m.def(
      "hull",
      [](py::handle pts, double rounding) {
        const auto v = points(pts, "points");
        auto poly = nearpoint::hull_polytope(std::span<const V3>(v.data(), v.size()));
        if (const char* why = poly.invalid_reason()) throw py::value_error(why);
        return make_shape(Shape<double>(std::move(poly), rounding_arg(rounding)), "polytope");
      },
      py::arg("points"), py::arg("rounding") = 0.0,
      "The convex hull of `points` (N, 3), computed with exact predicates and reduced to its "
      "vertices (with its faces, so that large hulls climb their edges).");
  m.def(
      "convex_hull",
      [](py::handle pts) {
        const auto v = points(pts, "points");
        if (v.empty()) throw py::value_error("convex_hull: no points");
        for (const auto& p : v)
          if (!p.allFinite()) throw py::value_error("convex_hull: a coordinate is not finite");
        const auto h = nearpoint::convex_hull(std::span<const V3>(v.data(), v.size()));
        py::array_t<double> verts({static_cast<py::ssize_t>(h.vertices.size()), py::ssize_t(3)});
        for (std::size_t i = 0; i < h.vertices.size(); ++i)
          for (int k = 0; k < 3; ++k) verts.mutable_data()[3 * i + k] = h.vertices[i][k];
        py::dict out;
        out["dimension"] = h.dimension;
        out["vertices"] = verts;
        out["input_index"] =
            py::array_t<int>(static_cast<py::ssize_t>(h.input_index.size()), h.input_index.data());
        out["faces"] = h.faces;
        return out;
      },
      py::arg("points"),
      "The hull of `points` as a dict: dimension (0-3), vertices (M, 3), input_index (M,), "
      "faces (vertex cycles, counter-clockwise from outside).");
#endif

  // ---- Compound
  py::class_<PyCompound, CompoundPtr>(m, "Compound", R"(A union of convex pieces, each a Shape
placed in the object's frame by an offset pose: Compound([(shape, pose), shape, ...]).
The distance to a compound is the least over its pieces.)")
      .def(py::init(&make_compound), py::arg("pieces"))
      .def("__len__", [](const PyCompound& c) { return c.compound.size(); })
      .def("__repr__", [](const PyCompound& c) {
        return "Compound(" + std::to_string(c.compound.size()) + " pieces)";
      });

  // ---- Cache
  py::class_<PyCache, std::shared_ptr<PyCache>>(m, "Cache", R"(Warm-start state (the paper's
Section VIII): the final simplex's vertex indices, per piece pair and per batch row. Pass the
same Cache to successive queries of the same pair(s) as the poses move; a query whose layout
(rows, piece pairs) differs from the stored one starts cold.)")
      .def(py::init<>())
      .def(
          "reset", [](PyCache& c) { c = PyCache{}; }, "Forget everything: the next query is cold.")
      .def_property_readonly("rows", [](const PyCache& c) { return c.rows; })
      .def_property_readonly("entries", [](const PyCache& c) { return c.entries.size(); })
      .def(
          "simplex",
          [](const PyCache& c, std::size_t i) {
            if (i >= c.entries.size()) throw py::index_error("cache entry out of range");
            const auto& e = c.entries[i];
            py::list pairs;
            for (int k = 0; k < e.count; ++k)
              pairs.append(py::make_tuple(e.index_a[k], e.index_b[k]));
            return pairs;
          },
          py::arg("entry") = 0, "The cached simplex of one entry as (index_a, index_b) pairs.")
      .def("__repr__", [](const PyCache& c) {
        return "Cache(rows=" + std::to_string(c.rows) +
               ", entries=" + std::to_string(c.entries.size()) + ")";
      });

  // ---- Result
  py::class_<PyResult>(m, "Result", R"(What a distance query returns: every field of the engine's
DistanceResult (see core/include/nearpoint/result.hpp). Fields that were not asked for (or do not
apply) are None; has_* say which are present. Points and directions are world frame.)")
      .def_property_readonly("status", [](const PyResult& q) { return g_status(int(q.r.status)); })
      .def_property_readonly("distance", [](const PyResult& q) { return q.r.distance; })
      .def_property_readonly("error_bound", [](const PyResult& q) { return q.r.error_bound; })
      .def_property_readonly("gap", [](const PyResult& q) { return q.r.gap; })
      .def_property_readonly("diameter_bound", [](const PyResult& q) { return q.r.diameter_bound; })
      .def_property_readonly("iterations", [](const PyResult& q) { return q.r.iterations; })
      .def_property_readonly("support_calls", [](const PyResult& q) { return q.r.support_calls; })
      .def_property_readonly("subalgorithm_runs",
                             [](const PyResult& q) { return q.r.subalgorithm_runs; })
      .def_property_readonly("termination",
                             [](const PyResult& q) { return g_termination(int(q.r.termination)); })
      .def_property_readonly("warm_started", [](const PyResult& q) { return q.r.warm_started; })
      .def_property_readonly("finished_by",
                             [](const PyResult& q) { return g_finished_by(int(q.r.finished_by)); })
      .def_property_readonly(
          "simplex",
          [](const PyResult& q) {
            py::list out;
            for (int k = 0; k < q.r.simplex_size; ++k)
              out.append(py::make_tuple(q.r.index_a[k], q.r.index_b[k], q.r.weights[k]));
            return out;
          },
          "The final simplex as (index_a, index_b, weight) triples.")
      .def_property_readonly("has_near_points",
                             [](const PyResult& q) { return q.r.has_near_points; })
      .def_property_readonly(
          "point_a",
          [](const PyResult& q) { return optional_vec(q.r.has_near_points, q.r.point_a); })
      .def_property_readonly(
          "point_b",
          [](const PyResult& q) { return optional_vec(q.r.has_near_points, q.r.point_b); })
      .def_property_readonly(
          "normal", [](const PyResult& q) { return optional_vec(q.r.has_near_points, q.r.normal); })
      .def_property_readonly("has_penetration_bound",
                             [](const PyResult& q) { return q.r.has_penetration_bound; })
      .def_property_readonly("penetration_bound",
                             [](const PyResult& q) {
                               return optional_scalar(q.r.has_penetration_bound,
                                                      q.r.penetration_bound);
                             })
      .def_property_readonly("has_signed_distance",
                             [](const PyResult& q) { return q.r.has_signed_distance; })
      .def_property_readonly("signed_distance",
                             [](const PyResult& q) {
                               return optional_scalar(q.r.has_signed_distance, q.r.signed_distance);
                             })
      .def_property_readonly("signed_distance_interval",
                             [](const PyResult& q) -> py::object {
                               if (!q.r.has_signed_distance) return py::none();
                               return py::make_tuple(q.r.signed_distance_lower,
                                                     q.r.signed_distance_upper);
                             })
      .def_property_readonly("has_penetration_depth",
                             [](const PyResult& q) { return q.r.has_penetration_depth; })
      .def_property_readonly(
          "depth",
          [](const PyResult& q) { return optional_scalar(q.r.has_penetration_depth, q.r.depth); })
      .def_property_readonly("depth_interval",
                             [](const PyResult& q) -> py::object {
                               if (!q.r.has_penetration_depth) return py::none();
                               return py::make_tuple(q.r.depth_lower, q.r.depth_upper);
                             })
      .def_property_readonly("depth_point_a",
                             [](const PyResult& q) {
                               return optional_vec(q.r.has_penetration_depth, q.r.depth_point_a);
                             })
      .def_property_readonly("depth_point_b",
                             [](const PyResult& q) {
                               return optional_vec(q.r.has_penetration_depth, q.r.depth_point_b);
                             })
      .def_property_readonly("depth_direction",
                             [](const PyResult& q) {
                               return optional_vec(q.r.has_penetration_depth, q.r.depth_direction);
                             })
      .def_property_readonly("depth_termination",
                             [](const PyResult& q) -> py::object {
                               if (!q.r.has_penetration_depth) return py::none();
                               return g_depth_termination(int(q.r.depth_termination));
                             })
      .def_property_readonly("depth_iterations",
                             [](const PyResult& q) { return q.r.depth_iterations; })
      .def_property_readonly("has_gradient", [](const PyResult& q) { return q.r.has_gradient; })
      .def_property_readonly("gradient_a",
                             [](const PyResult& q) -> py::object {
                               if (!q.r.has_gradient) return py::none();
                               return vector_out(q.r.gradient_a.data(), 6);
                             })
      .def_property_readonly("gradient_b",
                             [](const PyResult& q) -> py::object {
                               if (!q.r.has_gradient) return py::none();
                               return vector_out(q.r.gradient_b.data(), 6);
                             })
      .def_property_readonly("converged", [](const PyResult& q) { return q.r.converged(); })
      .def_property_readonly("in_contact", [](const PyResult& q) { return q.r.in_contact(); })
      .def_property_readonly("beyond_cutoff", [](const PyResult& q) { return q.r.beyond_cutoff(); })
      .def_property_readonly("depth_converged",
                             [](const PyResult& q) { return q.r.depth_converged(); })
      .def_property_readonly(
          "compound", [](const PyResult& q) { return q.compound; },
          "True when either side was a Compound (the piece fields apply).")
      .def_property_readonly("piece_a", [](const PyResult& q) { return q.piece_a; })
      .def_property_readonly("piece_b", [](const PyResult& q) { return q.piece_b; })
      .def_property_readonly("pairs_evaluated", [](const PyResult& q) { return q.pairs_evaluated; })
      .def_property_readonly("pairs_pruned", [](const PyResult& q) { return q.pairs_pruned; })
      .def_property_readonly("pairs_stopped_at_best",
                             [](const PyResult& q) { return q.pairs_stopped_at_best; })
      .def_property_readonly(
          "total_support_calls",
          [](const PyResult& q) { return q.compound ? q.total_support_calls : q.r.support_calls; })
      .def_property_readonly("total_subalgorithm_runs",
                             [](const PyResult& q) {
                               return q.compound ? q.total_subalgorithm_runs
                                                 : q.r.subalgorithm_runs;
                             })
      .def("__repr__", [](const PyResult& q) {
        return "Result(status=" +
               py::str(g_status(int(q.r.status)).attr("name")).cast<std::string>() +
               ", distance=" + py::repr(py::float_(q.r.distance)).cast<std::string>() +
               ", error_bound=" + py::repr(py::float_(q.r.error_bound)).cast<std::string>() + ")";
      });

  m.def("distance", &distance, py::arg("a"), py::arg("pose_a"), py::arg("b"), py::arg("pose_b"),
        R"(Distance between shape (or compound) `a` at `pose_a` and `b` at `pose_b`.

Poses: a Pose, a (4, 4) matrix or (tx, ty, tz, qw, qx, qy, qz). Keyword options (all off or at
the engine's defaults): near_points, penetration_bound, gradient, penetration_depth, epsilon,
max_iterations, distance_cutoff, depth_tolerance, depth_max_iterations, origin_shift,
subalgorithm ('signed_volumes' | 'johnson'), cold_start ('with_centroids' | 'single_point'),
and cache (a nearpoint.Cache, read as a warm start and updated). Raises ValueError with the
engine's message when the input is unusable.)");
  m.def("distance_batch", &distance_batch, py::arg("a"), py::arg("poses_a"), py::arg("b"),
        py::arg("poses_b"), "See nearpoint.distance_batch.");
}
