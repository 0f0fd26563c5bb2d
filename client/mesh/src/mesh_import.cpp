// SPDX-License-Identifier: Apache-2.0
// Mesh import: assimp reads the file, CGAL finds each part's extreme points.
//
// Why CGAL's extreme_points_3 rather than qhull: its predicates are exact (filtered floating point
// with an exact fallback), so the vertices it keeps are exactly the extreme points of the input —
// the convex set is unchanged, bit for bit, which the distances computed on it rely on. qhull
// decides with floating-point tolerances: it merges nearly coplanar facets (dropping vertices that
// are extreme by a hair) or joggles the input, and it rejects flat or collinear input unless told
// otherwise, whereas extreme_points_3 handles every dimension (3D, a flat polygon, a segment, a
// point). CGAL is header-only and already a dependency of the tests.
#include "nearpoint/client/mesh_import.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <iterator>
#include <sstream>
#include <system_error>
#include <utility>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/convex_hull_3.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Importer.hpp>

namespace nearpoint::client {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;

/// The vertices of one part, as read (after the node transform and the scale).
struct Part {
  std::string name;
  std::vector<Eigen::Vector3d> points;
};

std::string format_point(const Eigen::Vector3d& p) {
  std::ostringstream text;
  text.precision(17);
  text << '(' << p.x() << ", " << p.y() << ", " << p.z() << ')';
  return text.str();
}

bool lexicographic_less(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
}

/// The extreme points of `points`, in the order of their first appearance.
std::vector<Eigen::Vector3d> extreme_points(const std::vector<Eigen::Vector3d>& points) {
  std::vector<Kernel::Point_3> input;
  input.reserve(points.size());
  for (const Eigen::Vector3d& p : points) input.emplace_back(p.x(), p.y(), p.z());
  std::vector<Kernel::Point_3> hull;
  CGAL::extreme_points_3(input, std::back_inserter(hull));

  std::vector<Eigen::Vector3d> extreme;
  extreme.reserve(hull.size());
  for (const Kernel::Point_3& p : hull) extreme.emplace_back(p.x(), p.y(), p.z());
  if (extreme.size() <= 2) {
    // A collinear set (or a single point). CGAL 5.5 takes as the segment's ends the input point
    // nearest to the first one (the first itself) and the farthest from it, which is wrong when
    // the first point lies between the ends. Along a line the lexicographic order of (x, y, z) is
    // the order along the line, so the true ends are the lexicographic extremes — no arithmetic.
    const auto [low, high] = std::minmax_element(points.begin(), points.end(), lexicographic_less);
    extreme = {*low};
    if (*high != *low) extreme.push_back(*high);
  }

  // Keep the file's order: a stable, reproducible vertex list (and one without duplicates).
  std::sort(extreme.begin(), extreme.end(), lexicographic_less);
  std::vector<bool> taken(extreme.size(), false);
  std::vector<Eigen::Vector3d> ordered;
  ordered.reserve(extreme.size());
  for (const Eigen::Vector3d& p : points) {
    const auto it = std::lower_bound(extreme.begin(), extreme.end(), p, lexicographic_less);
    if (it == extreme.end() || *it != p) continue;
    const auto index = static_cast<std::size_t>(it - extreme.begin());
    if (taken[index]) continue;
    taken[index] = true;
    ordered.push_back(p);
  }
  return ordered;
}

std::size_t count_distinct(std::vector<Eigen::Vector3d> points) {
  std::sort(points.begin(), points.end(), lexicographic_less);
  return static_cast<std::size_t>(std::unique(points.begin(), points.end()) - points.begin());
}

Eigen::Matrix4d to_eigen(const aiMatrix4x4& m) {
  Eigen::Matrix4d out;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out(r, c) = static_cast<double>(m[r][c]);
  return out;
}

/// Collects one Part per node that holds meshes (all of its meshes together: assimp splits one
/// OBJ object into a mesh per material, yet the object is the part whose hull is wanted).
/// Returns an error message, or "" on success.
std::string collect_parts(const aiScene& scene, const aiNode& node, const Eigen::Matrix4d& parent,
                          double scale, std::vector<Part>& parts) {
  const Eigen::Matrix4d transform = parent * to_eigen(node.mTransformation);
  if (node.mNumMeshes > 0) {
    Part part;
    part.name = node.mName.C_Str();
    for (unsigned m = 0; m < node.mNumMeshes; ++m) {
      if (node.mMeshes[m] >= scene.mNumMeshes) return "corrupt scene: mesh index out of range";
      const aiMesh& mesh = *scene.mMeshes[node.mMeshes[m]];
      if (part.name.empty()) part.name = mesh.mName.C_Str();
      for (unsigned v = 0; v < mesh.mNumVertices; ++v) {
        const aiVector3D& raw = mesh.mVertices[v];
        const Eigen::Vector3d read(raw.x, raw.y, raw.z);
        const std::string where =
            (part.name.empty() ? std::string("the mesh") : "part '" + part.name + "'") +
            ", vertex " + std::to_string(part.points.size() + 1);
        if (!read.allFinite()) return where + " has a non-finite coordinate " + format_point(read);
        const Eigen::Vector3d placed =
            scale * (transform.topLeftCorner<3, 3>() * read + transform.topRightCorner<3, 1>());
        if (!placed.allFinite())
          return where +
                 " is not finite after the node transform and scale: " + format_point(placed);
        part.points.push_back(placed);
      }
    }
    if (!part.points.empty()) parts.push_back(std::move(part));
  }
  for (unsigned c = 0; c < node.mNumChildren; ++c) {
    std::string error = collect_parts(scene, *node.mChildren[c], transform, scale, parts);
    if (!error.empty()) return error;
  }
  return {};
}

MeshImport import_or_error(const std::filesystem::path& file, const MeshImportOptions& options) {
  MeshImport out;
  const auto fail = [&](const std::string& message) {
    out.pieces.clear();
    out.error = file.string() + ": " + message;
    return out;
  };
  if (!std::isfinite(options.scale) || !(options.scale > 0)) {
    std::ostringstream text;
    text << "scale must be finite and positive, got " << options.scale;
    return fail(text.str());
  }
  std::error_code ec;
  const std::filesystem::file_status status = std::filesystem::status(file, ec);
  if (status.type() == std::filesystem::file_type::not_found) return fail("no such file");
  if (ec) return fail("cannot read: " + ec.message());
  if (!std::filesystem::is_regular_file(status)) return fail("not a regular file");

  // No post-processing: the vertices are wanted exactly as written. Without a DefaultLogger
  // assimp logs nowhere, so nothing reaches stdout or stderr.
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(file.string(), 0);
  if (scene == nullptr) return fail(std::string("cannot import: ") + importer.GetErrorString());
  if ((scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE) != 0 || scene->mRootNode == nullptr)
    return fail("cannot import: the file holds no complete mesh");

  std::vector<Part> parts;
  const std::string error =
      collect_parts(*scene, *scene->mRootNode, Eigen::Matrix4d::Identity(), options.scale, parts);
  if (!error.empty()) return fail(error);
  if (parts.empty()) return fail("the mesh has no vertices");

  const std::string stem = file.stem().string();
  if (options.merge_parts) {
    Part all{stem, {}};
    for (const Part& part : parts)
      all.points.insert(all.points.end(), part.points.begin(), part.points.end());
    parts = {std::move(all)};
  }
  for (std::size_t i = 0; i < parts.size(); ++i) {
    ConvexPiece piece;
    piece.name = parts[i].name;
    if (piece.name.empty())
      piece.name = parts.size() == 1 ? stem : stem + "-" + std::to_string(i + 1);
    piece.vertices = extreme_points(parts[i].points);
    piece.source_vertex_count = count_distinct(parts[i].points);
    out.pieces.push_back(std::move(piece));
  }
  return out;
}

}  // namespace

MeshImport import_mesh(const std::filesystem::path& file, const MeshImportOptions& options) {
  // assimp catches its parsers' exceptions itself; this catches what is left (out of memory, a
  // CGAL precondition) so that no exception crosses the library's boundary.
  try {
    return import_or_error(file, options);
  } catch (const std::exception& e) {
    MeshImport out;
    out.error = file.string() + ": cannot import: " + e.what();
    return out;
  }
}

}  // namespace nearpoint::client
