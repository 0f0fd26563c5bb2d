// SPDX-License-Identifier: Apache-2.0
// Mesh files (OBJ, STL ascii/binary, OFF, PLY; also the other formats assimp reads, e.g. glTF)
// to the convex pieces nearpoint works on: each part of the mesh becomes the convex hull of its
// vertices, given as the hull's vertices only.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace nearpoint::client {

struct MeshImportOptions {
  /// One piece for the whole file (the hull of every part's vertices) instead of one per part.
  bool merge_parts = false;
  /// Multiplies every coordinate (e.g. 0.001 for a file in millimetres); finite and > 0.
  double scale = 1.0;
};

/// One convex piece: the convex hull of a part's vertices, as the extreme points of that set
/// (degenerate parts keep theirs: the corners of a flat part's polygon, the two ends of a
/// collinear one, a single point). Coordinates in the file's frame times `scale`.
struct ConvexPiece {
  /// The part's name in the file (OBJ `o`/`g` name, STL solid name), else the file's stem.
  std::string name;
  /// The hull's vertices, in the order they first appear in the file; no duplicates.
  std::vector<Eigen::Vector3d> vertices;
  /// How many distinct vertices the part had before the hull (a corner shared by several
  /// triangles counts once, whether or not the format repeats it per triangle, as STL does).
  std::size_t source_vertex_count = 0;
};

/// The outcome of `import_mesh`: the pieces, or an error message (and no pieces).
struct MeshImport {
  std::vector<ConvexPiece> pieces;
  std::string error;
  bool ok() const { return error.empty(); }
};

/// One convex piece (hull vertices) per mesh part, or one hull of all parts with merge_parts.
///
/// A part is an object of the file's scene graph (an OBJ `o` or `g` group; the whole file for
/// STL, OFF and PLY) with all its triangles, lines and points, transformed by the file's node
/// transforms. Coordinates are read in single precision (assimp's `ai_real`) and widened exactly.
/// Parts without vertices are skipped. Never throws; never prints. Errors name the file: missing
/// or unreadable file, an unsupported or corrupt file (the parser's message), no vertices at all,
/// a non-finite coordinate (part and vertex named), a scale that is not finite and positive.
MeshImport import_mesh(const std::filesystem::path& file, const MeshImportOptions& options = {});

}  // namespace nearpoint::client
