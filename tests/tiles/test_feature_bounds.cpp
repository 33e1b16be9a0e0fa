// SPDX-License-Identifier: GPL-3.0-or-later
// The feature-bounds accumulator (tiles/feature_bounds.h) holds a feature's
// box and lowest corners already rounded to float: its records must be
// those of the box and heights kept in double and rounded once at the end
// (the reference below), in whatever order the triangles come.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <random>

#include <meshoptimizer.h>

#include "tiles/feature_bounds.h"

using namespace cityatlas;
using format::FeatureBoundsRecord;

namespace {

// The rule in double, rounded once: the box outwards, the base (lowest
// ground corner, else lowest corner) and the longest wall's azimuth to
// nearest; equal spans keep the smaller azimuth.
std::vector<FeatureBoundsRecord> reference(const std::vector<Triangle>& tris, size_t features) {
    struct Acc {
        Box3d box;
        double ground = INFINITY, span = -1, az = 0;
        bool textured = false;
    };
    std::vector<Acc> acc(features);
    for (const Triangle& t : tris) {
        Acc& a = acc[t.feature];
        const auto& p = t.position_local;
        for (const Vec3d& v : p) {
            a.box.extend(v);
            if (t.semantic == SurfaceSemantic::Ground) a.ground = std::min(a.ground, v.z);
        }
        a.textured |= t.texture >= 0;
        // Which triangle is a wall, its span and azimuth: tiles::wallSpan (the
        // rule itself is checked against the synthetic truth by cli.feature_bounds).
        const std::optional<tiles::WallSpan> w = tiles::wallSpan(t);
        if (w && (w->span_m > a.span || (w->span_m == a.span && w->azimuth_deg < a.az))) a.span = w->span_m, a.az = w->azimuth_deg;
    }
    std::vector<FeatureBoundsRecord> out(features);
    for (size_t f = 0; f < features; ++f) {
        const Acc& a = acc[f];
        FeatureBoundsRecord& r = out[f];
        if (a.box.empty()) continue;
        const double lo[3] = {a.box.min.x, a.box.min.y, a.box.min.z}, hi[3] = {a.box.max.x, a.box.max.y, a.box.max.z};
        for (int k = 0; k < 3; ++k) {
            r.min[k] = std::nextafter(static_cast<float>(lo[k]), -INFINITY);
            while (static_cast<double>(std::nextafter(r.min[k], INFINITY)) <= lo[k]) r.min[k] = std::nextafter(r.min[k], INFINITY);
            r.max[k] = std::nextafter(static_cast<float>(hi[k]), INFINITY);
            while (static_cast<double>(std::nextafter(r.max[k], -INFINITY)) >= hi[k]) r.max[k] = std::nextafter(r.max[k], -INFINITY);
        }
        r.base_z = static_cast<float>(a.ground < INFINITY ? a.ground : a.box.min.z);
        r.flags = FeatureBoundsRecord::kHasGeometry | (a.textured ? FeatureBoundsRecord::kTextured : 0);
        if (a.span >= 0) {
            r.flags |= FeatureBoundsRecord::kHasWall;
            const unsigned short h = meshopt_quantizeHalf(static_cast<float>(a.az));
            r.azimuth_half = h == meshopt_quantizeHalf(360.0F) ? 0 : h;
        }
    }
    return out;
}

std::vector<FeatureBoundsRecord> accumulated(const std::vector<Triangle>& tris, size_t features) {
    tiles::FeatureBoundsAccumulator acc;
    for (const Triangle& t : tris) acc.add(t);
    return acc.finish(features);
}

bool same(const std::vector<FeatureBoundsRecord>& a, const std::vector<FeatureBoundsRecord>& b, std::string* why) {
    if (a.size() != b.size()) return *why = "sizes differ", false;
    for (size_t f = 0; f < a.size(); ++f)
        if (std::memcmp(&a[f], &b[f], sizeof a[f]) != 0) {
            *why = "feature " + std::to_string(f) + ": min " + std::to_string(a[f].min[0]) + " " + std::to_string(b[f].min[0]) +
                   ", max " + std::to_string(a[f].max[2]) + " " + std::to_string(b[f].max[2]) + ", base " +
                   std::to_string(a[f].base_z) + " " + std::to_string(b[f].base_z) + ", azimuth " +
                   std::to_string(a[f].azimuth_half) + " " + std::to_string(b[f].azimuth_half);
            return false;
        }
    return true;
}

}  // namespace

TEST(FeatureBounds, RoundedAsTheyComeEqualsRoundedOnceInAnyOrder) {
    // Features 5 km from the origin, corners at random fractions of a
    // millimetre (float's step there is ~0.5 mm: nearly every corner
    // rounds), walls of equal spans in several directions (the azimuth
    // tie-break) or spans equal only in float, ground triangles on some, a
    // feature with no triangles.
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(0, 1);
    const size_t features = 200;
    std::vector<Triangle> tris;
    for (uint32_t f = 0; f < features; ++f) {
        if (f == 7) continue;
        const double x0 = 5000 + 40 * u(rng), y0 = -5000 + 40 * u(rng), z0 = 30 + 5 * u(rng), h = 3 + 20 * u(rng);
        const double len = 10 + std::floor(3 * u(rng));  // whole metres: spans tie between directions
        const int walls = 1 + static_cast<int>(4 * u(rng));
        for (int w = 0; w < walls; ++w) {
            const double a = (w * 90 + (f % 3 == 0 ? 0 : 37)) * std::numbers::pi / 180;
            // Some features' walls differ in span by less than float's step
            // at 10 m: which is longest is decided in double.
            const double l = len + (f % 3 == 2 ? w * 2e-7 : 0.0);
            const Vec3d p{x0 + 1e-4 * u(rng), y0 + 1e-4 * u(rng), z0}, d{l * std::cos(a), l * std::sin(a), 0};
            Triangle t;
            t.feature = f;
            t.semantic = f % 4 == 1 ? SurfaceSemantic::Unclassified : SurfaceSemantic::Wall;
            t.position_local = {p, p + d, p + d + Vec3d{0, 0, h}};
            t.texture = f % 5 == 0 ? 1 : -1;
            tris.push_back(t);
        }
        Triangle roof;
        roof.feature = f;
        roof.semantic = SurfaceSemantic::Roof;
        roof.position_local = {Vec3d{x0 + u(rng), y0 + u(rng), z0 + h + u(rng)}, Vec3d{x0 + 9 + u(rng), y0 + u(rng), z0 + h},
                               Vec3d{x0 + u(rng), y0 + 9 + u(rng), z0 + h + 2 * u(rng)}};
        tris.push_back(roof);
        if (f % 2 == 0) {
            Triangle ground = roof;
            ground.semantic = SurfaceSemantic::Ground;
            for (Vec3d& v : ground.position_local) v.z = z0 + 0.3 + 1e-3 * u(rng);
            tris.push_back(ground);
        }
    }
    const std::vector<FeatureBoundsRecord> truth = reference(tris, features);
    std::string why;
    EXPECT_TRUE(same(accumulated(tris, features), truth, &why)) << why;
    std::reverse(tris.begin(), tris.end());
    EXPECT_TRUE(same(accumulated(tris, features), truth, &why)) << "reversed: " << why;
    std::shuffle(tris.begin(), tris.end(), rng);
    EXPECT_TRUE(same(accumulated(tris, features), truth, &why)) << "shuffled: " << why;
    EXPECT_EQ(truth[7].flags, 0) << "a feature without triangles has an all-zero record";
}
