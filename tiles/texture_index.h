// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Per scene texture, its (first) tileset texture number, -1 unused
/// (tilesetTextureIndex, tiles/texture_blocks.h): what the leaves' geometry
/// names its textures by. A column whose memory stops at
/// textureIndexBytes() (core/paged_column.h; a city's pages beyond it wait
/// in a scratch file): 4 bytes a texture of the city in the plan and the
/// merge until stop 54.

#include <cstdint>
#include <filesystem>

#include "core/paged_column.h"
#include "ingest/texture_table.h"

namespace cityatlas::tiles {

using TextureIndex = PagedColumn<int32_t>;

/// A quarter of the texture table's budget (16 MiB: 4 million textures in memory).
inline size_t textureIndexBytes() { return TextureTable::defaultMemoryBytes() / 4; }

/// An empty index whose pages past its budget go to `scratch_dir` (empty: the
/// system's temporary folder).
inline TextureIndex makeTextureIndex(const std::filesystem::path& scratch_dir = {}) {
    return TextureIndex(scratch_dir, "the texture index", textureIndexBytes());
}

}  // namespace cityatlas::tiles
