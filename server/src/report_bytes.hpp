// SPDX-License-Identifier: Apache-2.0
// How large a report can get, checked before any is made: a scene whose reports could exceed
// --max-message-bytes is refused at creation, a query or a stream's update when it arrives (the
// sizes themselves are report_size.hpp's).
#pragma once

#include <cstddef>
#include <optional>
#include <string>

#include "nearpoint/server/errors.hpp"
#include "nearpoint/server/scene_service.hpp"

namespace nearpoint::server {

/// The most one report of `scene` with `options` (outputs and report mode) can take on the wire,
/// threshold events left out.
std::size_t report_bytes_bound(const SceneDefinition& scene, const ResolvedOptions& options);

/// RESOURCE_EXHAUSTED when a report of `scene` with `options` (its outputs and report mode) could
/// be larger than `limit`: such a report could never be sent, so the scene (at creation) or the
/// request is refused instead. The message names the limit, the mode, the bound, how many pairs
/// fit, and which report modes would fit. `field` is "" at creation. `event_bytes`: what a
/// stream's threshold events may add (one update's crossings).
std::optional<Error> check_report_bytes(const SceneDefinition& scene,
                                        const ResolvedOptions& options, std::size_t limit,
                                        const std::string& field, std::size_t event_bytes = 0);

}  // namespace nearpoint::server
