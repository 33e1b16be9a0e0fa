// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// A BlockMap file's bytes (format/blockmap_file.h): the colour planes
/// encoded as BC1 (texture_codec.h), the rest as the format says. The build
/// writes them with tiles::writeBytes (tiles/node_blockmaps.h).

#include <cstdint>
#include <vector>

#include "format/blockmap.h"
#include "tiles/texture_codec.h"

namespace cityatlas::tiles {

/// The file's bytes (colour planes, when the BlockMap has them, as BC1 at `quality`).
std::vector<uint8_t> blockMapFileBytes(const format::BlockMap& blockmap, BcQuality quality);
/// The size of that file once the colour planes are made (`coloured`) or
/// without them, from the geometry planes alone: BC1's size depends on the
/// image's size only.
uint64_t blockMapFileSize(const format::BlockMap& blockmap, bool coloured);

}  // namespace cityatlas::tiles
