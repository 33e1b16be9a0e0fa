// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Large original textures split into overlapping tiles: papers/000 §4.6
/// (an original whose memory exceeds twice an atlas's is split into several
/// blocks) with papers/004 §2's overlap, so that bilinear filtering and the
/// first mip levels see the same texels on both sides of a tile line.
///
/// A texture of W x H texels is cut into cores of A x A texels (A = the atlas
/// size, the last row and column smaller); each tile is its core grown by
/// `overlap` texels on every side. A triangle is cut at the core lines in
/// texture space (in each period of a repeating texture it spans), so each
/// piece lies inside one core and samples its tile only; as long as a
/// sample's filter footprint stays within `overlap` texels of the core, the
/// tile gives what the whole texture gives. A triangle repeating the texture
/// over two periods or more is not cut (clipToTiles): it keeps the whole
/// texture.
///
/// How much overlap: bilinear filtering at level 0 reaches half a texel past
/// the core (Hesina's 1 texel), level k reaches 2^k texels; and the tiles are
/// stored as BC1/BC3, whose 4 x 4 blocks are encoded on their own, so a tile
/// encodes exactly the whole texture's blocks only when its origin is a
/// multiple of 4 texels at every level that must agree. `tileOverlap(m)` =
/// 4 * 2^m keeps levels 0..m identical to the untiled texture's (block grid
/// and box-filtered mips both aligned) away from the image border.
///
/// At the image border a tile follows the texture's wrap mode: a repeating
/// texture's overlap wraps around to the opposite side (what GL_REPEAT
/// samples), a clamped one's stops at the edge (what GL_CLAMP_TO_EDGE
/// repeats); the tiles themselves are sampled clamped.

#include <array>
#include <cstdint>
#include <vector>

#include "core/geometry.h"
#include "format/dds.h"
#include "ingest/scene.h"

namespace cityatlas::tiles {

/// Texels [x0, x1) x [y0, y1), rows counted from the top of the image; may
/// extend past the image for a repeating texture (the overlap wraps).
struct TexelRect {
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
    int width() const { return x1 - x0; }
    int height() const { return y1 - y0; }
    friend bool operator==(const TexelRect&, const TexelRect&) = default;
};

struct TileGrid {
    int width = 0, height = 0;  ///< the texture, texels
    int core = 0;               ///< A: the cores' size (the last column and row may be smaller)
    int overlap = 0;            ///< texels added on each side of a core
    bool wraps = false;         ///< the overlap wraps around at the image border (WrapMode::Wrap)
    int columns() const { return core > 0 ? (width + core - 1) / core : 0; }
    int rows() const { return core > 0 ? (height + core - 1) / core : 0; }
    int count() const { return columns() * rows(); }
    /// Tile `index` (row-major from the top left)'s core.
    TexelRect coreOf(int index) const;
    /// Tile `index`'s texels: its core grown by the overlap; clipped to the
    /// image unless the texture wraps.
    TexelRect rectOf(int index) const;
};

/// 4 * 2^mip_levels texels: levels 0..mip_levels of a tile equal the whole
/// texture's, BC blocks included (see the file comment).
constexpr int tileOverlap(int mip_levels) { return 4 << mip_levels; }

/// The default: 2 mip levels seam-free (16 texels, 13 % more texels on a 512 core).
constexpr int kDefaultTileOverlap = tileOverlap(2);

/// Whether a width x height texture is split: more than twice an atlas's
/// texels (papers/000 §4.6).
bool splitsTexture(int width, int height, int atlas_size_px);

/// The grid for a texture (core = the atlas size).
TileGrid tileGridFor(int width, int height, WrapMode wrap, int atlas_size_px, int overlap = kDefaultTileOverlap);

/// The grid of a scene texture that is split (`split` on and more than two
/// atlases of texels, by the size recorded at ingest); an empty grid
/// (count() == 0) for one that stays whole.
TileGrid splitGridOf(const TextureInfo& texture, int atlas_size_px, bool split);

/// The tileset textures a scene texture becomes, as their texels in it: the
/// whole image first, then a split one's tiles (row-major), in the
/// consecutive numbers tilesetTextureIndex (texture_blocks.h) gives them.
std::vector<TexelRect> tilesetEntries(const TextureInfo& texture, int atlas_size_px, bool split);

/// The texels of `rect` from `image` (rows top-down); texels outside the
/// image wrap around (a rect of a repeating texture's grid) or are clamped
/// to the edge.
format::Image8 cropTile(const format::Image8& image, const TexelRect& rect, bool wraps);

/// A triangle corner as the leaves store it: position (local frame), uv in
/// the texture (v = 0 at the image bottom; any period), atlas uv.
struct ClipVertex {
    Vec3d position;
    Vec2d uv, uv_atlas;
};

/// One piece of a triangle inside one tile's core: `uv` now in the tile's
/// own texture space.
struct TilePiece {
    int tile = 0;
    std::array<ClipVertex, 3> corners;
};

/// Cuts `triangle` at every core line it crosses (a repeating texture's in
/// each period it spans; a clamped texture's uv outside [0, 1] belongs to the
/// border tiles) and appends the pieces, in a fan per core cell, with their
/// tile and tile-space uv; position and atlas uv are interpolated. Cut
/// points are computed from each edge's endpoints in a fixed order, so two
/// triangles sharing an edge get the same points (no cracks). Pieces of no
/// area in texture space and position both are dropped.
/// Returns false, appending nothing, for a triangle that repeats a wrapping
/// texture over two periods or more in either axis (a tiled roof, a facade
/// pattern: cutting it at every period would multiply it) or whose
/// coordinates are not finite: such a triangle samples the whole texture.
bool clipToTiles(const TileGrid& grid, const std::array<ClipVertex, 3>& triangle, std::vector<TilePiece>* out);

}  // namespace cityatlas::tiles
