// SPDX-License-Identifier: Apache-2.0
// The JSON shape syntax lives in the transport-free formats library (formats/), shared with scene
// files and nearpointd; the command-line code names it in its own namespace.
#pragma once

#include "nearpoint/formats/json_shapes.hpp"

namespace nearpoint::cli {
using formats::describe_type;
using formats::Json;
using formats::kShapeKinds;
using formats::parse_pose;
using formats::parse_shape;
using formats::PlacedShape;
using formats::user_key;
}  // namespace nearpoint::cli
