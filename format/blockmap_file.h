// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// blockmap/<node>.bin: a BlockMap (format/blockmap.h) as a file. Little-endian:
///
///   offset  type      field
///   0       char[4]   "CABM"
///   4       uint32    version (1)
///   8       uint32    nx, ny
///   16      float64   cell_m, origin x, y, z, z_hi
///   56      uint32    columns, features, wall_width, wall_height
///   72      uint32    flags: bit 0 the colour planes follow
///   76      then the sections, each a uint64 byte count and its bytes:
///           cells    zstd: nx * ny x (uint16 top, uint16 base, uint32 feature, uint32 first_column)
///           columns  zstd: columns x (uint32 cell, uint8 side, uint8 0, uint16 base, rows, x, y)
///           features zstd: features x uint32
///           roof     BC1 blocks of the nx x ny roof colours (sRGB), with flag bit 0
///           walls    BC1 blocks of the wall image, with flag bit 0
///   end-8   uint64    XXH64 (seed 0) of every byte before it
///
/// The distance plane is not stored: readers compute it from the cells
/// (chebyshevDistances, one pass each way), which also keeps a file from
/// lying about it. Non-colour planes are zstd level 19 (long runs: empty
/// ground, equal heights); colour is BC1, as atlases are.
///
/// decodeBlockMapFile checks everything the ray caster indexes with, so a
/// decoded BlockMap is safe to draw: sizes, every cell's building and its
/// columns (one per exposed side, in side order, naming that cell and
/// side), every column inside the wall image.

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/status.h"
#include "format/blockmap.h"

namespace cityatlas::format {

inline constexpr uint32_t kBlockMapFileVersion = 1;

/// The file's bytes; `roof_bc1` and `walls_bc1` are the colour planes' BC1
/// blocks (tiles/texture_codec.h: encodeBc), both empty for no colour.
std::vector<uint8_t> encodeBlockMapFile(const BlockMap& blockmap, std::span<const uint8_t> roof_bc1,
                                        std::span<const uint8_t> walls_bc1);
/// The BlockMap of a file's bytes, its distance plane computed and its
/// colour planes decoded (sRGB RGB8); an invalid-input error naming `where`
/// and the first defect.
Status decodeBlockMapFile(std::span<const uint8_t> bytes, const std::string& where, BlockMap* out);

}  // namespace cityatlas::format
