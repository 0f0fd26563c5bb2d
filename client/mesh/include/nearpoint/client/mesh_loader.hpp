// SPDX-License-Identifier: Apache-2.0
// The mesh loader that scene files and robot descriptions need (formats::MeshLoader): each mesh
// file's parts imported (import_mesh) as convex polytope pieces. One definition for the CLI, the
// tests and the benchmarks, so that they read meshes exactly as `nearpoint scene create` does.
#pragma once

#include "nearpoint/formats/scene_file.hpp"

namespace nearpoint::client {

/// Imports every file of a request with its `merge` and `scale`, appending one polytope piece per
/// convex part; the import's error (naming the file) otherwise.
formats::MeshLoader mesh_loader();

}  // namespace nearpoint::client
