// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The sky-view factor of a surface point (issue 19's `sky_view` computed
/// texture; papers/000 §5.1.1 "sky exposure", done physically): the share of
/// the cosine-weighted hemisphere over the surface that sees the sky,
///
///   SVF(p) = (1/pi) * integral over {w . n > 0} of V(p, w) (n . w) dw,
///
/// V = 1 when the ray from p along w leaves the scene upwards (w_z > 0) and
/// hits nothing; directions at or below the horizon are ground (cityatlas has
/// no terrain). An unobstructed roof has 1, an unobstructed wall 1/2. The
/// thesis' version is the visibility of a quad above the city, which ignores
/// the normal and the cosine.
///
/// Estimated with N cosine-weighted directions, the fraction that sees the
/// sky. The directions form a Hammersley set in the surface's own frame: the
/// i-th has cos^2(theta) = 1 - (i + 1/2) / N and azimuth 2 pi (phi_2(i) +
/// 1/(2N)), phi_2 the base-2 radical inverse. The frame's first axis is
/// horizontal and its second points up the surface, so a wall's directions
/// split exactly half above and half below the horizon for N a power of 2:
/// an unobstructed wall gets exactly 1/2, not 1/2 give or take sampling.
/// Rays start 1 cm off the surface along its normal.

#include <vector>

#include "atlas/raycast.h"
#include "core/geometry.h"

namespace cityatlas::atlas {

/// N cosine-weighted Hammersley directions about +z (the file comment), unit length.
std::vector<Vec3d> hemisphereDirections(int n);

/// The sky-view factor at `point` on a surface with outward `normal` (any
/// length but 0), from `directions` (hemisphereDirections). 0 for a
/// surface facing straight down (its hemisphere is all ground). Only
/// triangles within `far_m` of the ray's origin block it (the horizon of a
/// computed texture: what a shard of a larger build can see).
double skyViewFactor(const RayCaster& caster, const Vec3d& point, const Vec3d& normal,
                     const std::vector<Vec3d>& directions,
                     double far_m = std::numeric_limits<double>::infinity());

}  // namespace cityatlas::atlas
