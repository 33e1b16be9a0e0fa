// SPDX-License-Identifier: GPL-3.0-or-later
#include "tiles/feature_bounds.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <meshoptimizer.h>

namespace cityatlas::tiles {

namespace {
// The float nearest below (above) `v`: a double box rounded outwards still
// contains every vertex.
float down(double v) {
    float f = static_cast<float>(v);
    if (static_cast<double>(f) > v) f = std::nextafter(f, -INFINITY);
    return f;
}
float up(double v) {
    float f = static_cast<float>(v);
    if (static_cast<double>(f) < v) f = std::nextafter(f, INFINITY);
    return f;
}
}  // namespace

std::optional<WallSpan> wallSpan(const Triangle& t) {
    const auto& p = t.position_local;
    const Vec3d n = cross(p[1] - p[0], p[2] - p[0]);
    const double n2 = dot(n, n);
    const bool vertical = n2 > 0 && n.z * n.z <= 0.01 * n2;  // within ~5.7 degrees of vertical
    const bool wall = t.semantic == SurfaceSemantic::Wall || (t.semantic == SurfaceSemantic::Unclassified && vertical);
    if (!wall || !(n.x != 0 || n.y != 0)) return std::nullopt;
    WallSpan w;
    for (int i = 0; i < 3; ++i)
        for (int j = i + 1; j < 3; ++j) w.span_m = std::max(w.span_m, std::hypot(p[i].x - p[j].x, p[i].y - p[j].y));
    // Clockwise from +y: atan2(east, north).
    w.azimuth_deg = std::atan2(n.x, n.y) * 180.0 / std::numbers::pi;
    if (w.azimuth_deg < 0) w.azimuth_deg += 360.0;
    if (w.azimuth_deg >= 360.0) w.azimuth_deg = 0.0;
    return w;
}

void FeatureBoundsAccumulator::add(const Triangle& t) {
    Acc& a = acc_.at(t.feature);
    const auto& p = t.position_local;
    for (const Vec3d& v : p) {
        const double c[3] = {v.x, v.y, v.z};
        for (int k = 0; k < 3; ++k) {
            a.lo[k] = std::min(a.lo[k], down(c[k]));
            a.hi[k] = std::max(a.hi[k], up(c[k]));
        }
        const float z = static_cast<float>(v.z);
        a.min_z = std::min(a.min_z, z);
        if (t.semantic == SurfaceSemantic::Ground) a.ground_min_z = std::min(a.ground_min_z, z);
    }
    if (t.texture >= 0) a.textured = true;

    const std::optional<WallSpan> w = wallSpan(t);
    if (!w) return;
    const double span = w->span_m;
    // Equal spans keep the smaller azimuth: the record does not depend on
    // the order triangles come in (a streaming read and a reordered scene
    // agree). Compared in float: two azimuths equal in float give one record.
    const float az_f = static_cast<float>(w->azimuth_deg);
    if (span < a.wall_span_m || (span == a.wall_span_m && az_f >= a.azimuth_deg)) return;
    a.wall_span_m = span;
    a.azimuth_deg = az_f;
}

std::vector<format::FeatureBoundsRecord> FeatureBoundsAccumulator::finish(size_t features) {
    std::vector<format::FeatureBoundsRecord> out(features);
    for (size_t f = 0; f < features; ++f) out[f] = record(f);
    return out;
}

format::FeatureBoundsRecord FeatureBoundsAccumulator::record(size_t f) {
    format::FeatureBoundsRecord r;
    const Acc a = acc_.get(f);
    if (a.empty()) return r;
    for (int k = 0; k < 3; ++k) r.min[k] = a.lo[k], r.max[k] = a.hi[k];
    r.base_z = a.ground_min_z < INFINITY ? a.ground_min_z : a.min_z;
    r.flags = format::FeatureBoundsRecord::kHasGeometry;
    if (a.textured) r.flags |= format::FeatureBoundsRecord::kTextured;
    if (a.wall_span_m >= 0) {
        r.flags |= format::FeatureBoundsRecord::kHasWall;
        // binary16 rounds 359.9 up to 360: that is north, 0.
        const unsigned short h = meshopt_quantizeHalf(a.azimuth_deg);
        r.azimuth_half = h == meshopt_quantizeHalf(360.0F) ? 0 : h;
    }
    return r;
}

std::vector<format::FeatureBoundsRecord> featureBounds(const Scene& scene) {
    FeatureBoundsAccumulator acc({}, scene.features.size() + 1);  // the scene is in memory: so are its records
    for (const Triangle& t : scene.triangles) acc.add(t);
    return acc.finish(scene.features.size());
}

}  // namespace cityatlas::tiles
