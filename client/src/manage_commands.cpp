// SPDX-License-Identifier: Apache-2.0
#include "manage_commands.hpp"

#include <algorithm>
#include <iomanip>
#include <iostream>
#include <memory>
#include <ostream>
#include <sstream>

#include <CLI/CLI.hpp>

namespace nearpoint::cli {
namespace {

constexpr int kNotFound = 5;  // grpc::StatusCode::NOT_FOUND

std::string number(double value) {
  std::ostringstream text;
  text << std::setprecision(6) << value;
  return text.str();
}

Json pose_json(const model::PoseInput& pose) {
  const auto& q = pose.rotation_wxyz;
  return {{"rotation", Json::array({q[0], q[1], q[2], q[3]})},
          {"translation",
           Json::array({pose.translation.x(), pose.translation.y(), pose.translation.z()})}};
}

Json scene_json(const client::SceneSummary& scene, bool with_objects) {
  Json out;
  out["scene_id"] = scene.scene_id;
  out["name"] = scene.name;
  out["object_count"] = scene.objects.size();
  out["pair_count"] = scene.pair_count;
  if (!with_objects) return out;
  Json objects = Json::array();
  for (const client::SceneObject& object : scene.objects) {
    Json o;
    o["id"] = object.id;
    o["geometry_id"] = object.geometry_id;
    o["pose"] = pose_json(object.pose);
    o["group"] = object.group.value_or(1);
    o["mask"] = object.mask.value_or(0xFFFFFFFFu);
    o["padding"] = object.padding;
    o["self_padding"] = object.self_padding;
    objects.push_back(std::move(o));
  }
  out["objects"] = std::move(objects);
  return out;
}

// The column width that fits every value of `values` and the header.
template <class T, class F>
int width(const std::vector<T>& rows, const char* header, F&& value) {
  std::size_t w = std::string(header).size();
  for (const T& row : rows) w = std::max(w, value(row).size());
  return int(w + 2);
}

// A failed call: the command's name, the target and the server's answer; the exit code.
int failed(const char* command, const RemoteOptions& remote, const client::Status& status,
           std::ostream& err) {
  err << "nearpoint " << command << ": " << remote.target << ": " << status.describe() << "\n";
  return exit_code_for(status);
}

int not_found(const char* command, const char* what, const std::string& id,
              const RemoteOptions& remote, std::ostream& err) {
  return failed(command, remote,
                client::Status::error(kNotFound,
                                      std::string("no ") + what + " \"" + id + "\" on this server"),
                err);
}

}  // namespace

int run_scene_list(const ManageOptions& options, std::ostream& out, std::ostream& err) {
  auto client = connect(options.remote, err);
  if (!client) return kExitBadInput;
  auto scenes = client->list_scenes();
  if (!scenes) return failed("scene list", options.remote, scenes.status(), err);
  if (options.remote.json) {
    Json list = Json::array();
    for (const client::SceneSummary& scene : *scenes) list.push_back(scene_json(scene, false));
    out << list.dump() << "\n";
    return 0;
  }
  if (scenes->empty()) {
    out << "no scenes on " << options.remote.target << "\n";
    return 0;
  }
  const int id_width = width(*scenes, "SCENE", [](const auto& s) { return s.scene_id; });
  const int name_width = width(*scenes, "NAME", [](const auto& s) { return s.name; });
  out << std::left << std::setw(id_width) << "SCENE" << std::setw(name_width) << "NAME"
      << std::setw(9) << "OBJECTS"
      << "PAIRS\n";
  for (const client::SceneSummary& scene : *scenes)
    out << std::left << std::setw(id_width) << scene.scene_id << std::setw(name_width) << scene.name
        << std::setw(9) << scene.objects.size() << scene.pair_count << "\n";
  return 0;
}

int run_scene_show(const ManageOptions& options, std::ostream& out, std::ostream& err) {
  auto client = connect(options.remote, err);
  if (!client) return kExitBadInput;
  auto scenes = client->list_scenes();
  if (!scenes) return failed("scene show", options.remote, scenes.status(), err);
  const std::string& id = options.ids.at(0);
  const auto found = std::find_if(scenes->begin(), scenes->end(),
                                  [&](const client::SceneSummary& s) { return s.scene_id == id; });
  if (found == scenes->end()) return not_found("scene show", "scene", id, options.remote, err);
  if (options.remote.json) {
    out << scene_json(*found, true).dump() << "\n";
    return 0;
  }
  out << "scene " << found->scene_id;
  if (!found->name.empty()) out << " \"" << found->name << "\"";
  out << ": " << found->objects.size() << (found->objects.size() == 1 ? " object, " : " objects, ")
      << found->pair_count << (found->pair_count == 1 ? " pair\n" : " pairs\n");
  const int id_width = width(found->objects, "OBJECT", [](const auto& o) { return o.id; });
  const int geometry_width =
      width(found->objects, "GEOMETRY", [](const auto& o) { return o.geometry_id; });
  out << "  " << std::left << std::setw(id_width) << "OBJECT" << std::setw(geometry_width)
      << "GEOMETRY"
      << "INITIAL POSE (translation; rotation w,x,y,z)\n";
  for (const client::SceneObject& object : found->objects) {
    const auto& t = object.pose.translation;
    const auto& q = object.pose.rotation_wxyz;
    out << "  " << std::left << std::setw(id_width) << object.id << std::setw(geometry_width)
        << object.geometry_id << number(t.x()) << "," << number(t.y()) << "," << number(t.z())
        << "; " << number(q[0]) << "," << number(q[1]) << "," << number(q[2]) << "," << number(q[3])
        << "\n";
  }
  return 0;
}

int run_scene_delete(const ManageOptions& options, std::ostream& out, std::ostream& err) {
  auto client = connect(options.remote, err);
  if (!client) return kExitBadInput;
  int code = 0;
  for (const std::string& id : options.ids) {
    const client::Status deleted = client->delete_scene(id);
    if (!deleted.ok()) {
      const int failure = failed("scene delete", options.remote, deleted, err);
      if (code == 0) code = failure;
      continue;
    }
    if (options.remote.json)
      out << Json{{"scene_id", id}, {"deleted", true}}.dump() << "\n";
    else
      out << "deleted scene " << id << "\n";
  }
  return code;
}

int run_geometry_list(const ManageOptions& options, std::ostream& out, std::ostream& err) {
  auto client = connect(options.remote, err);
  if (!client) return kExitBadInput;
  auto geometries = client->list_geometries();
  if (!geometries) return failed("geometry list", options.remote, geometries.status(), err);
  if (options.remote.json) {
    Json list = Json::array();
    for (const client::GeometryInfo& info : *geometries) list.push_back(to_json(info));
    out << list.dump() << "\n";
    return 0;
  }
  if (geometries->empty()) {
    out << "no geometries on " << options.remote.target << "\n";
    return 0;
  }
  const int id_width = width(*geometries, "GEOMETRY", [](const auto& g) { return g.geometry_id; });
  const int name_width = width(*geometries, "NAME", [](const auto& g) { return g.name; });
  out << std::left << std::setw(id_width) << "GEOMETRY" << std::setw(name_width) << "NAME"
      << std::setw(8) << "PIECES" << std::setw(10) << "VERTICES"
      << "BOUNDING RADIUS\n";
  for (const client::GeometryInfo& info : *geometries)
    out << std::left << std::setw(id_width) << info.geometry_id << std::setw(name_width)
        << info.name << std::setw(8) << info.piece_count << std::setw(10) << info.vertex_count
        << number(info.bounding_radius) << "\n";
  return 0;
}

int run_geometry_show(const ManageOptions& options, std::ostream& out, std::ostream& err) {
  auto client = connect(options.remote, err);
  if (!client) return kExitBadInput;
  auto geometries = client->list_geometries();
  if (!geometries) return failed("geometry show", options.remote, geometries.status(), err);
  const std::string& id = options.ids.at(0);
  const auto found =
      std::find_if(geometries->begin(), geometries->end(),
                   [&](const client::GeometryInfo& g) { return g.geometry_id == id; });
  if (found == geometries->end())
    return not_found("geometry show", "geometry", id, options.remote, err);
  if (options.remote.json) {
    out << to_json(*found).dump() << "\n";
    return 0;
  }
  const auto& c = found->bounding_center;
  out << "geometry " << found->geometry_id << " \"" << found->name << "\"\n"
      << "  pieces          " << found->piece_count << "\n"
      << "  vertices        " << found->vertex_count << "\n"
      << "  bounding sphere radius " << number(found->bounding_radius) << " at (" << number(c.x())
      << ", " << number(c.y()) << ", " << number(c.z()) << ")\n";
  return 0;
}

int run_geometry_remove(const ManageOptions& options, std::ostream& out, std::ostream& err) {
  auto client = connect(options.remote, err);
  if (!client) return kExitBadInput;
  int code = 0;
  for (const std::string& id : options.ids) {
    const client::Status removed = client->remove_geometry(id);
    if (!removed.ok()) {
      const int failure = failed("geometry remove", options.remote, removed, err);
      if (code == 0) code = failure;
      continue;
    }
    if (options.remote.json)
      out << Json{{"geometry_id", id}, {"removed", true}}.dump() << "\n";
    else
      out << "removed geometry " << id << "\n";
  }
  return code;
}

namespace {

using Runner = int (*)(const ManageOptions&, std::ostream&, std::ostream&);

// One verb: its ids (none, exactly one, or one or more), the remote options and the callback.
void add_verb(CLI::App& parent, const char* name, const char* description, const char* ids_help,
              int id_count, Runner run, int& exit_code, const RemoteOptionAdder& add_remote,
              const std::string& footer) {
  auto options = std::make_shared<ManageOptions>();
  CLI::App* command = parent.add_subcommand(name, description);
  if (id_count != 0) {
    CLI::Option* ids = command->add_option("ID", options->ids, ids_help)->required();
    if (id_count == 1) ids->expected(1);
  }
  add_remote(*command, options->remote);
  command->footer(footer);
  command->callback(
      [options, run, &exit_code] { exit_code = run(*options, std::cout, std::cerr); });
}

}  // namespace

void add_scene_management(CLI::App& scene, int& exit_code, const RemoteOptionAdder& add_remote,
                          const std::string& exit_codes_help) {
  add_verb(scene, "list", "List the server's scenes (id, name, objects, pairs)", "", 0,
           run_scene_list, exit_code, add_remote,
           "\nExample:\n  nearpoint scene list --json\n" + exit_codes_help);
  add_verb(scene, "show", "Show one scene: its objects, their geometries and initial poses",
           "The scene id", 1, run_scene_show, exit_code, add_remote,
           "\nExample:\n  nearpoint scene show cell-1\n" + exit_codes_help);
  add_verb(scene, "delete", "Delete scenes (their streams get NOT_FOUND from then on)", "Scene ids",
           -1, run_scene_delete, exit_code, add_remote,
           "\nExample:\n  nearpoint scene delete cell-1\n" + exit_codes_help);
}

void add_geometry_subcommand(CLI::App& app, int& exit_code, const RemoteOptionAdder& add_remote,
                             const std::string& exit_codes_help) {
  CLI::App* geometry = app.add_subcommand("geometry", "Geometries stored on the server");
  geometry->require_subcommand(1);
  add_verb(*geometry, "list", "List the stored geometries (id, name, pieces, vertices, radius)", "",
           0, run_geometry_list, exit_code, add_remote,
           "\nExample:\n  nearpoint geometry list\n" + exit_codes_help);
  add_verb(*geometry, "show", "Show one geometry: pieces, vertices, bounding sphere",
           "The geometry id", 1, run_geometry_show, exit_code, add_remote,
           "\nExample:\n  nearpoint geometry show geom-0123456789abcdef0123456789abcdef\n" +
               exit_codes_help);
  add_verb(*geometry, "remove",
           "Remove geometries from the store (scenes that use them keep working)", "Geometry ids",
           -1, run_geometry_remove, exit_code, add_remote,
           "\nExample:\n  nearpoint geometry remove geom-0123456789abcdef0123456789abcdef\n" +
               exit_codes_help);
}

}  // namespace nearpoint::cli
