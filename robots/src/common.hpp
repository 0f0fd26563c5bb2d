// SPDX-License-Identifier: Apache-2.0
// What the URDF and MJCF importers share: mesh files resolved and read into one convex piece,
// pair lists, per-link padding, reading a whole file.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "nearpoint/robots/robot.hpp"

namespace nearpoint::robots::detail {

/// The file's bytes, or an error "FILE: cannot read (reason)".
std::string read_file(const std::filesystem::path& file, std::string& text);

/// A mesh reference (package://PKG/…, file://…, absolute, or relative to `base_dir` and then to
/// each search path entry) → an existing file, or an error naming the reference and where it
/// looked.
std::string resolve_mesh(const std::string& uri, const std::filesystem::path& base_dir,
                         const ImportOptions& options, std::filesystem::path& out);

/// The convex hull of the mesh file `file` (all its parts), its vertices multiplied by `scale`
/// per axis: one polytope piece. "" or why not.
std::string load_mesh_piece(const std::filesystem::path& file, const Vec3d& scale,
                            const ImportOptions& options, model::PieceInput& out);

/// The padding of `link`'s objects (options.link_padding, else default_padding); "" or why it is
/// unusable. Also checks that every link named in options.link_padding exists.
std::string link_padding(const KinematicTree& tree, const ImportOptions& options,
                         std::vector<double>& padding);

bool finite(const Vec3d& v);
model::PoseInput to_input(const Pose3d& pose);

}  // namespace nearpoint::robots::detail
