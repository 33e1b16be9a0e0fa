// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Bytes of a block -> what the renderer uploads (render/core/decoded.h).
/// Pure functions, no I/O: the loader's workers call them off the render
/// thread, tests call them directly. Every check that could let a damaged
/// block reach the GPU is here: sizes, counts and ids against tileset.json.

#include <cstdint>
#include <vector>

#include "core/status.h"
#include "render/core/decoded.h"
#include "render/core/tileset_index.h"

namespace cityatlas::render {

/// A node layer's Draco GLB: float positions relative to the node centre,
/// the uv sets, ids; leaves' triangles sorted by texture with their ranges.
/// Fails (one line naming the uri) on a decode error, a triangle count other
/// than tileset.json's, or an id out of range.
Status decodeGeometryBlock(const TilesetIndex& index, BlockId id, const std::vector<uint8_t>& bytes, MeshData* out);

/// A DDS (an atlas, or one texture sliced from a texture block) -> its levels.
/// `expect_channels` 0 accepts either format.
Status decodeDds(const uint8_t* data, size_t size, int expect_channels, CompressedTexture* out);

/// Any block: dispatches on its kind and checks the byte size against tileset.json.
Status decodeBlock(const TilesetIndex& index, BlockId id, const std::vector<uint8_t>& bytes, DecodedBlock* out);

}  // namespace cityatlas::render
