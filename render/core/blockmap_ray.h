// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The BlockMap ray caster's traversal in C++ (format/blockmap.h;
/// papers/002 §3.2, ../shared/SEED-FEATURES.md §1.2 "Rendering"): the twin
/// of the fragment shader's, step for step, so tests can hold the shader to
/// it and it to a brute-force intersection with the prisms.
///
/// The walk runs in grid units (a cell is 1 wide, heights in cells above
/// the range's bottom) from where the ray enters the grid's box: an
/// Amanatides-Woo DDA over the cells; where the distance plane says D >= 2
/// every cell within D - 1 is empty, so the ray leaves that square in one
/// step (space leaping). In an occupied cell the ray hits
/// - the side it entered through, when it enters between base and top, or
///   below the base by no more than it descends over half a cell
///   (sideSkirt), never below the grid's box;
/// - the roof, when it enters above the top and leaves at or below it;
/// - the underside, when it enters below the base and leaves at or above it.

#include <cstdint>

#include "core/geometry.h"
#include "format/blockmap.h"

namespace cityatlas::render {

/// What a prism face a ray hits is: one of the four sides (BlockMapSide:
/// the side of the hit cell, facing the ray), the roof or the underside.
inline constexpr int kBlockMapRoof = 4;
inline constexpr int kBlockMapUnderside = 5;

struct BlockMapHit {
    bool hit = false;
    double t = 0;       ///< along the ray's direction as given (metres for a unit direction)
    int x = -1, y = -1; ///< the hit cell
    int face = -1;      ///< BlockMapSide, kBlockMapRoof or kBlockMapUnderside
    int steps = 0;      ///< loop iterations taken (cells visited and leaps)
};

/// How far below a cell's base a descending ray entering through side
/// `face` still hits that side, in the units of `d` (grid units: cells):
/// what the ray descends over half a cell of horizontal travel. A wall
/// stands up to half a cell from where the cell's centre put it, and a
/// BlockMap has no ground: without this a ray down through a gap or
/// courtyard narrower than the full detail's would pass under the far
/// wall's base where the full detail's ray meets that wall (issue 20: no
/// interior hole). 0 for a rising or vertical ray and for the roof and
/// underside.
double sideSkirt(const Vec3d& d, int face);

/// The nearest prism face on the ray `origin + t * direction` (local frame,
/// t > 0; `direction` not zero). `leap`: use the distance plane (the shader
/// does); false walks every cell (for tests).
BlockMapHit castBlockMapRay(const format::BlockMap& bm, const Vec3d& origin, const Vec3d& direction, bool leap = true);

}  // namespace cityatlas::render
