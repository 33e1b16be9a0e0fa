// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Visibility of a target (issue 19's `visibility:<building>` computed
/// texture; papers/000 §5.1.1, Figs. 34-35: "from where is the new tower
/// visible?"): the thesis' ratio f(p) = A_unoccluded / A_total, with its
/// offscreen rendering replaced by rays, so results are exact for the grid
/// and independent of threads and GPUs.
///
/// The thesis' camera: at p, looking at the centre m of the target's box,
/// a square image whose equal horizontal and vertical field of view is the
/// smallest that holds all eight corners of the box. Here the image is a
/// grid x grid set of rays through its pixel centres (16 x 16 in the thesis'
/// Fig. 34). A_total counts the rays that hit the target alone; A_unoccluded
/// those whose first hit in the whole scene is a target triangle (or that
/// meet nothing else within the horizon before the target). Rays start
/// 1 cm off the surface along its normal, so a point facing away from the
/// target sees its own building first.
///
/// Where p sees the box over more than a hemisphere (a corner at or behind
/// p's image plane: p inside or beside the box), the half-angle is capped at
/// 85 degrees. 0 when no ray hits the target.

#include <cstdint>
#include <limits>
#include <vector>

#include "atlas/raycast.h"
#include "core/geometry.h"

namespace cityatlas::atlas {

struct VisibilityTarget {
    const RayCaster* scene = nullptr;       ///< every triangle, target included
    std::vector<uint8_t> is_target;         ///< per triangle of `scene`: 1 for the target's
    const RayCaster* target = nullptr;      ///< the target's triangles alone
    Box3d box;                              ///< the target's box
    int grid = 16;
    /// Only what lies within this distance of the point can hide the
    /// target (a computed texture's horizon: a shard holds its
    /// surroundings, not the whole city); the target itself at any distance.
    double horizon_m = std::numeric_limits<double>::infinity();
};

/// The grid's counts at a point: rays that hit the target alone (A_total)
/// and rays whose first hit is the target (A_unoccluded).
struct VisibilityCounts {
    int total = 0, unoccluded = 0;
};
VisibilityCounts visibilityCounts(const VisibilityTarget& t, const Vec3d& point, const Vec3d& normal);

/// f(p) = unoccluded / total (0 without a total) for a point on a surface with outward `normal`.
double visibilityRatio(const VisibilityTarget& t, const Vec3d& point, const Vec3d& normal);

}  // namespace cityatlas::atlas
