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

/// The texture's own size in texels, per axis; 0 where unknown (no cap).
struct NativeSize {
    int w = 0, h = 0;
};

/// A packed region's size for a texture at `texels_per_u` / `texels_per_v`
/// over the uv box, with a border of real content on every side (borderFor:
/// at most `border` texels): content at least one texel, the total rounded up to whole 4 x 4
/// S3TC blocks (the rounding widens the content, never lowers its resolution).
/// The resolution cap: an axis that would hold more texels per unit than the
/// texture has (`native`) holds exactly the texture's texels instead, its box
/// moved onto texel boundaries so the region is a copy of them; the block
/// rounding then widens the border, never the resolution.
struct RegionSize {
    int w = 0, h = 0;        ///< texels, multiples of 4
    Vec2d uv_min, uv_max;    ///< the uv box grown so the border maps to real texture content
    bool native_u = false, native_v = false;  ///< capped: one texel per texture texel
    double density_u = 0, density_v = 0;      ///< texels per unit of u / v as stored
    double content_w = 0, content_h = 0;      ///< texels the uv box needs at that density (before rounding)
    int border_u = 0, border_v = 0;           ///< border texels on each side along u / v (borderFor)
};

/// The border a region gets along an axis with `content_texels` of content:
/// `max_border` (the --border option), but no more than a quarter of the
/// content (at least one texel). A border protects a region's edge from its
/// neighbours through mip levels; once a level holds a region in a few
/// texels, it shows a few pixels of it and a wider border buys nothing,
/// while tiny regions (one colour, small texture patches) would be mostly border.
int borderFor(double content_texels, int max_border);
RegionSize regionSize(double texels_per_u, double texels_per_v, Vec2d uv_min, Vec2d uv_max, int border,
                      NativeSize native = {});

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
/// Critical triangles in two steps, so a shard splits its own triangles at
/// the distance its plan chose for the whole input:
/// - CriticalDistanceBuilder, one triangle at a time (memory: the critical
///   ones only): the distance d_min is enlarged to when more than
///   `critical_fraction` of the textured triangles would be critical at the
///   requested one (and further if splitting would add too many pieces), and
///   the counts at the requested one;
/// - splitCriticalTriangles at that distance: replaces `triangles` by the
///   split set, `sources` gets each output triangle's index in the input, and
///   fills critical_after_enlarge and the split counts.
/// `pixels_per_metre_at_1m`: ProjectionBound::pixelsPerMetreAt1m(). Each
/// texture's own size in `textures` caps a triangle's content at that
/// resolution: a triangle that fits at it is never critical. The sizes are
/// read from the table as triangles come (a city's table pages, since stop
/// 54: no copy of 8 bytes a texture); the table must outlive the builder.
class CriticalDistanceBuilder {
public:
    CriticalDistanceBuilder(double d_min_requested_m, double pixels_per_metre_at_1m, int atlas_size, int border,
                            double critical_fraction, const TextureTable& textures);
    void add(const Triangle& t);
    CriticalResult finish();

private:
    NativeSize nativeSizeOf(const Triangle& t) const;
    double d_req_, ppm_, room_, fraction_;
    const TextureTable& textures_;
    std::vector<double> fits_from_;
    std::vector<std::pair<double, double>> overshoot_cap_;
    uint64_t textured_ = 0;
};
void splitCriticalTriangles(std::vector<Triangle>& triangles, std::vector<uint32_t>& sources, double d_min_used_m,
                            double pixels_per_metre_at_1m, int atlas_size, int border, std::span<const NativeSize> native,
                            CriticalResult* result);

}  // namespace cityatlas::atlas
