// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Triangle-set subdivision of a node (papers/000 §4.5.3, Figure 28).

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "ingest/scene.h"

namespace cityatlas::atlas {

/// Splits `ids` (indices into `triangles`) into four groups: sorted by
/// centroid along the longest axis of their bounding box and cut where the
/// running weight is closest to half, then each half likewise along the second
/// longest axis. Group index = first-axis half + 2 * second-axis half, so
/// groups map onto atlas quadrants in the same spatial order. With two or more
/// triangles at least two groups are non-empty and every cut leaves both sides
/// non-empty (the papers' termination argument). `weight` is per triangle
/// (the caller passes world area of textured triangles); all-zero weights fall
/// back to counting triangles, as does an empty `weight` (the caller's guard
/// against deep chains of ever smaller triangles). Ties are broken by index: deterministic.
std::array<std::vector<uint32_t>, 4> splitIntoFour(std::span<const uint32_t> ids,
                                                   std::span<const Triangle> triangles,
                                                   std::span<const double> weight);

/// The same cuts over given points, one per triangle (e.g. texture-space
/// centroids as (u, v, 0)), their box taken from the points.
std::array<std::vector<uint32_t>, 4> splitIntoFourAt(std::span<const uint32_t> ids, std::span<const Vec3d> points,
                                                     std::span<const double> weight);

}  // namespace cityatlas::atlas
