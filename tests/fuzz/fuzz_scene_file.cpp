// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the scene-file loader, JSON and YAML, through nearpointd's own preload path
// (formats::load_scene_file → register the geometries → create the scene), then one query of the
// scene at its initial poses. The first byte picks the format (even: JSON, odd: YAML); the rest is
// the file. Invariants: the loader never throws or crashes, a refusal is a message that names the
// file, and a loaded scene answers a query with a well-formed report.
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "scene_file.hpp"
#include "server_support.hpp"

namespace {

namespace fs = std::filesystem;
using namespace nearpoint;

// One directory per process for the file under test (the loader reads files: it picks the format
// by extension and resolves paths against the file's directory).
struct WorkDir {
  // In memory where there is a tmpfs: a file written and read per execution must not cost disk
  // I/O (measured: a third of the run time with /tmp on disk).
  static fs::path base() {
    std::error_code error;
    if (fs::is_directory("/dev/shm", error) && access("/dev/shm", W_OK) == 0) return "/dev/shm";
    return fs::temp_directory_path();
  }
  fs::path path;
  WorkDir() : path(base() / ("nearpoint-fuzz-scene-" + std::to_string(getpid()))) {
    fs::create_directories(path);
  }
  ~WorkDir() {
    std::error_code ignored;
    fs::remove_all(path, ignored);
  }
};

const fs::path& work_dir() {
  static const WorkDir dir;
  return dir.path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const bool yaml = data[0] & 1;
  const fs::path file = work_dir() / (yaml ? "scene.yaml" : "scene.json");
  {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data + 1), std::streamsize(size - 1));
  }
  // One service for the whole run, emptied after each input (a fresh one per input would cost a
  // thread start and join, most of the time of an execution).
  static server::SceneService service(fuzz::small_limits(), 1);
  struct Empty {
    ~Empty() {
      for (const model::GeometryInfo& info : service.list_geometries())
        NEARPOINT_FUZZ_CHECK(service.remove_geometry(info.geometry_id).ok(),
                             "a stored geometry could not be removed");
    }
  } empty_after;
  server::Expected<model::SceneInfo> scene = server::preload_scene_file(service, file.string());
  if (!scene) {
    fuzz::check_error(scene.error(), "preload_scene_file");
    NEARPOINT_FUZZ_CHECK(scene.error().describe().find(file.string()) != std::string::npos,
                         "a refusal that does not name the file: " + scene.error().describe());
    return 0;
  }
  struct Delete {
    const std::string& id;
    ~Delete() {
      NEARPOINT_FUZZ_CHECK(service.delete_scene(id).ok(), "the scene could not be deleted");
    }
  } delete_after{scene->scene_id};
  model::QueryInput query;
  query.scene_id = scene->scene_id;
  fuzz::ReportWaiter waiter;
  server::Outcome started = service.query(query, server::Clock::now(), waiter.callback());
  if (!started) {
    fuzz::check_error(started.error(), "query");
    return 0;
  }
  fuzz::check_report(waiter.wait(), true, "query of the loaded scene");
  return 0;
}
