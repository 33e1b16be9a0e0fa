// SPDX-License-Identifier: GPL-3.0-or-later
#include "render/core/lenses.h"

#include <algorithm>
#include <cmath>

namespace cityatlas::render {
namespace {

using format::FeatureBoundsRecord;

Vec3d lo(const FeatureBoundsRecord& r) { return {r.min[0], r.min[1], r.min[2]}; }
Vec3d hi(const FeatureBoundsRecord& r) { return {r.max[0], r.max[1], r.max[2]}; }

// Whether the segment a-b meets the box [lo, hi] (the slab test, in double).
bool segmentMeetsBox(const Vec3d& a, const Vec3d& b, const Vec3d& bl, const Vec3d& bh) {
    double t0 = 0, t1 = 1;
    const double from[3] = {a.x, a.y, a.z}, d[3] = {b.x - a.x, b.y - a.y, b.z - a.z};
    const double mn[3] = {bl.x, bl.y, bl.z}, mx[3] = {bh.x, bh.y, bh.z};
    for (int k = 0; k < 3; ++k) {
        if (d[k] == 0) {
            if (from[k] < mn[k] || from[k] > mx[k]) return false;
            continue;
        }
        double ta = (mn[k] - from[k]) / d[k], tb = (mx[k] - from[k]) / d[k];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
        if (t0 > t1) return false;
    }
    return true;
}

// A colour ramp over [0, 1] (dark blue, teal, yellow), linear rgb.
std::array<float, 3> ramp(double t) {
    static constexpr std::array<std::array<float, 3>, 3> stops{{{0.02F, 0.05F, 0.35F}, {0.0F, 0.45F, 0.4F}, {1.0F, 0.85F, 0.05F}}};
    t = std::clamp(t, 0.0, 1.0) * 2;
    const size_t i = std::min<size_t>(1, static_cast<size_t>(t));
    const double f = t - static_cast<double>(i);
    std::array<float, 3> c{};
    for (int k = 0; k < 3; ++k)
        c[static_cast<size_t>(k)] = static_cast<float>(stops[i][static_cast<size_t>(k)] * (1 - f) +
                                                        stops[i + 1][static_cast<size_t>(k)] * f);
    return c;
}

// Whether a box counts as near the viewer (papers/003 eqs. 3.16-3.17).
bool nearViewer(const Vec3d& bl, const Vec3d& bh, const Viewer& viewer, const Vec3d& up) {
    if (!(viewer.near_radius_m > 0)) return false;
    Vec3d to_centre = 0.5 * (bl + bh) - viewer.position;
    if (viewer.near_test == NearTest::Cylinder) to_centre = to_centre - dot(to_centre, up) * up;
    if (!(length(to_centre) < viewer.near_radius_m)) return false;
    if (viewer.near_test != NearTest::ViewerHeight) return true;
    // The box crosses the plane through the viewer normal to up: its corners'
    // heights above that plane do not all have one sign.
    double lowest = 1e300, highest = -1e300;
    for (int c = 0; c < 8; ++c) {
        const Vec3d corner{(c & 1) ? bh.x : bl.x, (c & 2) ? bh.y : bl.y, (c & 4) ? bh.z : bl.z};
        const double h = dot(corner - viewer.position, up);
        lowest = std::min(lowest, h);
        highest = std::max(highest, h);
    }
    return lowest <= 0 && highest >= 0;
}

}  // namespace

std::vector<uint32_t> occludersOf(const std::vector<FeatureBoundsRecord>& bounds, uint32_t poi, const Viewer& viewer) {
    const Vec3d& camera = viewer.position;
    const double up_length = length(viewer.up);
    const Vec3d up = up_length > 0 ? (1 / up_length) * viewer.up : Vec3d{0, 0, 1};
    std::vector<uint32_t> out;
    if (poi >= bounds.size() || !(bounds[poi].flags & FeatureBoundsRecord::kHasGeometry)) return out;
    const Vec3d pl = lo(bounds[poi]), ph = hi(bounds[poi]);
    // A 3 x 3 x 3 grid over the POI's box, pulled in by a hair so the points
    // lie inside it (a segment ending on the POI's face would graze its neighbour's).
    std::vector<Vec3d> targets;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k) {
                const double f[3] = {0.02 + 0.48 * i, 0.02 + 0.48 * j, 0.02 + 0.48 * k};
                targets.push_back({pl.x + f[0] * (ph.x - pl.x), pl.y + f[1] * (ph.y - pl.y), pl.z + f[2] * (ph.z - pl.z)});
            }
    for (uint32_t f = 0; f < bounds.size(); ++f) {
        if (f == poi || !(bounds[f].flags & FeatureBoundsRecord::kHasGeometry)) continue;
        const Vec3d bl = lo(bounds[f]), bh = hi(bounds[f]);
        bool occludes = nearViewer(bl, bh, viewer, up);
        for (size_t t = 0; t < targets.size() && !occludes; ++t) occludes = segmentMeetsBox(camera, targets[t], bl, bh);
        if (occludes) out.push_back(f);
    }
    return out;
}

LensStyle lensStyle(const LensParams& params, const std::vector<FeatureBoundsRecord>& bounds, const Vec3d& camera,
                    const Vec3d& up) {
    LensStyle s;
    s.flatten = params.flatten;
    s.xray_falloff = params.xray_falloff;
    s.lens = params.shape;
    s.lens_centre = params.centre;
    s.lens_radius_m = params.radius_m;
    const size_t n = bounds.size();
    const bool poi_ok = params.poi >= 0 && static_cast<size_t>(params.poi) < n;
    if (poi_ok && (params.solo || params.occlusion != LensParams::Occlusion::None)) {
        s.style.assign(n, LensStyle::kNormal);
        if (params.solo) {
            std::fill(s.style.begin(), s.style.end(), LensStyle::kDiscard);
            s.style[static_cast<size_t>(params.poi)] = LensStyle::kNormal;
        } else {
            const uint8_t how = params.occlusion == LensParams::Occlusion::Discard ? LensStyle::kDiscard
                                : params.occlusion == LensParams::Occlusion::XRay  ? LensStyle::kXRay
                                                                                   : LensStyle::kFlatten;
            const Viewer viewer{camera, up, params.sphere_radius_m, params.near_test};
            for (const uint32_t f : occludersOf(bounds, static_cast<uint32_t>(params.poi), viewer))
                s.style[f] = how;
        }
        if (params.occlusion == LensParams::Occlusion::Flatten) {
            s.base_z.resize(n);
            for (size_t f = 0; f < n; ++f) s.base_z[f] = bounds[f].base_z;
        }
    }
    if (!params.colour_by.empty() || !params.highlight.empty()) {
        s.tint.assign(n, {0, 0, 0, 0});
        if (params.colour_by == "height") {
            double top = 0;
            for (const FeatureBoundsRecord& r : bounds)
                if (r.flags & FeatureBoundsRecord::kHasGeometry) top = std::max(top, static_cast<double>(r.max[2] - r.base_z));
            for (size_t f = 0; f < n; ++f) {
                if (!(bounds[f].flags & FeatureBoundsRecord::kHasGeometry) || top <= 0) continue;
                const auto c = ramp((bounds[f].max[2] - bounds[f].base_z) / top);
                s.tint[f] = {c[0], c[1], c[2], 0.85F};
            }
        }
        for (const uint32_t f : params.highlight)
            if (f < n) s.tint[f] = {params.highlight_colour[0], params.highlight_colour[1], params.highlight_colour[2], 0.7F};
    }
    return s;
}

}  // namespace cityatlas::render
