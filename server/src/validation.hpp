// SPDX-License-Identifier: Apache-2.0
// Validation of the scene API's inputs, with error paths that name the offending field.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "nearpoint/server/errors.hpp"
#include "nearpoint/server/limits.hpp"
#include "nearpoint/server/report.hpp"
#include "nearpoint/server/scene_service.hpp"

namespace nearpoint::server {

/// An id (scene, object, geometry): 1–kMaxIdBytes bytes of printable ASCII without spaces.
/// INVALID_ARGUMENT naming `field`, quoting at most a short prefix of what was sent.
std::optional<Error> check_id(std::string_view id, const std::string& field);

/// A name (a label, a DDS client_id): at most kMaxNameBytes bytes of UTF-8 text without control
/// characters (empty allowed).
std::optional<Error> check_name(std::string_view name, const std::string& field);

/// A checked pose: finite, quaternion of unit length within kQuaternionNormTolerance (then
/// normalised). `field` names the pose ("poses[3].pose"); errors name ".rotation"/".translation".
Expected<Pose<double>> check_pose(const model::PoseInput& pose, const std::string& field);

/// `overrides` applied on top of `base`, each set field validated. `field` names the options
/// message ("options", "default_options").
Expected<ResolvedOptions> resolve_options(const ResolvedOptions& base,
                                          const model::QueryOptionsInput& overrides,
                                          const std::string& field);

/// A validated geometry with its bounding sphere; `geometry_id` is left empty. Errors name
/// "geometry.…".
Expected<std::shared_ptr<StoredGeometry>> build_geometry(const model::GeometryInput& geometry,
                                                         const ServiceLimits& limits);

}  // namespace nearpoint::server
