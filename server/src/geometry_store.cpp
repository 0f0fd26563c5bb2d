// SPDX-License-Identifier: Apache-2.0
// The service's geometry store: geometries stored once under their content ids, shared by every
// scene that uses them.
#include <algorithm>

#include "content_hash.hpp"
#include "nearpoint/server/scene_service.hpp"
#include "validation.hpp"

namespace nearpoint::server {

Expected<std::shared_ptr<const StoredGeometry>> SceneService::store_geometry(
    std::shared_ptr<StoredGeometry> geometry, const std::string& field) {
  std::unique_lock lock(geometries_mutex_);
  const auto found = geometries_.find(geometry->info.geometry_id);
  if (found != geometries_.end()) return found->second;  // the same content: idempotent
  if (geometries_.size() >= limits_.max_geometries)
    return resource_exhausted(
        field, text("the server holds ", geometries_.size(), " geometries; the limit is ",
                    limits_.max_geometries, " (--max-geometries)"));
  geometry->registration = next_geometry_number_++;
  geometries_.emplace(geometry->info.geometry_id, geometry);
  return std::shared_ptr<const StoredGeometry>(std::move(geometry));
}

Expected<model::GeometryInfo> SceneService::register_geometry(
    const model::GeometryInput& geometry) {
  Expected<std::shared_ptr<StoredGeometry>> built = build_geometry(geometry, limits_);
  if (!built) return built.error();
  built.value()->info.geometry_id = geometry_content_id(geometry);
  Expected<std::shared_ptr<const StoredGeometry>> stored =
      store_geometry(std::move(built.value()), "");
  if (!stored) return stored.error();
  return stored.value()->info;
}

Outcome SceneService::remove_geometry(const std::string& geometry_id) {
  if (auto error = check_id(geometry_id, "geometry_id")) return *error;
  std::unique_lock lock(geometries_mutex_);
  if (geometries_.erase(geometry_id) == 0)
    return not_found("geometry_id", text("no geometry ", quoted(geometry_id)));
  return {};
}

std::vector<model::GeometryInfo> SceneService::list_geometries() const {
  std::vector<model::GeometryInfo> out;
  {
    std::shared_lock lock(geometries_mutex_);
    out.reserve(geometries_.size());
    std::vector<const StoredGeometry*> stored;
    stored.reserve(geometries_.size());
    for (const auto& [id, geometry] : geometries_) stored.push_back(geometry.get());
    // Registration order (ids are content hashes and say nothing of it).
    std::sort(stored.begin(), stored.end(), [](const StoredGeometry* a, const StoredGeometry* b) {
      return a->registration < b->registration;
    });
    for (const StoredGeometry* geometry : stored) out.push_back(geometry->info);
  }
  return out;
}

std::shared_ptr<const StoredGeometry> SceneService::find_geometry(
    const std::string& geometry_id) const {
  std::shared_lock lock(geometries_mutex_);
  const auto found = geometries_.find(geometry_id);
  return found == geometries_.end() ? nullptr : found->second;
}

std::size_t SceneService::geometry_count() const {
  std::shared_lock lock(geometries_mutex_);
  return geometries_.size();
}

}  // namespace nearpoint::server
