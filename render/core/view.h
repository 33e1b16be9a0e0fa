// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The camera in the tileset's local frame (metres, z up, double), its view
/// frustum, box distances, and the matrices a renderer needs. Rendering is
/// camera-relative: the view matrix is a pure rotation (the camera sits at the
/// origin) and each node is translated by (node centre - camera position),
/// computed in double, so float32 never sees ECEF-sized coordinates.

#include <array>

#include "core/geometry.h"

namespace cityatlas::render {

struct Camera {
    Vec3d position;
    Vec3d direction{0, 1, 0};   ///< unit, where the camera looks
    Vec3d up{0, 0, 1};          ///< approximately up; orthogonalised against direction
    double vertical_fov_deg = 60;
    int width_px = 1280, height_px = 720;
    double near_m = 0.5, far_m = 1e5;
    double aspect() const { return static_cast<double>(width_px) / height_px; }
    /// (height / 2) / tan(fov / 2): pixels per unit of tangent at the screen centre.
    double focalPx() const;
    /// 1 + tan^2 of the angle between the view axis and a frustum corner ray.
    double cornerFactor() const;
};

/// A plane n.p + d = 0; the inside is n.p + d >= 0.
struct Plane {
    Vec3d n;
    double d = 0;
};

struct Frustum {
    std::array<Plane, 6> planes;  ///< left, right, bottom, top, near, far
};

Frustum frustumOf(const Camera& camera);

/// True when the box lies entirely outside one of the planes (conservative:
/// a box that straddles corners may count as inside, never the reverse).
bool outsideFrustum(const Frustum& frustum, const Box3d& box);

/// Euclidean distance from `p` to the box (0 inside).
double distanceToBox(const Vec3d& p, const Box3d& box);

/// Column-major 4x4: the camera's rotation (world axes -> eye axes, GL
/// convention: looking down -z, y up), no translation.
std::array<float, 16> viewRotation(const Camera& camera);

/// Column-major 4x4 OpenGL perspective projection from fov, aspect, near, far.
std::array<float, 16> projection(const Camera& camera);

Vec3d normalized(const Vec3d& v);

}  // namespace cityatlas::render
