// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Blocks as the loader hands them to the render thread: decoded off the
/// render thread, ready to upload (GL) or to inspect (tests). Plain data, no GL.

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "format/blockmap.h"
#include "render/core/tileset_index.h"

namespace cityatlas::render {

/// One node layer's geometry, float32 relative to the node's centre (the
/// centre stays double on the CPU; the renderer subtracts the camera there).
struct MeshData {
    std::vector<float> positions;        ///< xyz per vertex, metres relative to TileNode::centre
    std::vector<float> uv_atlas;         ///< uv per vertex in the node's own atlas ([0,1]^2); empty if untextured
    std::vector<float> uv_original;      ///< leaves: uv per vertex in its original texture; else empty
    std::vector<uint32_t> feature_id;    ///< per vertex: building index
    std::vector<int32_t> texture_id;     ///< per vertex (leaves): index into TilesetIndex::textures, -1 untextured
    std::vector<int32_t> material_id;    ///< per vertex: index into TilesetIndex::materials, -1 none
    std::vector<uint32_t> indices;       ///< triangles; in leaves sorted so each texture's triangles are contiguous
    /// Leaves: the index ranges per original texture, ascending texture id
    /// (-1, untextured, first). Empty for inner nodes (one range: everything).
    struct TextureRange {
        int32_t texture = -1;
        uint32_t first_index = 0, index_count = 0;
        /// Its triangles' box, relative to TileNode::centre: where the texture
        /// is seen, so a client loads only the texture blocks in view.
        Box3d bounds;
    };
    std::vector<TextureRange> texture_ranges;
    uint64_t cpuBytes() const;
};

/// A BC1/BC3 texture with its mip chain, as stored in the DDS (no decoding).
struct CompressedTexture {
    int width = 0, height = 0;
    int channels = 3;  ///< 3: BC1 (DXT1), 4: BC3 (DXT5), 1: BC4 (a computed texture)
    struct Level {
        int width = 0, height = 0;
        uint64_t offset = 0, bytes = 0;  ///< into `data`
    };
    std::vector<Level> levels;
    std::vector<uint8_t> data;  ///< the blocks of every level, back to back (header stripped)
};

/// What a finished load delivers for one block.
struct DecodedBlock {
    BlockId id = kNoBlock;
    BlockKind kind = BlockKind::Geometry;
    MeshData mesh;                 ///< Geometry
    CompressedTexture atlas;       ///< Atlas, Computed (BC4)
    /// Textures: (tileset texture index, texture) for every texture of the block.
    std::vector<std::pair<int32_t, CompressedTexture>> textures;
    /// BlockMap: its planes, the distance plane computed and the colours decoded (sRGB RGB8).
    format::BlockMap blockmap;
    uint64_t bytes_read = 0;       ///< bytes fetched (the file size)
};

}  // namespace cityatlas::render
