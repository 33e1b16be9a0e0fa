// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The geometry of one tile node as the tile GLB carries it (tiles/glb_writer.h
/// writes it, format/glb_reader.h reads it): an indexed triangle mesh in double
/// precision with optional uv sets and lossless per-vertex ids.

#include <cstdint>
#include <vector>

#include "core/geometry.h"

namespace cityatlas::format {

/// Name of the per-vertex feature id attribute (as in the debug glb).
inline constexpr const char* kTileFeatureIdAttribute = "_FEATURE_ID_0";
/// Per-vertex texture index (into the tileset's texture table; -1 untextured)
/// and material index (into its material table; -1 none), lossless like feature ids.
inline constexpr const char* kTileTextureIdAttribute = "_TEXTURE_ID";
inline constexpr const char* kTileMaterialIdAttribute = "_MATERIAL_ID";
/// Largest feature id written: float32 holds every integer up to 2^24 exactly.
inline constexpr uint32_t kMaxTileFeatureId = 1u << 24;

/// An indexed triangle mesh in double precision.
struct TileMesh {
    std::vector<Vec3d> positions;      ///< metres; world (or any frame), the centre is subtracted on writing
    std::vector<Vec2d> uv_original;    ///< optional (empty = absent): TEXCOORD_0, original texture coordinates
    std::vector<Vec2d> uv_atlas;       ///< optional: TEXCOORD_1 (TEXCOORD_0 without uv_original), atlas coordinates
    std::vector<uint32_t> feature_id;  ///< optional, per vertex: building index, _FEATURE_ID_0 (float, lossless)
    std::vector<int32_t> texture_id;   ///< optional, per vertex: _TEXTURE_ID, -1 = untextured (float, lossless)
    std::vector<int32_t> material_id;  ///< optional, per vertex: _MATERIAL_ID, -1 = none (float, lossless)
    std::vector<uint32_t> indices;     ///< triangles, counter-clockwise
};

}  // namespace cityatlas::format
