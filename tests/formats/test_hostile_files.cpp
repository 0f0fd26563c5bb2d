// SPDX-License-Identifier: Apache-2.0
// Hostile scene files and JSON text (issue 21, item 13), read through the formats library as
// `nearpoint scene create`, `nearpoint register` and `nearpointd --scene` read them: each one is
// refused with a short message naming the file and the line, instead of overflowing the stack,
// following an alias cycle, expanding an alias bomb or letting a parser exception escape.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "nearpoint/formats/json_shapes.hpp"
#include "nearpoint/formats/scene_file.hpp"

namespace nearpoint::formats {
namespace {

// A scratch file of this test process, removed when the object goes.
class TempFile {
 public:
  TempFile(const std::string& name, const std::string& content)
      : path_(std::filesystem::temp_directory_path() /
              ("nearpoint-hostile-" + std::to_string(::getpid()) + "-" + name)) {
    std::ofstream(path_, std::ios::binary) << content;
  }
  ~TempFile() { std::filesystem::remove(path_); }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

std::string nested(const std::string& open, const std::string& inner, const std::string& close,
                   int depth) {
  std::string text;
  text.reserve(std::size_t(depth) * (open.size() + close.size()) + inner.size());
  for (int i = 0; i < depth; ++i) text += open;
  text += inner;
  for (int i = 0; i < depth; ++i) text += close;
  return text;
}

std::string load_error(const TempFile& file) {
  SceneFile out;
  return load_scene_file(file.path(), /*meshes=*/{}, out);
}

bool yaml_available() {
  const TempFile probe("probe.yaml", "a: 1\n");
  Json out;
  return read_structured_file(probe.path(), out).empty();
}

constexpr std::size_t kShortMessage = 400;

// Guards the nesting bound of JSON files: a deeply nested "group" used to be parsed, then dumped
// into the error message recursively, which overflowed the stack.
TEST(HostileFiles, DeeplyNestedJsonSceneIsRefusedWithTheLine) {
  const TempFile file("nested.json",
                      "{\"geometries\": {\"g\": {\"box\": [1, 1, 1]}},\n"
                      "\"objects\": [{\"id\": \"a\", \"geometry\": \"g\",\n"
                      "\"group\": " +
                          nested("[", "1", "]", 100'000) + "}]}");
  const std::string error = load_error(file);
  EXPECT_NE(error.find(file.path().string()), std::string::npos) << error;
  EXPECT_NE(error.find("nesting deeper than 64 levels at line 3"), std::string::npos) << error;
  EXPECT_LT(error.size(), kShortMessage);
}

// Guards the message of a value of the wrong type: quoted by its type, never dumped whole.
TEST(HostileFiles, AWrongValueIsDescribedNotDumped) {
  const TempFile file("group.json",
                      "{\"geometries\": {\"g\": {\"box\": [1, 1, 1]}},\n"
                      "\"objects\": [{\"id\": \"a\", \"geometry\": \"g\", "
                      "\"group\": " +
                          nested("[", "1", "]", 60) + "}]}");
  const std::string error = load_error(file);
  EXPECT_NE(error.find("objects[0].group\" must be an integer"), std::string::npos) << error;
  EXPECT_NE(error.find("(got an array"), std::string::npos) << error;
}

// Guards the catch of every JSON parser exception: 1e999 raised nlohmann's out_of_range, which
// the catch of parse_error missed (nearpointd --scene aborted, the CLI printed a raw exception).
TEST(HostileFiles, JsonNumberBeyondDoubleIsRefusedWithTheLine) {
  const TempFile file("huge.json",
                      "{\"geometries\": {\"g\": {\"box\": [1, 1, 1]}},\n"
                      "\"objects\": [{\"id\": \"a\", \"geometry\": \"g\",\n"
                      "  \"pose\": {\"translation\": [1e999, 0, 0]}}]}");
  const std::string error = load_error(file);
  EXPECT_NE(error.find(file.path().string()), std::string::npos) << error;
  EXPECT_NE(error.find("1e999"), std::string::npos) << error;
  EXPECT_NE(error.find("line 3, column 28"), std::string::npos) << error;
}

// Guards the depth bound of the YAML conversion: yaml-cpp keeps `*a` as a second reference to the
// anchored node, so `a: &a [*a]` is a cycle that the conversion to JSON followed until SIGSEGV.
TEST(HostileFiles, SelfReferencingYamlAliasIsRefused) {
  if (!yaml_available()) GTEST_SKIP() << "built without yaml-cpp";
  const TempFile file("cycle.yaml", "id: x\na: &a [*a]\n");
  const std::string error = load_error(file);
  EXPECT_NE(error.find(file.path().string()), std::string::npos) << error;
  EXPECT_NE(error.find("nesting deeper than 64 levels"), std::string::npos) << error;
  EXPECT_NE(error.find("line 2"), std::string::npos) << error;
  EXPECT_LT(error.size(), kShortMessage);
}

// Guards the budget of values a YAML document may expand to: the 600-byte "billion laughs"
// document expands to 10⁹ values and grew past 6 GB. It must be refused quickly and the process
// must stay small.
TEST(HostileFiles, YamlAliasBombIsRefusedWithoutGrowing) {
  if (!yaml_available()) GTEST_SKIP() << "built without yaml-cpp";
  std::string text = "a0: &a0 [x, x, x, x, x, x, x, x, x, x]\n";
  for (int level = 1; level <= 9; ++level) {
    const std::string p = "*a" + std::to_string(level - 1);
    text += "a" + std::to_string(level) + ": &a" + std::to_string(level) + " [" + p;
    for (int k = 1; k < 10; ++k) text += ", " + p;
    text += "]\n";
  }
  ASSERT_LT(text.size(), 700u);
  const TempFile file("laughs.yaml", text);
  const std::string error = load_error(file);
  EXPECT_NE(error.find(file.path().string()), std::string::npos) << error;
  EXPECT_NE(error.find("too many values"), std::string::npos) << error;
  rusage usage{};
  ASSERT_EQ(getrusage(RUSAGE_SELF, &usage), 0);
  EXPECT_LT(usage.ru_maxrss, 1024L * 1024L) << "peak resident set, KiB";
}

// Guards the depth bound of the YAML conversion on plain nesting: 100 levels are below yaml-cpp's
// own parser bound (2,000, YAML::DeepRecursion) and used to be converted; 100,000 levels stop in
// that parser bound, whose message must name the file too.
TEST(HostileFiles, DeeplyNestedYamlIsRefused) {
  if (!yaml_available()) GTEST_SKIP() << "built without yaml-cpp";
  for (const int depth : {100, 100'000}) {
    const TempFile file("nested.yaml", "id: x\ngroup: " + nested("[", "1", "]", depth) + "\n");
    const std::string error = load_error(file);
    EXPECT_NE(error.find(file.path().string()), std::string::npos) << error;
    EXPECT_LT(error.size(), kShortMessage) << error.substr(0, 200);
    if (depth == 100) {
      EXPECT_NE(error.find("line 2: nesting deeper than 64 levels"), std::string::npos) << error;
    }
  }
}

// The bound itself: nesting up to kMaxNestingDepth parses, one more level does not; brackets in
// strings do not count.
TEST(ParseJson, NestingIsBoundedAtTheDocumentedDepth) {
  Json out;
  EXPECT_EQ(parse_json(nested("[", "", "]", kMaxNestingDepth), out), "");
  EXPECT_EQ(parse_json("[\"" + std::string(1000, '[') + "\"]", out), "");
  int id = -1;
  const std::string error = parse_json(nested("[", "", "]", kMaxNestingDepth + 1), out, &id);
  EXPECT_NE(error.find("nesting deeper than 64 levels at line 1, column 65"), std::string::npos)
      << error;
  EXPECT_EQ(id, 0);
  EXPECT_NE(parse_json("[1e999]", out, &id).find("1e999"), std::string::npos);
  EXPECT_EQ(id, 406);
  EXPECT_EQ(parse_json("[1e-999, -0.0]", out), "") << "underflow to zero is a finite double";
}

}  // namespace
}  // namespace nearpoint::formats
