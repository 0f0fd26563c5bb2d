// SPDX-License-Identifier: Apache-2.0
#include "nearpoint/client/mesh_loader.hpp"

#include <string>
#include <vector>

#include "nearpoint/client/mesh_import.hpp"

namespace nearpoint::client {

formats::MeshLoader mesh_loader() {
  return [](const formats::MeshRequest& request,
            std::vector<model::PieceInput>& pieces) -> std::string {
    MeshImportOptions options;
    options.merge_parts = request.merge;
    options.scale = request.scale;
    for (const std::filesystem::path& file : request.files) {
      const MeshImport imported = import_mesh(file, options);
      if (!imported.ok()) return imported.error;
      for (const ConvexPiece& piece : imported.pieces) {
        model::PieceInput input;
        input.shape = model::PolytopeInput{piece.vertices};
        pieces.push_back(std::move(input));
      }
    }
    return {};
  };
}

}  // namespace nearpoint::client
