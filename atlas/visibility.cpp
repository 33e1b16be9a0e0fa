// SPDX-License-Identifier: GPL-3.0-or-later
#include "atlas/visibility.h"

#include <algorithm>
#include <cmath>

namespace cityatlas::atlas {
namespace {

const double kMaxHalfTan = std::tan(85.0 * M_PI / 180.0);

Vec3d unit(const Vec3d& v) { return (1.0 / length(v)) * v; }

}  // namespace

VisibilityCounts visibilityCounts(const VisibilityTarget& t, const Vec3d& point, const Vec3d& normal) {
    VisibilityCounts out;
    if (!t.scene || !t.target || t.box.empty() || t.grid < 1 || !(length(normal) > 0)) return out;
    const Vec3d origin = surfaceRayOrigin(point, normal);
    const Vec3d m = 0.5 * (t.box.min + t.box.max);
    if (!(length(m - origin) > 0)) return out;
    // The camera frame: d at the box centre, r and u across the image.
    const Vec3d d = unit(m - origin);
    const Vec3d helper = std::abs(d.z) < 0.9 ? Vec3d{0, 0, 1} : Vec3d{1, 0, 0};
    const Vec3d r = unit(cross(d, helper)), u = cross(r, d);
    // The smallest square field of view holding the eight corners.
    double half = 0;
    for (int k = 0; k < 8; ++k) {
        const Vec3d c{(k & 1) ? t.box.max.x : t.box.min.x, (k & 2) ? t.box.max.y : t.box.min.y,
                      (k & 4) ? t.box.max.z : t.box.min.z};
        const Vec3d v = c - origin;
        const double z = dot(v, d);
        if (z <= 0) {
            half = kMaxHalfTan;
            break;
        }
        half = std::max({half, std::abs(dot(v, r)) / z, std::abs(dot(v, u)) / z});
    }
    half = std::min(half, kMaxHalfTan);
    for (int j = 0; j < t.grid; ++j)
        for (int i = 0; i < t.grid; ++i) {
            const double x = ((i + 0.5) / t.grid * 2 - 1) * half, y = ((j + 0.5) / t.grid * 2 - 1) * half;
            const Vec3d dir = d + x * r + y * u;
            const RayHit target = t.target->nearest(origin, dir);
            if (!target.hit) continue;
            ++out.total;
            // Blocked by what lies before the target and within the horizon.
            const RayHit first = t.scene->nearest(origin, dir, 0, std::min(target.distance, t.horizon_m));
            if (!first.hit || (first.triangle < t.is_target.size() && t.is_target[first.triangle])) ++out.unoccluded;
        }
    return out;
}

double visibilityRatio(const VisibilityTarget& t, const Vec3d& point, const Vec3d& normal) {
    const VisibilityCounts c = visibilityCounts(t, point, normal);
    return c.total > 0 ? static_cast<double>(c.unoccluded) / c.total : 0.0;
}

}  // namespace cityatlas::atlas
