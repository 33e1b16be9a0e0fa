// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Texture size estimation (papers/000 §4.5.2) and critical triangles (§4.5.3).
///
/// For a triangle, `s_world` and `t_world` are the world lengths of the
/// texture-space unit vectors (1,0) and (0,1) mapped through the triangle:
/// metres per unit of u and of v. A texture must carry `s_world * F` texels per
/// unit of u (F = pixels per metre at d_min, ProjectionBound / d_min) for no
/// texel to cover more than one pixel from d_min on.

#include <cstdint>
#include <span>
#include <vector>

#include "atlas/atlas_tree.h"

namespace cityatlas::atlas {

struct TexelDensity {
    double s_world = 0;  ///< metres per unit of u
    double t_world = 0;  ///< metres per unit of v
    Vec2d uv_min, uv_max;
    enum class Kind : uint8_t { Regular, Collinear, SingleColour } kind = Kind::Regular;
};

/// The papers' per-triangle estimate, degenerate texture coordinates included:
/// all three uv equal -> one colour (a 1 x 1 region); uv on a line -> the
/// stretch of the longest uv edge for both axes.
TexelDensity texelDensity(const Triangle& t);

/// A packed region's size for a texture at `texels_per_u` / `texels_per_v`
/// over the uv box, with a border of `border` texels of real content on every
/// side: content at least one texel, the total rounded up to whole 4 x 4
/// S3TC blocks (the rounding widens the content, never lowers its resolution).
struct RegionSize {
    int w = 0, h = 0;        ///< texels, multiples of 4
    Vec2d uv_min, uv_max;    ///< the uv box grown so the border maps to real texture content
};
RegionSize regionSize(double texels_per_u, double texels_per_v, Vec2d uv_min, Vec2d uv_max, int border);

/// Critical triangles (papers/000 §4.5.3): a triangle whose own region cannot
/// fit into one atlas. When more than `critical_fraction` of the textured
/// triangles are critical, d_min is raised until exactly that fraction is;
/// the remaining critical triangles are split at their longest edge (measured
/// in texels) until none is. Should that add more pieces than the scene has
/// textured triangles (at least 10,000), d_min is raised until it would not.
struct CriticalResult {
    double d_min_used_m = 0;
    uint64_t critical_at_requested = 0;
    uint64_t critical_after_enlarge = 0;
    uint64_t triangles_split = 0;
    uint64_t triangles_added = 0;
    bool enlarged_for_split_budget = false;  ///< d_min raised further so splitting stays bounded
};
/// `pixels_per_metre_at_1m`: ProjectionBound::pixelsPerMetreAt1m(). Replaces
/// `triangles` by the split set; `sources` gets each output triangle's index
/// in the input.
CriticalResult resolveCriticalTriangles(std::vector<Triangle>& triangles, std::vector<uint32_t>& sources,
                                        double d_min_requested_m, double pixels_per_metre_at_1m, int atlas_size,
                                        int border, double critical_fraction);

}  // namespace cityatlas::atlas
