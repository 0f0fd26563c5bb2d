// SPDX-License-Identifier: Apache-2.0
// `nearpoint distance` without a process: run_distance on string streams, checked against the
// contract in docs/design.md ("`nearpoint distance` JSON Lines contract") and against direct calls
// of nearpoint::distance on the same shapes.
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "distance_command.hpp"
#include "json_shapes.hpp"
#include "nearpoint/distance.hpp"

namespace nearpoint::cli {
namespace {

using Vec = Vec3<double>;

struct CommandRun {
  int exit_code = -1;
  std::vector<std::string> lines;  // raw output lines
  std::vector<Json> json;          // the same, parsed
  std::string diagnostics;
};

CommandRun run(const std::string& input) {
  std::istringstream in(input);
  std::ostringstream out;
  std::ostringstream diagnostics;
  DistanceCommandOptions options;
  options.diagnostics = &diagnostics;
  CommandRun result;
  result.exit_code = run_distance(in, out, options);
  result.diagnostics = diagnostics.str();
  std::istringstream lines(out.str());
  for (std::string line; std::getline(lines, line);) {
    result.lines.push_back(line);
    result.json.push_back(Json::parse(line));  // every output line must be JSON
  }
  return result;
}

// One input line → its one output object.
Json answer(const std::string& line) {
  CommandRun r = run(line + "\n");
  EXPECT_EQ(r.exit_code, kExitOk);
  EXPECT_EQ(r.json.size(), 1u) << line;
  return r.json.empty() ? Json() : r.json.front();
}

Vec vec(const Json& array) {
  return Vec(array.at(0).get<double>(), array.at(1).get<double>(), array.at(2).get<double>());
}

std::vector<std::string> keys(const Json& object) {
  std::vector<std::string> out;
  for (const auto& [key, ignored] : object.items()) out.push_back(key);
  return out;
}

// The answer to a line that must not be an error.
Json computed(const std::string& line) {
  Json out = answer(line);
  EXPECT_NE(out["status"], "error") << out.dump();
  return out;
}

// Pose from a quaternion (w, x, y, z), normalised, and a translation.
Pose<double> pose(double w, double x, double y, double z, const Vec& t) {
  return Pose<double>::from_quaternion(Eigen::Quaterniond(w, x, y, z), t);
}

const char* kSpherePair =
    R"("a": {"sphere": {}, "radius": 1}, "b": {"sphere": {}, "radius": 0.5, "pose": )"
    R"({"translation": [3, 0, 0]}})";

// --- the contract, field by field ---------------------------------------------------------------

TEST(DistanceCommand, SeparatedLineHasTheContractFieldsInOrder) {
  const Json out = computed(std::string(R"({"id": "s", )") + kSpherePair +
                            R"(, "options": {"near_points": true}})");
  EXPECT_EQ(keys(out),
            (std::vector<std::string>{"id", "status", "distance", "point_a", "point_b", "normal",
                                      "error_bound", "iterations", "warm_started"}));
  EXPECT_EQ(out["id"], "s");
  EXPECT_EQ(out["status"], "separated");
  const double error_bound = out["error_bound"].get<double>();
  EXPECT_GE(error_bound, 0.0);
  EXPECT_LT(error_bound, 1e-9);
  EXPECT_NEAR(out["distance"].get<double>(), 1.5, error_bound + 1e-15);
  EXPECT_LT((vec(out["point_a"]) - Vec(1, 0, 0)).norm(), 1e-12);
  EXPECT_LT((vec(out["point_b"]) - Vec(2.5, 0, 0)).norm(), 1e-12);
  EXPECT_LT((vec(out["normal"]) - Vec(1, 0, 0)).norm(), 1e-12);
  EXPECT_TRUE(out["iterations"].is_number_integer());
  EXPECT_GE(out["iterations"].get<int>(), 0);
  EXPECT_EQ(out["warm_started"], false);
}

TEST(DistanceCommand, IntersectingLineHasDistanceZeroAndNoNormalWhenCoresOverlap) {
  const Json out = computed(
      R"({"id": 1, "a": {"box": [1, 1, 1]}, "b": {"box": [1, 1, 1], "pose": {"translation": )"
      R"([0.5, 0.5, 0]}}, "options": {"near_points": true}})");
  EXPECT_EQ(out["status"], "intersecting");
  EXPECT_EQ(out["distance"].get<double>(), 0.0);
  EXPECT_FALSE(out.contains("normal")) << out.dump();  // undefined: left out, not a zero vector
  EXPECT_FALSE(out.contains("penetration_bound"));     // not asked
  EXPECT_FALSE(out.contains("message"));
}

TEST(DistanceCommand, NearPointsOnlyWhenAsked) {
  const std::string pair = std::string("{") + kSpherePair;
  for (const std::string& options : {std::string("}"), std::string(R"(, "options": {}})"),
                                     std::string(R"(, "options": {"near_points": false}})")}) {
    const Json out = computed(pair + options);
    EXPECT_EQ(out["status"], "separated");
    EXPECT_FALSE(out.contains("point_a")) << options;
    EXPECT_FALSE(out.contains("point_b")) << options;
    EXPECT_FALSE(out.contains("normal")) << options;
  }
  const Json out = computed(pair + R"(, "options": {"near_points": true}})");
  EXPECT_TRUE(out.contains("point_a"));
  EXPECT_TRUE(out.contains("point_b"));
  EXPECT_TRUE(out.contains("normal"));
}

TEST(DistanceCommand, OptionDefaultsAreTheEngines) {
  // A line without options must answer exactly as a direct call with DistanceOptions{}.
  const DistanceOptions<double> defaults;
  const Shape<double> a(Ellipsoid<double>{Vec(1, 0.5, 0.25)});
  const Shape<double> b(Cone<double>{0.5, 1.0}, 0.1);
  const Pose<double> pose_b = pose(0.8, 0, 0.36, 0.48, Vec(1.5, 1.0, 0.5));
  const DistanceResult<double> direct = distance(a, Pose<double>{}, b, pose_b, defaults);

  const Json out = computed(
      R"({"a": {"ellipsoid": [1, 0.5, 0.25]}, "b": {"cone": {"radius": 0.5, "half_height": 1}, )"
      R"("radius": 0.1, "pose": {"rotation": [0.8, 0, 0.36, 0.48], "translation": [1.5, 1, 0.5]}}})");
  EXPECT_EQ(out["distance"].get<double>(), direct.distance);
  EXPECT_EQ(out["error_bound"].get<double>(), direct.error_bound);
  EXPECT_EQ(out["iterations"].get<int>(), direct.iterations);
  EXPECT_EQ(out.contains("point_a"), defaults.near_points);
  EXPECT_EQ(out.contains("penetration_bound"), false);  // "penetration": "none" by default
}

TEST(DistanceCommand, EpsilonIsPassedToTheEngine) {
  // A smooth pair converges geometrically, so a coarse epsilon stops earlier: the same answer as a
  // direct call with that epsilon, bit for bit.
  DistanceOptions<double> options;
  options.epsilon = 1e-4;
  const Shape<double> a(Ellipsoid<double>{Vec(1, 0.5, 0.25)});
  const Shape<double> b(Ellipsoid<double>{Vec(0.3, 0.7, 0.4)});
  const Pose<double> pose_b = pose(0.1, 0.7, 0.1, 0.7, Vec(2, 0.3, -0.2));
  const DistanceResult<double> coarse = distance(a, Pose<double>{}, b, pose_b, options);
  const DistanceResult<double> fine = distance(a, Pose<double>{}, b, pose_b);
  ASSERT_LE(coarse.iterations, fine.iterations);

  const std::string pair =
      R"({"a": {"ellipsoid": [1, 0.5, 0.25]}, "b": {"ellipsoid": [0.3, 0.7, 0.4], "pose": )"
      R"({"rotation": [0.1, 0.7, 0.1, 0.7], "translation": [2, 0.3, -0.2]}})";
  const Json out = computed(pair + R"(, "options": {"epsilon": 1e-4}})");
  EXPECT_EQ(out["distance"].get<double>(), coarse.distance);
  EXPECT_EQ(out["error_bound"].get<double>(), coarse.error_bound);
  EXPECT_EQ(out["iterations"].get<int>(), coarse.iterations);
  const Json default_out = computed(pair + "}");
  EXPECT_EQ(default_out["iterations"].get<int>(), fine.iterations);
}

// Guards the shared epsilon rule (nearpoint::is_valid_epsilon, also nearpointd's): epsilon 0 is
// a valid tolerance — eq. (35) then never fires and the loop ends by its other stopping rules, on
// a curved pair well before the iteration cap — so the command answers it as the engine does,
// bit for bit. It used to refuse 0 ("must be a positive number") while the server accepted it.
TEST(DistanceCommand, EpsilonZeroIsAToleranceLikeAnyOther) {
  DistanceOptions<double> options;
  options.epsilon = 0;
  const Shape<double> a(Ellipsoid<double>{Vec(1, 0.5, 0.25)});
  const Shape<double> b(Ellipsoid<double>{Vec(0.3, 0.7, 0.4)});
  const Pose<double> pose_b = pose(0.1, 0.7, 0.1, 0.7, Vec(2, 0.3, -0.2));
  const DistanceResult<double> exact = distance(a, Pose<double>{}, b, pose_b, options);
  ASSERT_EQ(exact.status, Status::separated);
  ASSERT_LT(exact.iterations, kDefaultMaxIterations);

  const Json out = computed(
      R"({"a": {"ellipsoid": [1, 0.5, 0.25]}, "b": {"ellipsoid": [0.3, 0.7, 0.4], "pose": )"
      R"({"rotation": [0.1, 0.7, 0.1, 0.7], "translation": [2, 0.3, -0.2]}}, )"
      R"("options": {"epsilon": 0}})");
  EXPECT_EQ(out["status"], "separated") << out.dump();
  EXPECT_EQ(out["distance"].get<double>(), exact.distance);
  EXPECT_EQ(out["error_bound"].get<double>(), exact.error_bound);
  EXPECT_EQ(out["iterations"].get<int>(), exact.iterations);
}

// A cube and an octahedron overlapping: the final simplex is a tetrahedron around the origin.
const char* kOverlappingPair =
    R"("a": {"polytope": [[-1,-1,-1],[1,-1,-1],[-1,1,-1],[1,1,-1],[-1,-1,1],[1,-1,1],[-1,1,1],)"
    R"([1,1,1]]}, "b": {"polytope": [[1,0,0],[-1,0,0],[0,1,0],[0,-1,0],[0,0,1],[0,0,-1]], )"
    R"("pose": {"translation": [1.5, 0.25, 0]}})";

TEST(DistanceCommand, PenetrationBoundOnlyWhenAskedAndIntersecting) {
  const Json bound =
      computed(std::string("{") + kOverlappingPair + R"(, "options": {"penetration": "bound"}})");
  EXPECT_EQ(bound["status"], "intersecting");
  ASSERT_TRUE(bound.contains("penetration_bound")) << bound.dump();
  const double d_minus = bound["penetration_bound"].get<double>();
  EXPECT_GE(d_minus, 0.0);
  // The true depth is 0.5 (push B along +x until the cube's face x = 1 clears its vertex at 0.5).
  EXPECT_LE(d_minus, 0.5 + 1e-12);

  DistanceOptions<double> options;
  options.penetration_bound = true;
  std::vector<Vec> cube;
  for (int i = 0; i < 8; ++i) cube.emplace_back(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1);
  const std::vector<Vec> octahedron = {Vec(1, 0, 0),  Vec(-1, 0, 0), Vec(0, 1, 0),
                                       Vec(0, -1, 0), Vec(0, 0, 1),  Vec(0, 0, -1)};
  const DistanceResult<double> direct = distance(
      Shape<double>(Polytope<double>(cube)), Pose<double>{},
      Shape<double>(Polytope<double>(octahedron)), pose(1, 0, 0, 0, Vec(1.5, 0.25, 0)), options);
  EXPECT_EQ(d_minus, direct.penetration_bound);

  const Json none = computed(std::string("{") + kOverlappingPair + R"(, "options": {}})");
  EXPECT_FALSE(none.contains("penetration_bound"));
  const Json separated =
      computed(std::string("{") + kSpherePair + R"(, "options": {"penetration": "bound"}})");
  EXPECT_EQ(separated["status"], "separated");
  EXPECT_FALSE(separated.contains("penetration_bound"));
}

// "penetration": "depth": the signed distance and the depth with their intervals, the witnesses,
// direction and termination, as the engine computes them on the same shapes (the cube and the
// octahedron: true depth 0.5 along +x); the next line is answered as usual.
TEST(DistanceCommand, PenetrationDepthLinesCarryTheEnginesDepth) {
  const CommandRun r =
      run(std::string(R"({"id": "deep", )") + kOverlappingPair +
          R"(, "options": {"penetration": "depth"}})" + "\n" + "{" + kSpherePair + "}\n");
  ASSERT_EQ(r.json.size(), 2u);
  const Json& out = r.json[0];
  EXPECT_EQ(out["id"], "deep");
  ASSERT_EQ(out["status"], "intersecting") << out.dump();
  EXPECT_FALSE(out.contains("penetration_bound"));
  for (const char* key :
       {"signed_distance", "signed_distance_lower", "signed_distance_upper", "penetration_depth",
        "penetration_depth_lower", "penetration_depth_upper", "depth_point_a", "depth_point_b",
        "depth_direction", "depth_termination", "depth_iterations"})
    EXPECT_TRUE(out.contains(key)) << key << " in " << out.dump();
  const double depth = out["penetration_depth"].get<double>();
  EXPECT_LE(out["penetration_depth_lower"].get<double>(), 0.5);
  EXPECT_GE(out["penetration_depth_upper"].get<double>(), 0.5);
  EXPECT_NEAR(depth, 0.5, 1e-9);
  EXPECT_EQ(out["signed_distance"].get<double>(), -depth);
  EXPECT_NEAR((vec(out["depth_direction"]) - Vec(1, 0, 0)).norm(), 0.0, 1e-9);

  DistanceOptions<double> options;
  options.penetration_depth = true;
  std::vector<Vec> cube;
  for (int i = 0; i < 8; ++i) cube.emplace_back(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1);
  const std::vector<Vec> octahedron = {Vec(1, 0, 0),  Vec(-1, 0, 0), Vec(0, 1, 0),
                                       Vec(0, -1, 0), Vec(0, 0, 1),  Vec(0, 0, -1)};
  const DistanceResult<double> direct = distance(
      Shape<double>(Polytope<double>(cube)), Pose<double>{},
      Shape<double>(Polytope<double>(octahedron)), pose(1, 0, 0, 0, Vec(1.5, 0.25, 0)), options);
  ASSERT_TRUE(direct.has_penetration_depth);
  EXPECT_EQ(depth, direct.depth);
  EXPECT_EQ(out["penetration_depth_lower"].get<double>(), direct.depth_lower);
  EXPECT_EQ(out["signed_distance_upper"].get<double>(), direct.signed_distance_upper);
  EXPECT_EQ(vec(out["depth_point_a"]), direct.depth_point_a);
  EXPECT_EQ(out["depth_termination"], to_string(direct.depth_termination));
  EXPECT_EQ(out["depth_iterations"], direct.depth_iterations);
  EXPECT_EQ(r.json[1]["status"], "separated");          // and the next line is answered as usual
  EXPECT_FALSE(r.json[1].contains("signed_distance"));  // only when asked
}

// --- ids ----------------------------------------------------------------------------------------

TEST(DistanceCommand, IdsEchoBackWhateverTheirType) {
  const std::vector<std::string> ids = {R"("text")",
                                        "42",
                                        "-7",
                                        "2.5",
                                        "null",
                                        "true",
                                        R"({"k": [1, {"x": "y"}], "a": 0})",
                                        R"([1, "two", null])",
                                        "18446744073709551615",
                                        R"("unicode é ✓")"};
  std::string input;
  for (const std::string& id : ids) input += R"({"id": )" + id + ", " + kSpherePair + "}\n";
  // The same ids on error lines (a bad radius).
  for (const std::string& id : ids)
    input +=
        R"({"id": )" + id + R"(, "a": {"sphere": {}, "radius": -1}, "b": {"sphere": {}}})" + "\n";
  const CommandRun r = run(input);
  ASSERT_EQ(r.json.size(), 2 * ids.size());
  for (std::size_t i = 0; i < r.json.size(); ++i) {
    const Json expected = Json::parse(ids[i % ids.size()]);
    EXPECT_EQ(r.json[i]["id"], expected) << r.lines[i];
    EXPECT_EQ(r.json[i]["status"], i < ids.size() ? "separated" : "error");
  }
  // An object id keeps its key order.
  EXPECT_NE(r.lines[6].find(R"("id":{"k":[1,{"x":"y"}],"a":0})"), std::string::npos) << r.lines[6];
}

TEST(DistanceCommand, AbsentIdIsNull) {
  const Json out = computed(std::string("{") + kSpherePair + "}");
  ASSERT_TRUE(out.contains("id"));
  EXPECT_TRUE(out["id"].is_null());
  const Json error = answer("this is not JSON");
  ASSERT_TRUE(error.contains("id"));
  EXPECT_TRUE(error["id"].is_null());
}

// --- bad input ----------------------------------------------------------------------------------

struct BadLine {
  const char* name;
  std::string line;
  std::vector<std::string> message_mentions;  // substrings the message must contain
};

std::vector<BadLine> bad_lines() {
  const std::string b = R"("b": {"sphere": {}})";
  return {
      {"malformed JSON", R"({"id": 1, "a": {"sphere": {})", {"not valid JSON", "column"}},
      {"NaN literal",
       R"({"a": {"sphere": {}, "radius": NaN}, )" + b + "}",
       {"not valid JSON", "NaN"}},
      {"Infinity literal",
       R"({"a": {"box": [Infinity, 1, 1]}, )" + b + "}",
       {"not valid JSON", "Infinity"}},
      {"number overflowing to infinity",
       R"({"a": {"sphere": {}, "radius": 1e999}, )" + b + "}",
       {"1e999", "finite"}},
      {"NaN as a string",
       R"({"a": {"sphere": {}, "radius": "NaN"}, )" + b + "}",
       {"\"a.radius\"", "got a string"}},
      // Nesting is bounded before anything is built (issue 21, item 13): an id nested 100,000
      // deep overflowed the stack when it was copied into the answer and dumped.
      {"id nested 100,000 deep",
       "{\"id\": " + std::string(100'000, '[') + std::string(100'000, ']') + ", " + b + "}",
       {"not valid JSON", "nesting deeper than 64 levels at column 71"}},
      {"shape nested 100,000 deep",
       R"({"a": {"polytope": )" + std::string(100'000, '[') + std::string(100'000, ']') + "}, " +
           b + "}",
       {"not valid JSON", "nesting deeper than 64 levels"}},
      {"not an object", "[1, 2, 3]", {"JSON object", "got an array"}},
      {"missing a", "{" + b + "}", {"missing \"a\""}},
      {"missing b", R"({"a": {"sphere": {}}})", {"missing \"b\""}},
      {"wrong type of shape", R"({"a": "box", )" + b + "}", {"\"a\"", "got a string"}},
      {"wrong type of radius",
       R"({"a": {"sphere": {}, "radius": [1]}, )" + b + "}",
       {"\"a.radius\"", "number"}},
      {"empty polytope",
       R"({"a": {"polytope": []}, )" + b + "}",
       {"\"a.polytope\" must be a non-empty array of [x,y,z]"}},
      {"polytope vertex of two numbers",
       R"({"a": {"polytope": [[0,0,0],[1,2]]}, )" + b + "}",
       {"\"a.polytope[1]\"", "3 numbers"}},
      {"polytope vertex with a string",
       R"({"a": {"polytope": [[0,"x",0]]}, )" + b + "}",
       {"\"a.polytope[0][1]\"", "number"}},
      {"negative radius",
       R"({"a": {"sphere": {}}, "b": {"sphere": {}, "radius": -0.5}})",
       {"\"b.radius\"", "non-negative"}},
      {"negative box half extent",
       R"({"a": {"box": [1, -1, 1]}, )" + b + "}",
       {"\"a.box[1]\"", "non-negative"}},
      {"negative cylinder radius",
       R"({"a": {"cylinder": {"radius": -1, "half_height": 1}}, )" + b + "}",
       {"\"a.cylinder.radius\"", "non-negative"}},
      {"cone without half_height",
       R"({"a": {"cone": {"radius": 1}}, )" + b + "}",
       {"\"a.cone\"", "half_height"}},
      {"segment of one point",
       R"({"a": {"segment": [[0,0,0]]}, )" + b + "}",
       {"\"a.segment\"", "2 points"}},
      {"ellipsoid of two radii",
       R"({"a": {"ellipsoid": [1, 2]}, )" + b + "}",
       {"\"a.ellipsoid\"", "3 numbers"}},
      {"non-unit quaternion",
       R"({"a": {"box": [1,1,1], "pose": {"rotation": [1, 1, 0, 0]}}, )" + b + "}",
       {"\"a.pose\"", "unit length"}},
      {"zero quaternion",
       R"({"a": {"box": [1,1,1], "pose": {"rotation": [0, 0, 0, 0]}}, )" + b + "}",
       {"\"a.pose\"", "unit length"}},
      {"quaternion of three numbers",
       R"({"a": {"box": [1,1,1], "pose": {"rotation": [1, 0, 0]}}, )" + b + "}",
       {"\"a.pose.rotation\"", "[w,x,y,z]"}},
      {"translation of a string",
       R"({"a": {"box": [1,1,1], "pose": {"translation": "here"}}, )" + b + "}",
       {"\"a.pose.translation\"", "[x,y,z]"}},
      {"unknown pose key",
       R"({"a": {"box": [1,1,1], "pose": {"position": [0,0,0]}}, )" + b + "}",
       {"\"a.pose\"", "\"position\""}},
      {"unknown shape kind",
       R"({"a": {"torus": [1, 2]}, )" + b + "}",
       {"\"a\"", "\"torus\"", "polytope, sphere, segment, box, ellipsoid, cylinder, cone"}},
      {"no shape kind", R"({"a": {"radius": 1}, )" + b + "}", {"\"a\"", "no shape kind"}},
      {"two shape kinds",
       R"({"a": {"box": [1,1,1], "sphere": {}}, )" + b + "}",
       {"\"a\"", "two shape kinds"}},
      {"misspelt radius",
       R"({"a": {"sphere": {}, "radus": 1}, )" + b + "}",
       {"\"a\"", "\"radus\""}},
      {"sphere radius inside",
       R"({"a": {"sphere": {"radius": 1}}, )" + b + "}",
       {"\"a.sphere\"", "\"a.radius\""}},
      {"unknown option",
       R"({"a": {"sphere": {}}, )" + b + R"(, "options": {"near_point": true}})",
       {"unknown option", "\"near_point\""}},
      {"options not an object",
       R"({"a": {"sphere": {}}, )" + b + R"(, "options": [1]})",
       {"\"options\"", "object"}},
      {"near_points not a boolean",
       R"({"a": {"sphere": {}}, )" + b + R"(, "options": {"near_points": 1}})",
       {"\"options.near_points\"", "true or false"}},
      {"warm not a boolean",
       R"({"a": {"sphere": {}}, )" + b + R"(, "options": {"warm": "yes"}})",
       {"\"options.warm\"", "true or false"}},
      {"unknown penetration",
       R"({"a": {"sphere": {}}, )" + b + R"(, "options": {"penetration": "exact"}})",
       {"\"options.penetration\"", "\"exact\""}},
      {"epsilon of 1",
       R"({"a": {"sphere": {}}, )" + b + R"(, "options": {"epsilon": 1}})",
       {"\"options.epsilon\"", "[0, 1)"}},
      {"negative epsilon",
       R"({"a": {"sphere": {}}, )" + b + R"(, "options": {"epsilon": -1e-300}})",
       {"\"options.epsilon\"", "[0, 1)"}},
      {"epsilon a string",
       R"({"a": {"sphere": {}}, )" + b + R"(, "options": {"epsilon": "1"}})",
       {"\"options.epsilon\"", "[0, 1)"}},
      {"unknown top-level key",
       R"({"a": {"sphere": {}}, )" + b + R"(, "c": {"sphere": {}}})",
       {"unknown key", "\"c\""}},
      {"invalid UTF-8",
       "{\"id\": \"\xff\", \"a\": {\"sphere\": {}}, " + b + "}",
       {"not valid JSON", "UTF-8"}},
  };
}

TEST(DistanceCommand, EveryBadLineClassYieldsOneErrorLineAndProcessingContinues) {
  const std::vector<BadLine> cases = bad_lines();
  // Each bad line is followed by a good one, which must still be answered.
  std::string input;
  for (const BadLine& bad : cases) input += bad.line + "\n" + "{" + kSpherePair + "}\n";
  const CommandRun r = run(input);
  EXPECT_EQ(r.exit_code, kExitOk);
  EXPECT_EQ(r.diagnostics, "");
  ASSERT_EQ(r.json.size(), 2 * cases.size());
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const BadLine& bad = cases[i];
    const Json& error = r.json[2 * i];
    SCOPED_TRACE(bad.name);
    EXPECT_EQ(error["status"], "error") << r.lines[2 * i];
    EXPECT_EQ(keys(error), (std::vector<std::string>{"id", "status", "message"}));
    const std::string message = error["message"].get<std::string>();
    const std::string prefix = "line " + std::to_string(2 * i + 1) + ": ";
    EXPECT_EQ(message.rfind(prefix, 0), 0u) << message;
    for (const std::string& mention : bad.message_mentions)
      EXPECT_NE(message.find(mention), std::string::npos)
          << message << "\nshould mention " << mention;
    EXPECT_EQ(r.json[2 * i + 1]["status"], "separated") << r.lines[2 * i + 1];
  }
}

TEST(DistanceCommand, BlankLinesAreSkippedButCountedInMessages) {
  const CommandRun r = run("\n   \n\t\r\n{\"id\": 1}\n\n{" + std::string(kSpherePair) + "}");
  ASSERT_EQ(r.json.size(), 2u);
  EXPECT_EQ(r.json[0]["status"], "error");
  EXPECT_EQ(r.json[0]["id"], 1);
  EXPECT_EQ(r.json[0]["message"].get<std::string>().rfind("line 4: ", 0), 0u);
  EXPECT_EQ(r.json[1]["status"], "separated");  // the last line needs no newline
}

TEST(DistanceCommand, CrLfLineEndingsAreAccepted) {
  const CommandRun r =
      run("{" + std::string(kSpherePair) + "}\r\n{\"id\": 2, " + kSpherePair + "}\r\n");
  ASSERT_EQ(r.json.size(), 2u);
  EXPECT_EQ(r.json[0]["status"], "separated");
  EXPECT_EQ(r.json[1]["id"], 2);
}

TEST(DistanceCommand, EmptyInputGivesNoOutput) {
  const CommandRun r = run("");
  EXPECT_EQ(r.exit_code, kExitOk);
  EXPECT_TRUE(r.lines.empty());
}

// --- agreement with the engine and number output -----------------------------------------------

struct DirectCase {
  const char* line;
  Shape<double> a;
  Pose<double> pose_a;
  Shape<double> b;
  Pose<double> pose_b;
};

std::vector<DirectCase> direct_cases() {
  const std::vector<Vec> tetrahedron = {Vec(0, 0, 0), Vec(1, 0, 0), Vec(0, 1, 0), Vec(0, 0, 1)};
  return {
      {R"({"a": {"box": [1, 0.5, 0.25]}, "b": {"polytope": [[0,0,0],[1,0,0],[0,1,0],[0,0,1]], )"
       R"("pose": {"rotation": [0.9238795325112867, 0, 0, 0.3826834323650898], )"
       R"("translation": [2, 1, 0.5]}}, "options": {"near_points": true}})",
       Shape<double>(Box<double>{Vec(1, 0.5, 0.25)}), Pose<double>{},
       Shape<double>(Polytope<double>(tetrahedron)),
       pose(0.9238795325112867, 0, 0, 0.3826834323650898, Vec(2, 1, 0.5))},
      {R"({"a": {"segment": [[-1, 0, 0], [1, 0.2, 0]], "radius": 0.25, "pose": {"translation": )"
       R"([0.1, 0.2, 0.3]}}, "b": {"ellipsoid": [1, 0.5, 0.3], "pose": {"rotation": )"
       R"([0.7, 0.7, 0.1, 0.1], "translation": [0.3, 2, 0.1]}}, "options": {"near_points": true}})",
       Shape<double>::capsule(Vec(-1, 0, 0), Vec(1, 0.2, 0), 0.25),
       pose(1, 0, 0, 0, Vec(0.1, 0.2, 0.3)), Shape<double>(Ellipsoid<double>{Vec(1, 0.5, 0.3)}),
       pose(0.7, 0.7, 0.1, 0.1, Vec(0.3, 2, 0.1))},
      {R"({"a": {"cylinder": {"radius": 0.5, "half_height": 1}, "pose": {"rotation": )"
       R"([0.9, 0.3, 0.3, 0.1], "translation": [1000000, -2000000, 3]}}, "b": {"cone": )"
       R"({"radius": 0.7, "half_height": 0.4}, "radius": 0.05, "pose": {"rotation": )"
       R"([0.5, 0.5, -0.5, 0.5], "translation": [1000001.5, -1999999.5, 3.2]}}, )"
       R"("options": {"near_points": true}})",
       Shape<double>(Cylinder<double>{0.5, 1}), pose(0.9, 0.3, 0.3, 0.1, Vec(1e6, -2e6, 3)),
       Shape<double>(Cone<double>{0.7, 0.4}, 0.05),
       pose(0.5, 0.5, -0.5, 0.5, Vec(1000001.5, -1999999.5, 3.2))},
      {R"({"a": {"sphere": {}, "radius": 0.75}, "b": {"box": [0.5, 0.5, 0.5], "radius": 0.1, )"
       R"("pose": {"rotation": [0.8, 0.36, 0.48, 0], "translation": [1, 0.9, 0.8]}}, )"
       R"("options": {"near_points": true}})",
       Shape<double>::sphere(0.75), Pose<double>{},
       Shape<double>(Box<double>{Vec(0.5, 0.5, 0.5)}, 0.1),
       pose(0.8, 0.36, 0.48, 0, Vec(1, 0.9, 0.8))},
  };
}

TEST(DistanceCommand, AgreesWithCallingTheEngineDirectlyBitForBit) {
  DistanceOptions<double> options;
  options.near_points = true;
  for (const DirectCase& c : direct_cases()) {
    SCOPED_TRACE(c.line);
    const DistanceResult<double> direct = distance(c.a, c.pose_a, c.b, c.pose_b, options);
    ASSERT_NE(direct.status, Status::invalid_input) << direct.message;
    const Json out = computed(c.line);
    EXPECT_EQ(out["status"], status_name(direct.status));
    // Exact equality: the output must carry every bit of the engine's doubles.
    EXPECT_EQ(out["distance"].get<double>(), direct.distance);
    EXPECT_EQ(out["error_bound"].get<double>(), direct.error_bound);
    EXPECT_EQ(out["iterations"].get<int>(), direct.iterations);
    if (direct.status == Status::separated) {
      EXPECT_EQ(vec(out["point_a"]), direct.point_a);
      EXPECT_EQ(vec(out["point_b"]), direct.point_b);
      EXPECT_EQ(vec(out["normal"]), direct.normal);
    }
  }
}

TEST(DistanceCommand, NumbersRoundTripThroughTheirText) {
  // Distances that need all 17 significant digits, read back with strtod from the raw text.
  const Json out = computed(direct_cases()[0].line);
  const std::string text = out["distance"].dump();
  const double parsed = std::strtod(text.c_str(), nullptr);
  EXPECT_EQ(parsed, out["distance"].get<double>());
  DistanceOptions<double> options;
  options.near_points = true;
  const std::vector<DirectCase> cases = direct_cases();
  const DirectCase& c = cases.front();
  const DistanceResult<double> direct = distance(c.a, c.pose_a, c.b, c.pose_b, options);
  EXPECT_EQ(parsed, direct.distance) << text;

  // And values across the whole double range print as JSON numbers that read back exactly.
  for (const double value : {1.0 / 3.0, 0.1, 1e-300, 5e-324, 1.7976931348623157e308,
                             2.220446049250313e-14, 123456789.12345678}) {
    const std::string printed = Json(value).dump();
    EXPECT_EQ(std::strtod(printed.c_str(), nullptr), value) << printed;
  }
}

TEST(DistanceCommand, NeverPrintsNaNOrInfinity) {
  // Degenerate but valid shapes: zero-size boxes and ellipsoids, coincident points, a segment of
  // zero length, shapes exactly on top of each other.
  const std::vector<std::string> lines = {
      R"({"a": {"box": [0, 0, 0]}, "b": {"box": [0, 0, 0]}, "options": {"near_points": true, )"
      R"("penetration": "bound"}})",
      R"({"a": {"ellipsoid": [0, 0, 0]}, "b": {"ellipsoid": [1, 0, 1], "pose": {"translation": )"
      R"([0, 2, 0]}}, "options": {"near_points": true}})",
      R"({"a": {"polytope": [[1, 1, 1], [1, 1, 1]]}, "b": {"sphere": {}, "pose": {"translation": )"
      R"([1, 1, 1]}}, "options": {"near_points": true, "penetration": "bound"}})",
      R"({"a": {"segment": [[0, 0, 0], [0, 0, 0]]}, "b": {"cylinder": {"radius": 0, )"
      R"("half_height": 0}, "pose": {"translation": [0, 0, 1e-300]}}, "options": )"
      R"({"near_points": true}})",
      R"({"a": {"cone": {"radius": 1e300, "half_height": 1e300}}, "b": {"sphere": {}, "pose": )"
      R"({"translation": [1e300, 1e300, 1e300]}}, "options": {"near_points": true}})",
  };
  std::string input;
  for (const std::string& line : lines) input += line + "\n";
  const CommandRun r = run(input);
  ASSERT_EQ(r.json.size(), lines.size());
  for (std::size_t i = 0; i < r.json.size(); ++i) {
    SCOPED_TRACE(r.lines[i]);
    EXPECT_EQ(r.lines[i].find("nan"), std::string::npos);
    EXPECT_EQ(r.lines[i].find("inf"), std::string::npos);
    for (const auto& [key, value] : r.json[i].items()) {
      if (value.is_number()) {
        EXPECT_TRUE(std::isfinite(value.get<double>())) << key;
      }
    }
  }
}

// --- warm start (Section VIII) ------------------------------------------------------------------

std::string path_line(int step, bool warm, const char* box = "[1, 1, 1]") {
  // A tetrahedron turning and sliding past a box: poses along a path, shapes fixed.
  const double angle = 0.1 * step;
  const Eigen::Quaterniond q(Eigen::AngleAxisd(angle, Vec(0.3, 0.4, 0.866).normalized()));
  Json line;
  line["id"] = "path-" + std::to_string(step);
  line["a"] = Json::parse(std::string(R"({"box": )") + box + "}");
  line["b"] = Json::parse(R"({"polytope": [[0,0,0],[1,0,0],[0,1,0],[0,0,1],[0.3,0.3,0.3]]})");
  line["b"]["pose"]["rotation"] = {q.w(), q.x(), q.y(), q.z()};
  line["b"]["pose"]["translation"] = {2.5 - 0.1 * step, 0.05 * step, 0.1};
  line["options"]["warm"] = warm;
  return line.dump();
}

TEST(DistanceCommand, WarmRunIsWarmStartedFromTheSecondLineAndAgreesWithColdRuns) {
  constexpr int kSteps = 8;
  std::string warm_input;
  std::string cold_input;
  for (int step = 0; step < kSteps; ++step) {
    warm_input += path_line(step, true) + "\n";
    cold_input += path_line(step, false) + "\n";
  }
  const CommandRun warm = run(warm_input);
  const CommandRun cold = run(cold_input);
  ASSERT_EQ(warm.json.size(), static_cast<std::size_t>(kSteps));
  ASSERT_EQ(cold.json.size(), static_cast<std::size_t>(kSteps));
  for (int step = 0; step < kSteps; ++step) {
    const Json& w = warm.json[static_cast<std::size_t>(step)];
    const Json& c = cold.json[static_cast<std::size_t>(step)];
    SCOPED_TRACE(warm.lines[static_cast<std::size_t>(step)]);
    EXPECT_EQ(w["status"], c["status"]);
    EXPECT_EQ(w["warm_started"], step > 0);
    EXPECT_EQ(c["warm_started"], false);
    const double tolerance = w["error_bound"].get<double>() + c["error_bound"].get<double>();
    EXPECT_LE(std::abs(w["distance"].get<double>() - c["distance"].get<double>()), tolerance);
  }
}

TEST(DistanceCommand, WarmRunMatchesTheEngineWithACarriedCache) {
  // The command's warm run is the engine's: one SimplexCache carried from pose to pose.
  std::string input;
  for (int step = 0; step < 4; ++step) input += path_line(step, true) + "\n";
  const CommandRun r = run(input);
  ASSERT_EQ(r.json.size(), 4u);
  SimplexCache cache{};
  for (std::size_t step = 0; step < 4; ++step) {
    const Json line = Json::parse(path_line(static_cast<int>(step), true));
    PlacedShape a;
    PlacedShape b;
    ASSERT_EQ(parse_shape(line["a"], "a", a), "");
    ASSERT_EQ(parse_shape(line["b"], "b", b), "");
    const DistanceResult<double> direct = distance(a.shape, a.pose, b.shape, b.pose, {}, &cache);
    EXPECT_EQ(r.json[step]["distance"].get<double>(), direct.distance);
    EXPECT_EQ(r.json[step]["iterations"].get<int>(), direct.iterations);
    EXPECT_EQ(r.json[step]["warm_started"].get<bool>(), direct.warm_started);
  }
}

TEST(DistanceCommand, WarmChainNeedsConsecutiveWarmLinesOfTheSameShapes) {
  const std::string other_pair = "{" + std::string(kSpherePair) + R"(, "options": {"warm": true}})";
  const std::string bad = R"({"a": {"sphere": {}}})";
  const CommandRun r = run(path_line(0, true) + "\n" +                  // cold: first of its run
                           path_line(1, true) + "\n" +                  // warm
                           path_line(2, true, "[1, 1, 1.5]") + "\n" +   // another box: cold
                           path_line(3, true, "[1, 1, 1.5]") + "\n" +   // warm
                           path_line(4, false, "[1, 1, 1.5]") + "\n" +  // not warm
                           path_line(5, true, "[1, 1, 1.5]") + "\n" +  // cold: the chain was broken
                           bad + "\n" +                                // an error line
                           path_line(6, true, "[1, 1, 1.5]") + "\n" +  // cold again
                           "\n" +                                      // blank lines do not count
                           path_line(7, true, "[1, 1, 1.5]") + "\n" +  // warm
                           other_pair + "\n" +                         // another pair: cold
                           path_line(8, true, "[1, 1, 1.5]") + "\n");  // cold
  const std::vector<bool> expected = {false, true,  false, true,  false, false,
                                      false, false, true,  false, false};
  ASSERT_EQ(r.json.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    SCOPED_TRACE(r.lines[i]);
    if (r.json[i]["status"] == "error") {
      EXPECT_EQ(i, 6u);
      continue;
    }
    EXPECT_EQ(r.json[i]["warm_started"].get<bool>(), expected[i]);
  }
}

// --- I/O failures -------------------------------------------------------------------------------

// A stream buffer whose reads fail, as a disk or a pipe can.
class FailingInput : public std::streambuf {
 protected:
  int_type underflow() override { throw std::runtime_error("read failed"); }
};

TEST(DistanceCommand, UnreadableInputExitsWithTwoAndSaysWhy) {
  FailingInput buffer;
  std::istream in(&buffer);
  std::ostringstream out;
  std::ostringstream diagnostics;
  DistanceCommandOptions options;
  options.diagnostics = &diagnostics;
  options.input_name = "trajectory.jsonl";
  EXPECT_EQ(run_distance(in, out, options), kExitIoError);
  EXPECT_NE(diagnostics.str().find("cannot read trajectory.jsonl"), std::string::npos)
      << diagnostics.str();
}

TEST(DistanceCommand, UnwritableOutputExitsWithTwo) {
  std::istringstream in("{" + std::string(kSpherePair) + "}\n");
  std::ostringstream out;
  out.setstate(std::ios::badbit);
  std::ostringstream diagnostics;
  DistanceCommandOptions options;
  options.diagnostics = &diagnostics;
  EXPECT_EQ(run_distance(in, out, options), kExitIoError);
  EXPECT_NE(diagnostics.str().find("cannot write"), std::string::npos);
}

// --- SHAPE parsing ------------------------------------------------------------------------------

TEST(JsonShapes, EveryKindParsesToItsEngineShape) {
  PlacedShape s;
  ASSERT_EQ(parse_shape(Json::parse(R"({"polytope": [[0,0,0],[1,2,3]]})"), "a", s), "");
  ASSERT_TRUE(std::holds_alternative<Polytope<double>>(s.shape.geometry));
  EXPECT_EQ(std::get<Polytope<double>>(s.shape.geometry).size(), 2u);
  EXPECT_EQ(std::get<Polytope<double>>(s.shape.geometry).vertex(1), Vec(1, 2, 3));

  ASSERT_EQ(parse_shape(Json::parse(R"({"sphere": {}, "radius": 2})"), "a", s), "");
  EXPECT_TRUE(std::holds_alternative<Point>(s.shape.geometry));
  EXPECT_EQ(s.shape.radius, 2.0);

  ASSERT_EQ(parse_shape(Json::parse(R"({"segment": [[1,2,3],[4,5,6]]})"), "a", s), "");
  ASSERT_TRUE(std::holds_alternative<Segment<double>>(s.shape.geometry));
  EXPECT_EQ(std::get<Segment<double>>(s.shape.geometry).a, Vec(1, 2, 3));
  EXPECT_EQ(std::get<Segment<double>>(s.shape.geometry).b, Vec(4, 5, 6));
  EXPECT_EQ(s.shape.radius, 0.0);

  ASSERT_EQ(parse_shape(Json::parse(R"({"box": [1,2,3]})"), "a", s), "");
  ASSERT_TRUE(std::holds_alternative<Box<double>>(s.shape.geometry));
  EXPECT_EQ(std::get<Box<double>>(s.shape.geometry).half_extents, Vec(1, 2, 3));

  ASSERT_EQ(parse_shape(Json::parse(R"({"ellipsoid": [1,2,3]})"), "a", s), "");
  ASSERT_TRUE(std::holds_alternative<Ellipsoid<double>>(s.shape.geometry));
  EXPECT_EQ(std::get<Ellipsoid<double>>(s.shape.geometry).radii, Vec(1, 2, 3));

  ASSERT_EQ(parse_shape(Json::parse(R"({"cylinder": {"radius": 1, "half_height": 2}})"), "a", s),
            "");
  ASSERT_TRUE(std::holds_alternative<Cylinder<double>>(s.shape.geometry));
  EXPECT_EQ(std::get<Cylinder<double>>(s.shape.geometry).radius, 1.0);
  EXPECT_EQ(std::get<Cylinder<double>>(s.shape.geometry).half_height, 2.0);

  ASSERT_EQ(parse_shape(Json::parse(R"({"cone": {"half_height": 4, "radius": 3}})"), "a", s), "");
  ASSERT_TRUE(std::holds_alternative<Cone<double>>(s.shape.geometry));
  EXPECT_EQ(std::get<Cone<double>>(s.shape.geometry).radius, 3.0);
  EXPECT_EQ(std::get<Cone<double>>(s.shape.geometry).half_height, 4.0);
}

TEST(JsonShapes, PoseIsTheCheckedQuaternionAndTheTranslation) {
  PlacedShape s;
  // 90° about z, slightly off unit length (within 1e-4): accepted and normalised.
  const double h = std::sqrt(0.5) * (1 + 5e-5);
  Json shape = Json::parse(R"({"box": [1,1,1]})");
  shape["pose"]["rotation"] = {h, 0, 0, h};
  shape["pose"]["translation"] = {1, 2, 3};
  ASSERT_EQ(parse_shape(shape, "a", s), "");
  EXPECT_LT((s.pose.apply(Vec(1, 0, 0)) - Vec(1, 3, 3)).norm(), 1e-12);
  EXPECT_EQ(s.pose.translation, Vec(1, 2, 3));

  // Either part may be left out.
  ASSERT_EQ(parse_shape(Json::parse(R"({"box": [1,1,1], "pose": {}})"), "a", s), "");
  EXPECT_EQ(s.pose.rotation, Mat3<double>::Identity());
  EXPECT_EQ(s.pose.translation, Vec::Zero());

  // A parse failure leaves the output untouched and names the field.
  PlacedShape untouched;
  untouched.shape.radius = 7;
  EXPECT_EQ(parse_shape(Json::parse(R"({"box": [1,1,1], "pose": {"rotation": [2,0,0,0]}})"), "b",
                        untouched)
                .rfind("\"b.pose\"", 0),
            0u);
  EXPECT_EQ(untouched.shape.radius, 7.0);
}

TEST(JsonShapes, NonFiniteValuesBuiltInCodeAreRejected) {
  // The JSON parser cannot produce them, but a Json built in code (a future JSON geometry file
  // reader, say) can.
  PlacedShape s;
  Json shape = Json::parse(R"({"box": [1,1,1]})");
  shape["box"][2] = std::numeric_limits<double>::infinity();
  EXPECT_NE(parse_shape(shape, "a", s).find("\"a.box[2]\" must be a finite number"),
            std::string::npos);
  shape = Json::parse(R"({"sphere": {}})");
  shape["radius"] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(parse_shape(shape, "a", s).find("\"a.radius\""), std::string::npos);
}

}  // namespace
}  // namespace nearpoint::cli
