// SPDX-License-Identifier: Apache-2.0
#include "common.hpp"

#include <cmath>
#include <fstream>
#include <sstream>
#include <system_error>
#include <variant>

namespace nearpoint::robots::detail {

std::string read_file(const std::filesystem::path& file, std::string& text) {
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec)) return file.string() + ": is a directory";
  std::ifstream in(file, std::ios::binary);
  if (!in) return file.string() + ": cannot open the file";
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) return file.string() + ": cannot read the file";
  text = buffer.str();
  return {};
}

std::string resolve_mesh(const std::string& uri, const std::filesystem::path& base_dir,
                         const ImportOptions& options, std::filesystem::path& out) {
  std::error_code ec;
  auto exists = [&](const std::filesystem::path& p) {
    return std::filesystem::is_regular_file(p, ec);
  };
  static constexpr std::string_view kPackage = "package://";
  static constexpr std::string_view kFile = "file://";
  if (uri.empty()) return "empty mesh file name";
  if (uri.starts_with(kPackage)) {
    const std::string rest = uri.substr(kPackage.size());
    std::string tried;
    for (const std::filesystem::path& dir : options.search_path) {
      const std::filesystem::path candidate = dir / rest;
      if (exists(candidate)) {
        out = candidate;
        return {};
      }
      tried += (tried.empty() ? "" : ", ") + dir.string();
    }
    return "mesh '" + uri + "' not found: package:// resolves against the search path (" +
           (tried.empty() ? std::string("empty; give one") : tried) + ")";
  }
  std::filesystem::path path = uri.starts_with(kFile) ? uri.substr(kFile.size()) : uri;
  if (path.is_absolute()) {
    if (!exists(path)) return "mesh '" + uri + "' not found";
    out = path;
    return {};
  }
  if (exists(base_dir / path)) {
    out = base_dir / path;
    return {};
  }
  for (const std::filesystem::path& dir : options.search_path)
    if (exists(dir / path)) {
      out = dir / path;
      return {};
    }
  return "mesh '" + uri + "' not found (looked in " + base_dir.string() +
         (options.search_path.empty() ? std::string() : " and the search path") + ")";
}

std::string load_mesh_piece(const std::filesystem::path& file, const Vec3d& scale,
                            const ImportOptions& options, model::PieceInput& out) {
  if (!detail::finite(scale) || scale.x() == 0 || scale.y() == 0 || scale.z() == 0)
    return "mesh '" + file.string() + "': scale must be finite and non-zero";
  if (!options.meshes)
    return "mesh '" + file.string() + "': no mesh reader was given (ImportOptions::meshes)";
  formats::MeshRequest request;
  request.files = {file};
  request.merge = true;
  std::vector<model::PieceInput> pieces;
  if (std::string error = options.meshes(request, pieces); !error.empty()) return error;
  model::PolytopeInput hull;
  for (const model::PieceInput& piece : pieces) {
    const auto* polytope = std::get_if<model::PolytopeInput>(&piece.shape);
    if (polytope == nullptr) return "mesh '" + file.string() + "': the reader gave no polytope";
    for (const Vec3d& v : polytope->vertices) hull.vertices.push_back(v.cwiseProduct(scale));
  }
  if (hull.vertices.empty()) return "mesh '" + file.string() + "': no vertices";
  out.shape = std::move(hull);
  return {};
}

std::string link_padding(const KinematicTree& tree, const ImportOptions& options,
                         std::vector<double>& padding) {
  if (!std::isfinite(options.default_padding) || options.default_padding < 0)
    return "default padding must be finite and >= 0";
  padding.assign(tree.links.size(), options.default_padding);
  for (const auto& [name, value] : options.link_padding) {
    const int link = tree.find_link(name);
    if (link < 0) return "padding given for link '" + name + "', which the robot does not have";
    if (!std::isfinite(value) || value < 0)
      return "padding of link '" + name + "' must be finite and >= 0";
    padding[link] = value;
  }
  return {};
}

bool finite(const Vec3d& v) {
  return v.allFinite();
}

model::PoseInput to_input(const Pose3d& pose) {
  const Eigen::Quaterniond q(pose.rotation);
  model::PoseInput out;
  out.rotation_wxyz = {q.w(), q.x(), q.y(), q.z()};
  out.translation = pose.translation;
  return out;
}

}  // namespace nearpoint::robots::detail
