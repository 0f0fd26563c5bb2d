// Validation of the scene API's inputs, with error paths that name the offending field.
#pragma once

#include <memory>
#include <string>

#include "nearpoint/server/errors.hpp"
#include "nearpoint/server/limits.hpp"
#include "nearpoint/server/scene_service.hpp"
#include "nearpoint/server/scene_types.hpp"

namespace nearpoint::server {

/// A checked pose: finite, quaternion of unit length within kQuaternionNormTolerance (then
/// normalised). `field` names the pose ("poses[3].pose"); errors name ".rotation"/".translation".
Expected<Pose<double>> check_pose(const PoseInput& pose, const std::string& field);

/// `overrides` applied on top of `base`, each set field validated. `field` names the options
/// message ("options", "default_options").
Expected<ResolvedOptions> resolve_options(const ResolvedOptions& base,
                                          const QueryOptionsInput& overrides,
                                          const std::string& field);

/// A validated geometry with its bounding sphere; `geometry_id` is left empty. Errors name
/// "geometry.…".
Expected<std::shared_ptr<StoredGeometry>> build_geometry(const GeometryInput& geometry,
                                                         const ServiceLimits& limits);

}  // namespace nearpoint::server
