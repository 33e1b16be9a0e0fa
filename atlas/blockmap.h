// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Building a BlockMap's geometry planes (format/blockmap.h; papers/002 §3.3,
/// ../shared/SEED-FEATURES.md §1.2 "Build algorithm", steps 1-3, 5 and 6).
///
/// Passes:
/// 1. **cells**: through every cell centre (or 4 x 4 points: BlockMapSample)
///    a vertical ray down from above the buildings (atlas/raycast.h:
///    Embree's watertight test) gives the top and the building; one up from
///    below gives the base; a building no ray hit takes a free cell under
///    its box (BlockMapParams::keep_small);
/// 2. **columns**: one per exposed side (format/blockmap.h), its span from
///    the higher of the cell's base and the neighbour's top (the cell's base
///    when the neighbour stands higher) to the cell's top, `row_m` per texel; shelf-packed, tallest first, into the wall
///    image;
/// 3. **distance**: format::chebyshevDistances (exact, two passes),
///    clamped to 255.
/// 4. **colours** (when the surfaces' textures and materials are given):
///    a cell's roof is the mean, in linear light, of 4 x 4 vertical rays
///    spread over the cell (stratified and jittered: a regular grid aliases
///    with periodic textures); a wall texel the mean of 4 x 4 horizontal rays
///    into its side from half a cell outside, the first hit within 1.5
///    cells (none: the cell's roof colour). A hit's colour is its texture's
///    texel at the hit's uv (nearest, wrapped as the texture says, at the
///    mip level whose texel matches the samples' spacing when that level is
///    a reduced one (ReducedTextures), else at full resolution through an
///    OpenImageIO ImageCache), else its
///    material's diffuse colour, else grey 0.7; alpha is ignored (the
///    texel's colour counts as opaque).
///
/// Deterministic: the planes depend on the triangles and the parameters
/// only (the ray caster's answers do not depend on threads).

#include <array>
#include <memory>
#include <span>

#include "core/status.h"
#include "format/blockmap.h"
#include "ingest/scene.h"

namespace cityatlas::atlas {

/// Textures reduced to their small mip levels (32 texels a side and less,
/// box-filtered in linear light), each decoded once and kept for every
/// BlockMap of a build: an upper node's samples are tens of texels apart,
/// so they read a reduced level instead of decoding the full image again
/// (10,000 facades of 512 px: each decoded once instead of once a level).
/// Thread-safe. About 4 kB a texture.
class ReducedTextures;
std::shared_ptr<ReducedTextures> makeReducedTextures(size_t textures);

/// What the colour pass needs of the scene (Scene::textures, ::materials).
struct SurfaceTables {
    const TextureTable& textures;
    std::span<const Material> materials;
    size_t cache_mb = 256;  ///< decoded textures kept (OpenImageIO ImageCache)
    /// Small mip levels kept across BlockMaps (makeReducedTextures over the
    /// same textures); null: every sample reads the full image.
    ReducedTextures* reduced = nullptr;
};

/// What the colour pass saw.
struct BlockMapColourStats {
    uint64_t rays = 0, hits = 0;
    uint64_t texels_without_hit = 0;    ///< wall texels given their cell's roof colour
    uint64_t unreadable_samples = 0;    ///< texture reads that failed (grey)
    uint64_t reduced_samples = 0;       ///< texture reads from reduced mip levels (ReducedTextures)
};

/// How a cell's prism is sampled: at its centre (the paper's; a building
/// smaller than a cell may hold no centre and be missing), or the highest of
/// 4 x 4 samples over the cell (conservative: a building wider than a
/// quarter cell both ways is present, silhouettes grow by up to a cell).
enum class BlockMapSample : uint8_t { Centre, Max };

struct BlockMapParams {
    double cell_m = 1;  ///< grid side
    BlockMapSample sample = BlockMapSample::Centre;
    double row_m = 0;   ///< wall texel height; 0: cell_m
    int wall_width = 1024;  ///< the wall image's width (GL 3.3's least MAX_TEXTURE_SIZE)
    /// A building no sample hits (narrower than a cell) takes the cell under
    /// its box's centre when no other building holds it, as a prism of its
    /// box's height: no building vanishes from afar (issue 20) where a cell
    /// is free, at the cost of up to a cell of silhouette (a pixel from the
    /// node's distance). false: the samples alone (the paper).
    bool keep_small = true;
};

/// The grid buildBlockMap lays over `triangles` at `cell_m`: its cells
/// along x and y (as doubles: a grid too large for the file is still counted).
std::array<double, 2> blockMapGridSize(std::span<const Triangle> triangles, double cell_m);

/// The BlockMap of `triangles` (a node's buildings, in full) on the grid of
/// side params.cell_m aligned to multiples of it from the local origin. No
/// triangles: an empty BlockMap (nx = ny = 0). A bad parameter fails.
/// With `surfaces`, also the colour planes (pass 4).
Status buildBlockMap(std::span<const Triangle> triangles, const BlockMapParams& params, format::BlockMap* out,
                     const SurfaceTables* surfaces = nullptr, BlockMapColourStats* stats = nullptr);

/// Pass 4 alone, for planes built without `surfaces`: the colour planes of
/// `blockmap` from the same `triangles` (the build weighs a BlockMap's bytes
/// before paying for its colours).
void colourBlockMap(std::span<const Triangle> triangles, const SurfaceTables& surfaces, format::BlockMap* blockmap,
                    BlockMapColourStats* stats = nullptr);

/// How far a BlockMap's prisms are from the triangles they stand for (B4):
/// the farthest triangle point from the prisms as solids (0 inside one: a
/// party wall between two buildings or a floor is hidden in the original
/// too), and the farthest point of the prisms' visible surface (roofs,
/// exposed side spans, undersides of floating cells) from the triangles;
/// both sampled at `spacing` (a lower bound of the true distance by at most
/// about spacing / sqrt(2)).
struct BlockMapError {
    double triangles_to_prisms_m = 0;
    double prisms_to_triangles_m = 0;
    double hausdorff_m = 0;  ///< the larger of the two
};
/// spacing_m <= 0: a quarter cell (../shared/SEED-FEATURES.md §1.2 step 7),
/// or coarser where the triangles' area would take more than
/// kMaxErrorSamples points at that spacing (the time is bounded; the
/// result's slack, up to spacing / sqrt 2, grows).
inline constexpr uint64_t kMaxErrorSamples = 500'000;
BlockMapError measureBlockMapError(std::span<const Triangle> triangles, const format::BlockMap& blockmap,
                                   double spacing_m = 0);

}  // namespace cityatlas::atlas
