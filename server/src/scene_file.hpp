// SPDX-License-Identifier: Apache-2.0
// `nearpointd --scene FILE`: preloads a scene file's geometries and scene (under the id the file
// requests) into the scene API before the server announces its port, so that clients — a pure DDS
// client among them — find the scene ready. The file format is the client's
// (formats/scene_file.hpp); mesh geometries are not read here (the server links no mesh importer):
// they get an error. A robot description (URDF, MJCF; robots/) becomes an articulated scene whose
// id is the robot's name.
#pragma once

#include <string>

#include "nearpoint/server/errors.hpp"
#include "nearpoint/server/scene_service.hpp"

namespace nearpoint::server {

/// Registers the file's geometries and creates its scene. Errors name the file and the field.
Expected<model::SceneInfo> preload_scene_file(SceneService& service, const std::string& path);

}  // namespace nearpoint::server
