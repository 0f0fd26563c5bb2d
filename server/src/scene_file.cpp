// SPDX-License-Identifier: Apache-2.0
#include "scene_file.hpp"

#include <map>

#include "nearpoint/formats/scene_file.hpp"
#ifdef NEARPOINT_HAVE_ROBOTS
#include "nearpoint/robots/robot.hpp"
#endif

namespace nearpoint::server {

Expected<model::SceneInfo> preload_scene_file(SceneService& service, const std::string& path) {
  formats::SceneFile file;
#ifdef NEARPOINT_HAVE_ROBOTS
  // A robot description (URDF with its SRDF beside it, MJCF): an articulated scene under the
  // robot's name. Meshes are refused by name, as for scene files.
  if (robots::is_robot_file(path)) {
    if (std::string error = robots::load_robot_scene(path, {}, {}, file); !error.empty())
      return invalid_argument("", error);
  } else
#endif
      if (std::string error = formats::load_scene_file(path, /*meshes=*/{}, file); !error.empty())
    return invalid_argument("", error);
  if (file.robot) {
#ifdef NEARPOINT_HAVE_ROBOTS
    if (std::string error = robots::add_robot_to_scene(file, {}); !error.empty())
      return invalid_argument("", path + ": robot: " + error);
#else
    return invalid_argument("", path + ": \"robot\": this nearpointd reads no robot descriptions");
#endif
  }
  std::map<std::string, std::string> ids;
  for (const auto& [name, geometry] : file.geometries) {
    Expected<model::GeometryInfo> info = service.register_geometry(geometry);
    if (!info)
      return Error{info.error().code, "",
                   path + ": geometries." + name + ": " + info.error().describe()};
    ids[name] = info->geometry_id;
  }
  for (std::size_t i = 0; i < file.scene.objects.size(); ++i)
    if (!file.geometry_names[i].empty())
      file.scene.objects[i].geometry_id = ids.at(file.geometry_names[i]);
  Expected<model::SceneInfo> scene = service.create_scene(file.scene);
  if (!scene) return Error{scene.error().code, "", path + ": " + scene.error().describe()};
  return scene;
}

}  // namespace nearpoint::server
