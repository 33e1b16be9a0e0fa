// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Building a BlockMap's geometry planes (format/blockmap.h; papers/002 §3.3,
/// ../shared/SEED-FEATURES.md §1.2 "Build algorithm", steps 1-3, 5 and 6).
///
/// Passes:
/// 1. **cells**: through every cell centre a vertical ray down from above
///    the buildings (atlas/raycast.h: Embree's watertight test) gives the
///    top and the building; one up from below gives the base;
/// 2. **columns**: one per exposed side (format/blockmap.h), its span from
///    the higher of the cell's base and the neighbour's top (the cell's base
///    when the neighbour stands higher) to the cell's top, `row_m` per texel; shelf-packed, tallest first, into the wall
///    image;
/// 3. **distance**: the exact Chebyshev distance transform (two passes),
///    clamped to 255.
/// The colour planes (roof, walls) are not filled here.
///
/// Deterministic: the planes depend on the triangles and the parameters
/// only (the ray caster's answers do not depend on threads).

#include <span>

#include "core/status.h"
#include "format/blockmap.h"
#include "ingest/scene.h"

namespace cityatlas::atlas {

struct BlockMapParams {
    double cell_m = 1;  ///< grid side
    double row_m = 0;   ///< wall texel height; 0: cell_m
    int wall_width = 1024;  ///< the wall image's width (GL 3.3's least MAX_TEXTURE_SIZE)
};

/// The BlockMap of `triangles` (a node's buildings, in full) on the grid of
/// side params.cell_m aligned to multiples of it from the local origin. No
/// triangles: an empty BlockMap (nx = ny = 0). A bad parameter fails.
Status buildBlockMap(std::span<const Triangle> triangles, const BlockMapParams& params, format::BlockMap* out);

}  // namespace cityatlas::atlas
