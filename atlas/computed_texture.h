// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Computed textures over the atlas coordinates (issue 19; papers/000
/// §5.1.1-5.1.2, SEED-FEATURES §2.2): a scalar field of the surface, such as
/// the sky-view factor, sampled on a leaf's atlas grid so it draws with the
/// photo atlas's own texture coordinates.
///
/// The texel -> surface map. A leaf layer's computed image has the photo
/// atlas's normalised coordinates at 1/scale of its texels. Each of its
/// texels whose centre lies on a textured triangle's atlas image (closed; the
/// first triangle of the layer's range that has it) stands for the point of
/// that triangle with the same barycentric coordinates: the thesis'
/// (triangle id, barycentric) parameterization, with the thesis'
/// per-triangle textures replaced by the atlas's charts. The other texels of
/// a packed region (its border and the gaps between its triangles) take the
/// triangle of their nearest covered neighbour, grown a ring at a time inside
/// the region, with the barycentric coordinates of their own centre in that
/// triangle's plane (extrapolated, the thesis' border fill), so bilinear
/// filtering at a chart's edge blends values of the chart's own surface.
/// Texels outside every region stand for nothing.
///
/// The map is only one-to-one where the atlas is (AtlasParams::unique_charts):
/// with shared charts, a texel stands for the first of the places sharing it.
/// Untextured triangles have no atlas texels and so no computed values.

#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

#include "atlas/atlas_tree.h"

namespace cityatlas::atlas {

struct TexelSurface {
    uint32_t triangle = 0;  ///< index into AtlasTree::triangles
    Vec3d point;            ///< local frame, metres (on the triangle's plane; inside it when covered)
    Vec3d normal;           ///< the triangle's unit normal (its winding's), in the local frame
    bool covered = false;   ///< the texel's centre lies on the triangle; false: a border texel
};

struct LeafTexelMap {
    int width = 0, height = 0;          ///< texels; row 0 is the bottom row (v up, as the atlas)
    std::vector<int32_t> texel;         ///< width * height: index into `surfaces`, or -1
    std::vector<TexelSurface> surfaces;
    uint64_t covered = 0;               ///< surfaces with covered = true
};

/// The map of leaf `node`'s `layer` at 1/`scale` of its photo atlas (scale 1,
/// 2 or 4: the atlas's sides and regions are multiples of 4 texels, so every
/// computed texel lies in one region). An empty map for an absent layer.
LeafTexelMap leafTexelMap(const AtlasTree& tree, int32_t node, Layer layer, int scale);

/// A computed image: one value per texel, row 0 at the bottom; texels that
/// stand for nothing hold `empty`.
struct ScalarImage {
    int width = 0, height = 0;
    std::vector<float> value;
};

/// Evaluates `field` at every texel that stands for a surface point, on
/// `threads` threads (0: the calling task arena's, all cores at the top
/// level). `field` must be safe to call from many threads; the image does
/// not depend on the thread count.
ScalarImage evaluateComputed(const LeafTexelMap& map, const std::function<double(const TexelSurface&)>& field,
                             int threads = 0, float empty = 0.0f);

/// Texels that stand for nothing, in the images the hierarchy is built from.
inline constexpr float kNoValue = std::numeric_limits<float>::quiet_NaN();

/// An inner node's computed image at 1/`scale` of its photo atlas: each
/// child's image halved (the mean of each 2x2 block's texels that hold a
/// value: a chart's edge is not darkened by empty space) and placed where
/// the photo atlas places the child (childPlacements; its texels are
/// multiples of 4, so of `scale` <= 4). `child_image(c)` gives child c's
/// image (leaves: evaluateComputed with kNoValue as `empty`), or null for
/// none. Texels no child covers hold kNoValue.
ScalarImage innerComputed(const AtlasTree& tree, int32_t node, Layer layer, int scale,
                          const std::function<const ScalarImage*(int32_t child)>& child_image);

/// 8 bits of a unit-range field, rows top-down (the DDS writer's order):
/// round(255 v) clamped to [0, 255]; kNoValue as 0.
format::Image8 quantizeUnit(const ScalarImage& image);

}  // namespace cityatlas::atlas
