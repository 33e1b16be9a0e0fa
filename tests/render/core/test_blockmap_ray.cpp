// SPDX-License-Identifier: GPL-3.0-or-later
// The BlockMap traversal (render/core/blockmap_ray.h) against brute force:
// every ray against every occupied cell's prism with the slab test, and
// against each side's skirt below the base (sideSkirt) as a quad, in the
// local frame (../shared/SEED-FEATURES.md §1.3 item 7: 10^6 random rays), on
// random BlockMaps (tall and flat cells, floating cells with a base above
// the range's bottom, plates with base = top, empty stretches for space
// leaping); and with space leaping off, the same answers.
#include "render/core/blockmap_ray.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace cityatlas::render {
namespace {

using format::BlockMap;

BlockMap randomBlockMap(std::mt19937_64& rng, int nx, int ny, double occupied_share) {
    std::uniform_real_distribution<double> u(0, 1);
    BlockMap bm;
    bm.nx = nx, bm.ny = ny;
    bm.cell_m = 0.5 + 4 * u(rng);
    bm.origin = {std::floor(-5000 * u(rng)) * bm.cell_m, std::floor(3000 * u(rng)) * bm.cell_m, -20 + 40 * u(rng)};
    bm.z_hi = bm.origin.z + 5 + 100 * u(rng);
    bm.cells.resize(static_cast<size_t>(nx) * static_cast<size_t>(ny));
    // Occupied cells in clumps (blocks of buildings) so that empty stretches are wide.
    for (int y = 0; y < ny; ++y)
        for (int x = 0; x < nx; ++x) {
            const bool clump = ((x / 6 + y / 5) % 3 == 0);
            if (u(rng) > (clump ? occupied_share * 2 : occupied_share / 4)) continue;
            format::BlockMapCell& c = bm.cells[bm.index(x, y)];
            c.feature = static_cast<uint32_t>(bm.index(x, y));
            c.top = static_cast<uint16_t>(1 + u(rng) * 65534);
            const double r = u(rng);
            c.base = r < 0.6 ? 0 : r < 0.9 ? static_cast<uint16_t>(u(rng) * c.top) : c.top;  // grounded, floating, a plate
        }
    bm.dist.resize(bm.cells.size());
    for (int y = 0; y < ny; ++y)
        for (int x = 0; x < nx; ++x) {
            int d = 255;
            for (int oy = 0; oy < ny; ++oy)
                for (int ox = 0; ox < nx; ++ox)
                    if (bm.cells[bm.index(ox, oy)].occupied()) d = std::min(d, std::max(std::abs(ox - x), std::abs(oy - y)));
            bm.dist[bm.index(x, y)] = static_cast<uint8_t>(d);
        }
    return bm;
}

// Brute force: the nearest entry into any occupied cell's prism, local frame.
BlockMapHit bruteForce(const BlockMap& bm, const Vec3d& o, const Vec3d& d) {
    BlockMapHit best;
    best.t = std::numeric_limits<double>::infinity();
    for (int y = 0; y < bm.ny; ++y)
        for (int x = 0; x < bm.nx; ++x) {
            const format::BlockMapCell& c = bm.cells[bm.index(x, y)];
            if (!c.occupied()) continue;
            const double lo[3] = {bm.origin.x + x * bm.cell_m, bm.origin.y + y * bm.cell_m, bm.height(c.base)};
            const double hi[3] = {lo[0] + bm.cell_m, lo[1] + bm.cell_m, bm.height(c.top)};
            const double oo[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
            double t0 = -std::numeric_limits<double>::infinity(), t1 = std::numeric_limits<double>::infinity();
            int axis = -1;
            bool miss = false;
            for (int a = 0; a < 3 && !miss; ++a) {
                if (dd[a] == 0) {
                    miss = oo[a] < lo[a] || oo[a] > hi[a];
                    continue;
                }
                const double ta = (lo[a] - oo[a]) / dd[a], tb = (hi[a] - oo[a]) / dd[a];
                if (std::min(ta, tb) > t0) t0 = std::min(ta, tb), axis = a;
                t1 = std::min(t1, std::max(ta, tb));
            }
            if (!(miss || t0 > t1 || t0 < 0 || t0 >= best.t)) {
                best.hit = true, best.t = t0, best.x = x, best.y = y;
                if (axis == 0) best.face = d.x > 0 ? format::kMinusX : format::kPlusX;
                else if (axis == 1) best.face = d.y > 0 ? format::kMinusY : format::kPlusY;
                else best.face = d.z < 0 ? kBlockMapRoof : kBlockMapUnderside;
            }
            // The skirts: each side's quad continued below the base by what a
            // descending ray falls over half a cell of horizontal travel,
            // entered from outside the cell, never below the grid's box.
            const double horizontal = std::hypot(d.x, d.y);
            if (!(d.z < 0) || horizontal == 0) continue;
            const double skirt = 0.5 * bm.cell_m * -d.z / horizontal;
            for (int a = 0; a < 2; ++a) {
                if (dd[a] == 0) continue;
                const double plane = dd[a] > 0 ? lo[a] : hi[a];  // the side the ray enters through
                const double t = (plane - oo[a]) / dd[a];
                if (t < 0 || t >= best.t) continue;
                const int b = 1 - a;
                const double pb = oo[b] + t * dd[b], pz = o.z + t * d.z;
                if (pb < lo[b] || pb > hi[b] || pz < std::max(lo[2] - skirt, bm.origin.z) || pz >= lo[2]) continue;
                best.hit = true, best.t = t, best.x = x, best.y = y;
                best.face = a == 0 ? (d.x > 0 ? format::kMinusX : format::kPlusX) : (d.y > 0 ? format::kMinusY : format::kPlusY);
            }
        }
    return best;
}

TEST(BlockMapRay, EqualsBruteForceOnAMillionRandomRays) {
    std::mt19937_64 rng(20);
    std::uniform_real_distribution<double> u(0, 1);
    size_t rays = 0, hits = 0, leaps = 0, mismatched = 0;
    for (int map = 0; map < 10; ++map) {
        const BlockMap bm = randomBlockMap(rng, 20 + map * 3, 14 + map * 2, 0.25);
        const Vec3d lo = bm.origin, hi{bm.origin.x + bm.nx * bm.cell_m, bm.origin.y + bm.ny * bm.cell_m, bm.z_hi};
        const Vec3d centre = 0.5 * (lo + hi);
        const double radius = length(hi - lo);
        for (int i = 0; i < 100000; ++i, ++rays) {
            // From a sphere around the box (above the ground mostly: cameras look down at cities)
            // towards a point in the box, or sometimes any direction.
            const double az = 2 * M_PI * u(rng), el = std::asin(2 * u(rng) - 1) * (u(rng) < 0.8 ? 0.5 : 1) + (u(rng) < 0.8 ? 0.6 : 0);
            const Vec3d o = centre + radius * Vec3d{std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)};
            const Vec3d target{lo.x + (hi.x - lo.x) * u(rng), lo.y + (hi.y - lo.y) * u(rng), lo.z + (hi.z - lo.z) * u(rng)};
            const Vec3d d = target - o;
            const BlockMapHit a = castBlockMapRay(bm, o, d);
            const BlockMapHit b = bruteForce(bm, o, d);
            const BlockMapHit walk = castBlockMapRay(bm, o, d, false);
            hits += b.hit;
            leaps += walk.steps > a.steps;
            const bool same = a.hit == b.hit && (!a.hit || (a.x == b.x && a.y == b.y && a.face == b.face &&
                                                            std::abs(a.t - b.t) <= 1e-9 * (1 + b.t)));
            const bool same_walk = walk.hit == a.hit && walk.x == a.x && walk.y == a.y && walk.face == a.face &&
                                   std::abs(walk.t - a.t) <= 1e-9 * (1 + a.t);
            if ((!same || !same_walk) && mismatched < 5)
                ADD_FAILURE() << "map " << map << " ray " << i << ": DDA " << a.hit << " (" << a.x << "," << a.y << ") face "
                              << a.face << " t " << a.t << "; brute force " << b.hit << " (" << b.x << "," << b.y << ") face "
                              << b.face << " t " << b.t << "; without leaps " << walk.hit << " (" << walk.x << "," << walk.y
                              << ") face " << walk.face;
            mismatched += !same || !same_walk;
        }
    }
    EXPECT_EQ(mismatched, 0u) << "of " << rays << " rays";
    EXPECT_GT(hits, rays / 4) << "most rays should meet a prism";
    EXPECT_GT(leaps, rays / 10) << "space leaping saves steps";
}

TEST(BlockMapRay, AxisAlignedRaysAndAnEmptyMap) {
    std::mt19937_64 rng(3);
    BlockMap bm = randomBlockMap(rng, 9, 7, 0.4);
    const double s = bm.cell_m;
    // Straight down through each cell centre: the roof at the top, or nothing.
    for (int y = 0; y < bm.ny; ++y)
        for (int x = 0; x < bm.nx; ++x) {
            const Vec3d o{bm.origin.x + (x + 0.5) * s, bm.origin.y + (y + 0.5) * s, bm.z_hi + 10};
            const BlockMapHit h = castBlockMapRay(bm, o, {0, 0, -1});
            const format::BlockMapCell& c = bm.cells[bm.index(x, y)];
            ASSERT_EQ(h.hit, c.occupied()) << x << "," << y;
            if (!h.hit) continue;
            EXPECT_EQ(h.x, x);
            EXPECT_EQ(h.y, y);
            EXPECT_EQ(h.face, kBlockMapRoof);
            EXPECT_NEAR(h.t, bm.z_hi + 10 - bm.height(c.top), 1e-9);
        }
    // Level rays along +x at each row's mid-height of the range.
    for (int y = 0; y < bm.ny; ++y) {
        const Vec3d o{bm.origin.x - 3 * s, bm.origin.y + (y + 0.5) * s, bm.origin.z + 0.5 * (bm.z_hi - bm.origin.z)};
        EXPECT_EQ(castBlockMapRay(bm, o, {1, 0, 0}).hit, bruteForce(bm, o, {1, 0, 0}).hit) << y;
    }
    for (auto& c : bm.cells) c = format::BlockMapCell{};
    for (auto& d : bm.dist) d = 255;
    EXPECT_FALSE(castBlockMapRay(bm, bm.origin - Vec3d{10, 10, -5}, {1, 1, 0}).hit);
    EXPECT_FALSE(castBlockMapRay(BlockMap{}, {0, 0, 0}, {1, 0, 0}).hit);
}

TEST(BlockMapRay, NonFiniteRaysAndDegenerateGridsMiss) {
    // fuzz_blockmap's regress-nan-ray: a cell size that made grid coordinates NaN (an int conversion of NaN).
    std::mt19937_64 rng(9);
    BlockMap bm = randomBlockMap(rng, 6, 5, 0.5);
    const double inf = std::numeric_limits<double>::infinity();
    EXPECT_FALSE(castBlockMapRay(bm, {std::nan(""), 0, 0}, {1, 0, 0}).hit);
    EXPECT_FALSE(castBlockMapRay(bm, {0, 0, 0}, {inf, 1, 0}).hit);
    bm.cell_m = 1e-300;
    EXPECT_FALSE(castBlockMapRay(bm, {-5, -5, 50}, {1, 1, -1}).hit);
    bm.cell_m = 1e300;
    (void)castBlockMapRay(bm, {-5, -5, 50}, {1, 1, -1});  // any answer, no undefined behaviour (UBSan in fuzz builds)
}

}  // namespace
}  // namespace cityatlas::render
