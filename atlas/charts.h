// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// The regions one texture takes in one node's atlas (papers/000 §4.5.2,
/// refined): its triangles are grouped into charts, each chart becomes one
/// packed region at the largest density of its triangles (capped at the
/// texture's own resolution), and neighbouring charts are merged where one
/// region costs fewer texels than two (their borders and gaps overlap).
/// Internal to the atlas stage; exposed for tests.

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "atlas/texel_estimate.h"

namespace cityatlas::atlas {

/// One triangle as the planner sees it: its uv box and texels per unit of u
/// and v at 1 m (texel density times ProjectionBound::pixelsPerMetreAt1m()).
struct ChartMember {
    Vec2d uv_min, uv_max;
    double per_u_1m = 0, per_v_1m = 0;
    /// Unique charts only (surfaceComponents): members of different surfaces
    /// never share a chart, whatever their uv boxes. 0 everywhere otherwise.
    uint32_t surface = 0;
};

struct PlannedRegion {
    RegionSize size;
    double per_u_1m = 0, per_v_1m = 0;  ///< the chart's need at 1 m (max over its members)
    Vec2d uv_min, uv_max;               ///< the members' uv box, border excluded
    bool single_colour = false;         ///< every member has one uv: the region is one colour
};

struct TextureRegions {
    std::vector<PlannedRegion> regions;
    std::vector<uint32_t> region_of;  ///< per member: its region
};

struct ChartSettings {
    double d_min_m = 1;      ///< the distance the content is sized for
    double shrink = 1;       ///< < 1 lowers the content resolution (forced leaves)
    int border_px = 8;
    int atlas_size_px = 512;
    NativeSize native;       ///< the texture's own size (0: unknown, no cap)
    bool merge = true;       ///< merge charts where that saves texels
    /// Hold the texture at its own resolution on both axes (texture_economy.h):
    /// exact regions, no original needed. Needs a known native size.
    bool promote = false;
    /// Unique charts (`--unique-charts`): no two world-distinct triangles
    /// share atlas texels. Charts never join members of different surfaces,
    /// and two charts merge only where their uv boxes are disjoint.
    bool unique = false;
};

/// World-connected surfaces of one texture's triangles, for unique charts:
/// two triangles are one surface when they are the only two along an edge
/// (both endpoints equal in position and in uv, bit for bit) and lie on
/// opposite sides of it in uv, so their uv triangles meet along it without
/// folding over it; transitively. Inside such a surface the uv -> world map is continuous and
/// one-to-one along every joint, so the surface's texels belong to one place
/// each (a surface that wraps around onto its own texels again is not
/// detected: charts are checked texel by texel in the tests). A triangle
/// with zero uv area joins nothing. Returns a surface id per triangle (the
/// smallest position in it).
struct SurfaceTriangle {
    std::array<Vec3d, 3> position;
    std::array<Vec2d, 3> uv;
};
std::vector<uint32_t> surfaceComponents(std::span<const SurfaceTriangle> triangles);

/// Charts: members whose uv boxes overlap (and whose surfaces agree), transitively. Returns a chart id per
/// member (the smallest member position in its chart).
std::vector<uint32_t> uvCharts(std::span<const ChartMember> members);

/// Charts (transitively overlapping uv boxes), then greedy merging: two
/// regions whose bordered uv boxes overlap or touch become one when the union's
/// region has fewer texels than the two and still fits one atlas. Deterministic.
TextureRegions planTextureRegions(std::span<const ChartMember> members, const ChartSettings& settings);

/// The distance from which every texel of `r` covers at most one pixel
/// (0 for one colour).
double sharpFrom(const PlannedRegion& r);

}  // namespace cityatlas::atlas
