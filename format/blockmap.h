// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// A BlockMap (papers/002, Cignoni et al.; ../shared/SEED-FEATURES.md §1.2):
/// a node's buildings as vertical prisms on a square grid, small enough to
/// ray-cast in a fragment shader as the far field. The value type the atlas
/// stage builds (atlas/blockmap.h), the tiles stage writes and the client
/// draws; it holds no pipeline type.
///
/// The grid: `nx` x `ny` square cells of side `cell_m`, cell (0, 0) starting
/// at (`origin.x`, `origin.y`) of the local frame, a multiple of `cell_m`
/// (so grids of side s and s/2 nest). Heights are 16-bit over [`origin.z`,
/// `z_hi`]. Per cell:
/// - top and **base** (the paper stores a top only and stands on terrain;
///   city models have no terrain and their bases vary, so without a base the
///   walls would reach down to the lowest building's base);
/// - the building (an index into `features`);
/// - the first of its wall columns.
///
/// An occupied cell's side is **exposed** unless the neighbour across it
/// covers it: occupied, as high and with a base as low. That is the paper's
/// boundary texels (a lower neighbour) and also a side under a neighbour
/// whose base is higher (buildings on a slope: the paper stands on terrain
/// and has no such case). Every exposed side has a **column** of its own
/// (the paper averages a cell's sides into one column and scales the
/// columns to fit 256; both are lossy), spanning from the cell's base (when
/// the neighbour's base is higher, or there is none) or the neighbour's top
/// up to the cell's top, in `rows` texels; a cell's
/// columns follow each other in side order +x, -x, +y, -y, so the ray caster
/// finds a side's column from the cell's first one and its exposed sides.
/// The columns are shelf-packed into a `wall_width`-wide image.
///
/// `dist`: the Chebyshev distance in cells to the nearest occupied cell,
/// clamped to 255 (0: occupied), for space leaping.

#include <array>
#include <cstdint>
#include <vector>

#include "core/geometry.h"

namespace cityatlas::format {

inline constexpr uint32_t kBlockMapNone = 0xFFFFFFFFu;
/// The most cells, columns and wall rows a BlockMap may have (the file's
/// limits): 4096 x 4096 cells, an atlas-sized node at its own texel.
inline constexpr uint64_t kBlockMapMaxCells = uint64_t{1} << 24;
inline constexpr uint64_t kBlockMapMaxColumns = uint64_t{1} << 24;
inline constexpr int kBlockMapMaxWallHeight = 1 << 20;

/// Cell sides, in the order a cell's columns follow each other.
enum BlockMapSide : uint8_t { kPlusX = 0, kMinusX = 1, kPlusY = 2, kMinusY = 3 };
inline constexpr std::array<int, 4> kSideDx{1, -1, 0, 0};
inline constexpr std::array<int, 4> kSideDy{0, 0, 1, -1};

struct BlockMapCell {
    uint16_t top = 0;   ///< quantized height; 0: empty (an occupied cell's top is at least 1)
    uint16_t base = 0;  ///< quantized height of the building's base under the cell centre
    uint32_t feature = kBlockMapNone;       ///< index into BlockMap::features
    uint32_t first_column = kBlockMapNone;  ///< index into BlockMap::columns; none without exposed sides
    bool occupied() const { return feature != kBlockMapNone; }
};

struct BlockMapColumn {
    uint32_t cell = 0;      ///< y * nx + x
    uint8_t side = 0;       ///< BlockMapSide
    uint16_t base = 0;      ///< quantized bottom of the wall span (the top is the cell's)
    uint16_t rows = 0;      ///< texels along the span, >= 1
    uint16_t x = 0, y = 0;  ///< the column's first (lowest) texel in the wall image; rows go up in y
};

struct BlockMap {
    int nx = 0, ny = 0;
    double cell_m = 0;
    Vec3d origin{0, 0, 0};  ///< local frame: the grid's corner (x, y) and the bottom of the height range (z)
    double z_hi = 0;        ///< top of the height range
    std::vector<BlockMapCell> cells;   ///< nx * ny, row-major from y = 0
    std::vector<uint8_t> dist;         ///< nx * ny
    std::vector<BlockMapColumn> columns;
    int wall_width = 1024, wall_height = 0;
    std::vector<uint32_t> features;    ///< local index -> scene feature id, in order of first cell
    /// Colour planes, sRGB RGB8, rows from y = 0; both empty when not coloured.
    std::vector<uint8_t> roof;         ///< nx * ny * 3: each cell's roof
    std::vector<uint8_t> walls;        ///< wall_width * wall_height * 3: the columns

    size_t index(int x, int y) const { return static_cast<size_t>(y) * static_cast<size_t>(nx) + static_cast<size_t>(x); }
    bool inside(int x, int y) const { return x >= 0 && y >= 0 && x < nx && y < ny; }
    /// The top of cell (x, y); 0 outside the grid.
    uint16_t topAt(int x, int y) const { return inside(x, y) ? cells[index(x, y)].top : 0; }
    double height(uint16_t q) const { return origin.z + (z_hi - origin.z) * q / 65535.0; }
    /// The nearest quantized height (clamped to the range).
    uint16_t quantize(double z) const;
    /// Bit k set: side k of cell (x, y) is exposed (the neighbour does not cover it); 0 for an empty cell.
    uint8_t exposedSides(int x, int y) const;
    /// The column of side `side` of cell (x, y); kBlockMapNone when that side is not exposed.
    uint32_t columnOf(int x, int y, int side) const;
    /// Bytes of the planes as the client uploads them (render/gl/blockmap_pass.h:
    /// cells 16 B and distance 1 B a cell, columns 8 B, ids 4 B; with colour,
    /// roof and walls as RGB8).
    uint64_t gpuBytes(bool coloured) const {
        const uint64_t cells_n = static_cast<uint64_t>(nx) * static_cast<uint64_t>(ny);
        const uint64_t colour = coloured ? 3 * (cells_n + static_cast<uint64_t>(wall_width) * static_cast<uint64_t>(wall_height)) : 0;
        return 17 * cells_n + 8 * columns.size() + 4 * features.size() + colour;
    }
};

/// The distance plane of `blockmap`'s cells: the exact Chebyshev distance
/// to the nearest occupied cell (a forward and a backward pass over the
/// 8-neighbourhood), clamped to 255; 255 everywhere without one.
std::vector<uint8_t> chebyshevDistances(const BlockMap& blockmap);

}  // namespace cityatlas::format
