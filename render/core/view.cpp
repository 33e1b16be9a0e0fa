// SPDX-License-Identifier: GPL-3.0-or-later
#include "render/core/view.h"

#include <algorithm>
#include <cmath>

namespace cityatlas::render {
namespace {

struct Basis {
    Vec3d forward, right, up;
};

Basis basisOf(const Camera& c) {
    Basis b;
    b.forward = normalized(c.direction);
    Vec3d right = cross(b.forward, c.up);
    if (length(right) < 1e-9) {
        // Looking straight along `up`: any right vector will do; keep it stable.
        right = cross(b.forward, std::abs(b.forward.x) < 0.9 ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0});
    }
    b.right = normalized(right);
    b.up = cross(b.right, b.forward);
    return b;
}

Plane planeThrough(const Vec3d& point, const Vec3d& normal) {
    const Vec3d n = normalized(normal);
    return {n, -dot(n, point)};
}

}  // namespace

Vec3d normalized(const Vec3d& v) {
    const double l = length(v);
    return l > 0 ? (1.0 / l) * v : Vec3d{0, 0, 0};
}

double Camera::focalPx() const { return 0.5 * height_px / std::tan(0.5 * vertical_fov_deg * M_PI / 180.0); }

double Camera::cornerFactor() const {
    const double f = focalPx(), hw = 0.5 * width_px, hh = 0.5 * height_px;
    return 1.0 + (hw * hw + hh * hh) / (f * f);
}

Frustum frustumOf(const Camera& c) {
    const Basis b = basisOf(c);
    const double tan_v = std::tan(0.5 * c.vertical_fov_deg * M_PI / 180.0);
    const double tan_h = tan_v * c.aspect();
    Frustum f;
    // Side planes pass through the eye; their normals point inwards.
    f.planes[0] = planeThrough(c.position, b.right + tan_h * b.forward);        // left
    f.planes[1] = planeThrough(c.position, tan_h * b.forward - b.right);        // right
    f.planes[2] = planeThrough(c.position, b.up + tan_v * b.forward);           // bottom
    f.planes[3] = planeThrough(c.position, tan_v * b.forward - b.up);           // top
    f.planes[4] = planeThrough(c.position + c.near_m * b.forward, b.forward);   // near
    f.planes[5] = planeThrough(c.position + c.far_m * b.forward, -1.0 * b.forward);  // far
    return f;
}

bool outsideFrustum(const Frustum& frustum, const Box3d& box) {
    if (box.empty()) return true;
    for (const Plane& p : frustum.planes) {
        // The box corner furthest along the normal: if even it is outside, all are.
        const Vec3d v{p.n.x >= 0 ? box.max.x : box.min.x, p.n.y >= 0 ? box.max.y : box.min.y,
                      p.n.z >= 0 ? box.max.z : box.min.z};
        if (dot(p.n, v) + p.d < 0) return true;
    }
    return false;
}

double distanceToBox(const Vec3d& p, const Box3d& box) {
    const double dx = std::max({box.min.x - p.x, 0.0, p.x - box.max.x});
    const double dy = std::max({box.min.y - p.y, 0.0, p.y - box.max.y});
    const double dz = std::max({box.min.z - p.z, 0.0, p.z - box.max.z});
    return std::sqrt(dx * dx + dy * dy + dz * dz);
}

std::array<float, 16> viewRotation(const Camera& c) {
    const Basis b = basisOf(c);
    // Rows: right, up, -forward (GL eye space looks down -z).
    std::array<float, 16> m{};
    const Vec3d rows[3] = {b.right, b.up, -1.0 * b.forward};
    for (int r = 0; r < 3; ++r) {
        m[0 * 4 + r] = static_cast<float>(rows[r].x);
        m[1 * 4 + r] = static_cast<float>(rows[r].y);
        m[2 * 4 + r] = static_cast<float>(rows[r].z);
    }
    m[15] = 1;
    return m;
}

std::array<float, 16> projection(const Camera& c) {
    const double f = 1.0 / std::tan(0.5 * c.vertical_fov_deg * M_PI / 180.0);
    const double n = c.near_m, fa = c.far_m;
    std::array<float, 16> m{};
    m[0] = static_cast<float>(f / c.aspect());
    m[5] = static_cast<float>(f);
    m[10] = static_cast<float>((fa + n) / (n - fa));
    m[11] = -1;
    m[14] = static_cast<float>(2 * fa * n / (n - fa));
    return m;
}

}  // namespace cityatlas::render
