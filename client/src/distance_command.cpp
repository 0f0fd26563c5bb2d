// SPDX-License-Identifier: Apache-2.0
#include "distance_command.hpp"

#include <cmath>
#include <exception>
#include <istream>
#include <ostream>
#include <utility>

#include "nearpoint/distance.hpp"
#include "nearpoint/model/vocabulary.hpp"
#include "nearpoint/options.hpp"

namespace nearpoint::cli {
namespace {

// A problem with one input line: becomes that line's "status": "error" answer.
struct LineError {
  std::string message;
};

// What one line asks for, beyond the shapes.
struct LineOptions {
  DistanceOptions<double> engine;  // the engine's defaults (options.hpp) unless the line says
  model::PenetrationMode penetration = model::PenetrationMode::none;
  bool warm = false;
};

std::string in_quotes(std::string_view name) {
  return "\"" + std::string(name) + "\"";
}

// parse_json's messages say "parse error at line 1, column 5: "; the line is ours to number, so
// keep the column and the explanation.
std::string without_line_one(std::string text) {
  if (const std::size_t at = text.find("line 1, "); at != std::string::npos)
    text.erase(at, std::string_view("line 1, ").size());  // "parse error at column 5: …"
  return text;
}

// JSON has no NaN or Infinity; say so when a line seems to have tried one.
bool mentions_non_finite(std::string_view line) {
  for (const std::string_view word : {"NaN", "nan", "Infinity", "infinity", "inf", "Inf"}) {
    if (line.find(word) != std::string_view::npos) return true;
  }
  return false;
}

bool read_bool(const Json& options, const char* key, bool& out) {
  if (!options.contains(key)) return true;
  const Json& value = options[key];
  if (!value.is_boolean()) return false;
  out = value.get<bool>();
  return true;
}

LineOptions parse_options(const Json& options) {
  LineOptions out;
  if (!options.is_object())
    throw LineError{R"("options" must be an object such as {"near_points": true} (got )" +
                    describe_type(options) + ")"};
  for (const auto& [key, ignored] : options.items()) {
    if (key != "epsilon" && key != "near_points" && key != "penetration" && key != "warm")
      throw LineError{"unknown option " + user_key(key) +
                      "; the options are epsilon, near_points, penetration and warm"};
  }
  if (options.contains("epsilon")) {
    const Json& epsilon = options["epsilon"];
    // The server's rule (nearpoint::is_valid_epsilon): a line the CLI answers, nearpointd answers.
    if (!epsilon.is_number() || !is_valid_epsilon(epsilon.get<double>()))
      throw LineError{R"("options.epsilon" must be a number in [0, 1) (got )" +
                      (epsilon.is_number() ? epsilon.dump() : describe_type(epsilon)) + ")"};
    out.engine.epsilon = epsilon.get<double>();
  }
  if (!read_bool(options, "near_points", out.engine.near_points))
    throw LineError{R"("options.near_points" must be true or false (got )" +
                    describe_type(options["near_points"]) + ")"};
  if (!read_bool(options, "warm", out.warm))
    throw LineError{R"("options.warm" must be true or false (got )" +
                    describe_type(options["warm"]) + ")"};
  if (options.contains("penetration")) {
    const Json& penetration = options["penetration"];
    const std::string expected =
        R"("options.penetration" must be )" + model::spellings<model::PenetrationMode>("\"");
    if (!penetration.is_string())
      throw LineError{expected + " (got " + describe_type(penetration) + ")"};
    const std::string& name = penetration.get_ref<const std::string&>();
    out.penetration = model::from_spelling<model::PenetrationMode>(name);
    if (out.penetration == model::PenetrationMode::unknown)
      throw LineError{expected + " (got " + user_key(name) + ")"};
  }
  out.engine.penetration_bound = out.penetration == model::PenetrationMode::bound;
  out.engine.penetration_depth = out.penetration == model::PenetrationMode::depth;
  return out;
}

PlacedShape parse_placed_shape(const Json& line, const char* key) {
  if (!line.contains(key))
    throw LineError{"missing " + in_quotes(key) +
                    R"( (a SHAPE such as {"sphere": {}, "radius": 1}))"};
  PlacedShape placed;
  if (std::string error = parse_shape(line[key], key, placed); !error.empty())
    throw LineError{std::move(error)};
  return placed;
}

// The shape without its pose: two lines whose shapes compare equal this way differ only in where
// the shapes are, so the vertex indices of a simplex cache keep their meaning from one to the next.
Json without_pose(const Json& shape) {
  Json out = shape;
  out.erase("pose");
  return out;
}

Json vector_json(const Vec3<double>& v) {
  return Json::array({v[0], v[1], v[2]});
}

bool all_finite(const DistanceResult<double>& r) {
  return std::isfinite(r.distance) && std::isfinite(r.error_bound) &&
         std::isfinite(r.penetration_bound) && r.point_a.allFinite() && r.point_b.allFinite() &&
         r.normal.allFinite() && std::isfinite(r.signed_distance) &&
         std::isfinite(r.signed_distance_lower) && std::isfinite(r.signed_distance_upper) &&
         std::isfinite(r.depth) && std::isfinite(r.depth_lower) && std::isfinite(r.depth_upper) &&
         r.depth_point_a.allFinite() && r.depth_point_b.allFinite() &&
         r.depth_direction.allFinite();
}

}  // namespace

const char* status_name(Status status) {
  // The contract's names are the engine's, except that unusable input is an "error" line.
  return status == Status::invalid_input ? "error" : to_string(status);
}

Json DistanceSession::answer_json(std::string_view text, long line_number) {
  // Whatever happens on this line, the warm chain continues only through a warm query that
  // succeeds; take it out now so that every error below ends it.
  std::optional<WarmChain> previous = std::move(chain_);
  chain_.reset();

  Json out = Json::object();
  out["id"] = nullptr;
  try {
    // Nesting is bounded (formats::kMaxNestingDepth) before anything is built: the id is copied
    // into the answer and dumped, recursively, and a line nested 100,000 deep overflowed the stack.
    Json line;
    int error_id = 0;
    if (std::string error = formats::parse_json(text, line, &error_id); !error.empty()) {
      const std::string detail = without_line_one(std::move(error));
      std::string message = "not valid JSON: " + detail;
      if (error_id == 406 ||
          (detail.find("invalid literal") != std::string::npos && mentions_non_finite(text)))
        message += " (JSON has no NaN or Infinity: every number must be finite)";
      throw LineError{std::move(message)};
    }
    if (!line.is_object())
      throw LineError{
          "a line must be a JSON object such as {\"id\": 1, \"a\": SHAPE, \"b\": "
          "SHAPE} (got " +
          describe_type(line) + ")"};
    if (line.contains("id")) out["id"] = line["id"];
    for (const auto& [key, ignored] : line.items()) {
      if (key != "id" && key != "a" && key != "b" && key != "options")
        throw LineError{"unknown key " + user_key(key) +
                        R"(; a line has "id", "a", "b" and "options")"};
    }

    const LineOptions options =
        line.contains("options") ? parse_options(line["options"]) : LineOptions{};
    const PlacedShape a = parse_placed_shape(line, "a");
    const PlacedShape b = parse_placed_shape(line, "b");

    SimplexCache cache{};  // zeroed: a cold start
    Json shape_a;
    Json shape_b;
    if (options.warm) {
      shape_a = without_pose(line["a"]);
      shape_b = without_pose(line["b"]);
      if (previous && previous->shape_a == shape_a && previous->shape_b == shape_b)
        cache = previous->cache;
    }
    const DistanceResult<double> r =
        distance(a.shape, a.pose, b.shape, b.pose, options.engine, options.warm ? &cache : nullptr);
    if (r.status == Status::invalid_input)
      throw LineError{r.message != nullptr ? r.message : "the engine rejected the input"};
    if (!all_finite(r))
      throw LineError{
          "the engine returned a non-finite number, which it must never do: please "
          "report this line"};

    out["status"] = status_name(r.status);
    out["distance"] = r.distance + 0.0;  // + 0.0 turns a -0 into 0
    if (options.engine.near_points && r.has_near_points) {
      out["point_a"] = vector_json(r.point_a);
      out["point_b"] = vector_json(r.point_b);
      // The normal is undefined (zero) when the cores intersect: no field rather than a fake.
      if (r.normal.squaredNorm() > 0) out["normal"] = vector_json(r.normal);
    }
    out["error_bound"] = r.error_bound + 0.0;
    out["iterations"] = r.iterations;
    out["warm_started"] = r.warm_started;
    const bool contact = r.status == Status::intersecting || r.status == Status::touching;
    if (options.penetration == model::PenetrationMode::bound && contact && r.has_penetration_bound)
      out["penetration_bound"] = r.penetration_bound + 0.0;
    if (options.penetration == model::PenetrationMode::depth) {
      // The same keys as the reports of `stream` and `query` (client/schema/report.schema.json).
      if (r.has_signed_distance) {
        out["signed_distance"] = r.signed_distance + 0.0;
        out["signed_distance_lower"] = r.signed_distance_lower + 0.0;
        out["signed_distance_upper"] = r.signed_distance_upper + 0.0;
      }
      if (r.has_penetration_depth) {
        out["penetration_depth"] = r.depth + 0.0;
        out["penetration_depth_lower"] = r.depth_lower + 0.0;
        out["penetration_depth_upper"] = r.depth_upper + 0.0;
        // Witnesses and direction only where they are defined: a separated pair's are its near
        // points (asked for with near_points), an overlapping pair's the expansion's.
        if (r.depth_direction.squaredNorm() > 0) {
          out["depth_point_a"] = vector_json(r.depth_point_a);
          out["depth_point_b"] = vector_json(r.depth_point_b);
          out["depth_direction"] = vector_json(r.depth_direction);
        }
        out["depth_termination"] = to_string(r.depth_termination);
        out["depth_iterations"] = r.depth_iterations;
      }
    }
    if (r.status == Status::iteration_limit)
      out["message"] = "line " + std::to_string(line_number) +
                       ": the iteration cap was reached before the stopping rule (eq. 35) held; "
                       "distance is an upper bound, within error_bound of the true distance";
    if (options.warm) chain_ = WarmChain{std::move(shape_a), std::move(shape_b), cache};
    return out;
  } catch (const LineError& e) {
    out["status"] = "error";
    out["message"] = "line " + std::to_string(line_number) + ": " + e.message;
    return out;
  }
}

std::string DistanceSession::answer(std::string_view line, long line_number) noexcept {
  try {
    // Replace, not throw, on invalid UTF-8: input strings were validated by the parser, but the
    // output must be valid JSON whatever happens.
    return answer_json(line, line_number)
        .dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
  } catch (const std::exception& e) {
    // Only reachable through exhausted memory or a bug; still one well-formed error line.
    chain_.reset();
    Json out = Json::object();
    out["id"] = nullptr;
    out["status"] = "error";
    out["message"] = "line " + std::to_string(line_number) + ": internal error: " + e.what();
    return out.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
  }
}

int run_distance(std::istream& in, std::ostream& out, const DistanceCommandOptions& options) {
  const auto complain = [&](const std::string& what) {
    if (options.diagnostics != nullptr)
      *options.diagnostics << "nearpoint distance: " << what << '\n' << std::flush;
  };
  try {
    DistanceSession session;
    std::string line;
    long line_number = 0;
    for (;;) {
      // About to wait for input that is not buffered yet: let the reader see what we have.
      if (in.rdbuf() == nullptr || in.rdbuf()->in_avail() <= 0) out.flush();
      if (!std::getline(in, line)) break;
      ++line_number;
      if (line.find_first_not_of(" \t\r\n\f\v") == std::string::npos) continue;  // blank
      if (!line.empty() && line.back() == '\r') line.pop_back();                 // CRLF input
      out << session.answer(line, line_number) << '\n';
      if (!out) {
        complain("cannot write the output");
        return kExitIoError;
      }
    }
    out.flush();
    if (in.bad()) {
      complain("cannot read " + options.input_name + " (stopped after line " +
               std::to_string(line_number) + ")");
      return kExitIoError;
    }
    if (!out) {
      complain("cannot write the output");
      return kExitIoError;
    }
    return kExitOk;
  } catch (const std::exception& e) {
    complain(std::string("I/O failure: ") + e.what());
    return kExitIoError;
  }
}

}  // namespace nearpoint::cli
