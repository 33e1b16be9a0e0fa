// SPDX-License-Identifier: GPL-3.0-or-later
#include "atlas/sky_view.h"

#include <cmath>

namespace cityatlas::atlas {
namespace {

double radicalInverse2(uint32_t i) {
    uint32_t r = 0;
    for (int b = 0; b < 32; ++b) r |= ((i >> b) & 1u) << (31 - b);
    return static_cast<double>(r) / 4294967296.0;
}

Vec3d unit(const Vec3d& v) { return (1.0 / length(v)) * v; }

}  // namespace

std::vector<Vec3d> hemisphereDirections(int n) {
    std::vector<Vec3d> out;
    out.reserve(static_cast<size_t>(std::max(n, 0)));
    for (int i = 0; i < n; ++i) {
        const double u = (i + 0.5) / n;  // sin^2 theta: cosine-weighted
        const double phi = 2 * M_PI * (radicalInverse2(static_cast<uint32_t>(i)) + 0.5 / n);
        const double r = std::sqrt(u);
        out.push_back({r * std::cos(phi), r * std::sin(phi), std::sqrt(1 - u)});
    }
    return out;
}

double skyViewFactor(const RayCaster& caster, const Vec3d& point, const Vec3d& normal,
                     const std::vector<Vec3d>& directions, double far_m) {
    if (directions.empty() || !(length(normal) > 0)) return 0;
    const Vec3d n = unit(normal);
    // The frame: t horizontal, b up the surface (world up for a wall), n out.
    const Vec3d up{0, 0, 1};
    Vec3d t = cross(up, n);
    t = length(t) > 1e-12 ? unit(t) : Vec3d{1, 0, 0};
    const Vec3d b = cross(n, t);
    const Vec3d origin = surfaceRayOrigin(point, n);
    int sky = 0;
    for (const Vec3d& d : directions) {
        const Vec3d w = d.x * t + d.y * b + d.z * n;
        if (w.z <= 0) continue;  // ground
        if (!caster.occluded(origin, w, 0, far_m)) ++sky;
    }
    return static_cast<double>(sky) / static_cast<double>(directions.size());
}

}  // namespace cityatlas::atlas
