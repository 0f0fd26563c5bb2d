// Entry points shared inside the core: compound queries validate their poses once and then query
// piece pairs without re-checking poses composed from validated ones.
#pragma once

#include "nearpoint/distance.hpp"

namespace nearpoint::detail {

/// Why a pose is unusable (non-finite, not orthonormal, a reflection), or nullptr.
template <class S>
const char* invalid_pose_reason(const Pose<S>& pose);

/// `distance` for poses already known to be valid (the shapes and options are still checked).
template <class S>
DistanceResult<S> distance_with_valid_poses(const Shape<S>& a, const Pose<S>& pose_a,
                                            const Shape<S>& b, const Pose<S>& pose_b,
                                            const DistanceOptions<S>& options, SimplexCache* cache);

}  // namespace nearpoint::detail
