// SPDX-License-Identifier: GPL-3.0-or-later
// Visibility of a target (atlas/visibility.h; issue 19), against the exact
// truths of SEED-FEATURES §2.3:
// - T5: on the synthetic town, with the tallest rectangular building as the
//   target, every wall of a rectangular building whose plane has the
//   target's whole box strictly behind it sees the target not at all (0):
//   its rays enter their own building first;
// - T6: a target box, an observer wall facing it and a blocker wall
//   between: where the target's eight corners, projected from p onto the
//   blocker's plane, fall inside the blocker shrunk by a margin, 0; where
//   their projection misses the blocker entirely, 1;
// - the target's own surface sees itself.
#include "atlas/visibility.h"

#include <gtest/gtest.h>

#include <cmath>

#include "ingest/synth/town.h"
#include "tests/atlas/scenes.h"

namespace cityatlas::atlas {
namespace {

using Tris = test::Triangles;
using test::addBox;
using test::normalOf;

TEST(Visibility, T6ABlockerHidesExactlyWhatItsShadowCovers) {
    // Target T: a box north of the observer wall; blocker C: a wall at y = 25.
    const Vec3d t_lo{-5, 50, 0}, t_hi{5, 60, 20};
    Tris all, target;
    addBox(t_lo, t_hi, &target);
    all = target;
    const double cx0 = -10, cx1 = 10, cz0 = 0, cz1 = 15, cy = 25;
    all.push_back({Vec3d{cx0, cy, cz0}, Vec3d{cx1, cy, cz0}, Vec3d{cx1, cy, cz1}});
    all.push_back({Vec3d{cx0, cy, cz0}, Vec3d{cx1, cy, cz1}, Vec3d{cx0, cy, cz1}});
    const auto scene = RayCaster::build(all), only = RayCaster::build(target);
    VisibilityTarget vt;
    vt.scene = scene.get(), vt.target = only.get();
    vt.is_target.assign(all.size(), 0);
    std::fill(vt.is_target.begin(), vt.is_target.begin() + static_cast<long>(target.size()), 1);
    vt.box.extend(t_lo), vt.box.extend(t_hi);
    int hidden = 0, open = 0, between = 0;
    for (double x = -40; x <= 40; x += 2.5)
        for (double z = 0.5; z <= 40; z += 2.5) {
            const Vec3d p{x, 0, z};
            // The corners' projections from p (1 cm off the wall, where rays start) onto y = 25.
            const Vec3d o{x, 0.01, z};
            double lo_x = 1e300, hi_x = -1e300, lo_z = 1e300, hi_z = -1e300;
            for (int k = 0; k < 8; ++k) {
                const Vec3d c{(k & 1) ? t_hi.x : t_lo.x, (k & 2) ? t_hi.y : t_lo.y, (k & 4) ? t_hi.z : t_lo.z};
                const double s = (cy - o.y) / (c.y - o.y);
                const Vec3d q = o + s * (c - o);
                lo_x = std::min(lo_x, q.x), hi_x = std::max(hi_x, q.x), lo_z = std::min(lo_z, q.z), hi_z = std::max(hi_z, q.z);
            }
            const double margin = 0.05;
            const bool inside = lo_x > cx0 + margin && hi_x < cx1 - margin && lo_z > cz0 + margin && hi_z < cz1 - margin;
            const bool disjoint = hi_x < cx0 || lo_x > cx1 || hi_z < cz0 || lo_z > cz1;
            const double f = visibilityRatio(vt, p, {0, 1, 0});
            if (inside) {
                EXPECT_EQ(f, 0.0) << "hidden at x " << x << ", z " << z;
                ++hidden;
            } else if (disjoint) {
                EXPECT_EQ(f, 1.0) << "open at x " << x << ", z " << z;
                ++open;
            } else {
                ++between;  // partly hidden: a sliver narrower than the ray grid may still read 0
            }
        }
    std::printf("  %d hidden, %d open, %d partly hidden points\n", hidden, open, between);
    EXPECT_GT(hidden, 10);
    EXPECT_GT(open, 100);
    EXPECT_GT(between, 10);
    EXPECT_EQ(visibilityRatio(vt, {0, 0, 5}, {0, 1, 0}), 0.0);   // straight behind the blocker's middle
    // The target's own face sees the target (its rays hit it first).
    EXPECT_GT(visibilityRatio(vt, {0, 50, 10}, {0, -1, 0}), 0.0);
}

TEST(Visibility, T5WallsFacingAwayFromTheTargetSeeNothingOfIt) {
    for (uint64_t seed = 1; seed < 40; ++seed) {
        synth::TownSettings s;
        s.buildings = 60;
        s.seed = seed;
        s.texture_size_px = 16;
        const synth::Town town = synth::generateTown(s);
        const auto& b = town.buildings;
        size_t target = b.size();
        for (size_t i = 0; i < b.size(); ++i)
            if (b[i].shape == synth::FootprintShape::Rectangle &&
                (target == b.size() || b[i].base_height_m + b[i].ridge_height_m > b[target].base_height_m + b[target].ridge_height_m))
                target = i;
        if (target == b.size()) continue;
        const Scene scene = synth::townToScene(town, "/nonexistent");
        Tris all, mine;
        VisibilityTarget vt;
        for (const Triangle& t : scene.triangles) {
            all.push_back(t.position_local);
            vt.is_target.push_back(t.feature == target);
            if (t.feature == target) mine.push_back(t.position_local), vt.box.extend(t.position_local[0]),
                                     vt.box.extend(t.position_local[1]), vt.box.extend(t.position_local[2]);
        }
        const auto caster = RayCaster::build(all), only = RayCaster::build(mine);
        vt.scene = caster.get(), vt.target = only.get();
        int checked = 0;
        for (const Triangle& t : scene.triangles) {
            if (t.semantic != SurfaceSemantic::Wall || t.feature == target) continue;
            const synth::SynthBuilding& sb = b[t.feature];
            if (sb.shape != synth::FootprintShape::Rectangle || !sb.holes.empty()) continue;
            const Vec3d n = normalOf(t.position_local);
            bool behind = true;
            for (int k = 0; k < 8; ++k) {
                const Vec3d c{(k & 1) ? vt.box.max.x : vt.box.min.x, (k & 2) ? vt.box.max.y : vt.box.min.y,
                              (k & 4) ? vt.box.max.z : vt.box.min.z};
                behind = behind && dot(c - t.position_local[0], n) < 0;
            }
            if (!behind) continue;
            const auto& p = t.position_local;
            const Vec3d centre = (1.0 / 3.0) * (p[0] + p[1] + p[2]);
            EXPECT_EQ(visibilityRatio(vt, centre, n), 0.0) << "T5 on building " << t.feature;
            ++checked;
        }
        std::printf("  seed %llu: target building %zu, %d walls facing away\n", static_cast<unsigned long long>(seed),
                    target, checked);
        EXPECT_GT(checked, 50);
        return;
    }
    FAIL() << "no town with a rectangular building";
}

}  // namespace
}  // namespace cityatlas::atlas
