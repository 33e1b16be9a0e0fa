// SPDX-License-Identifier: GPL-3.0-or-later
// The ray caster (atlas/raycast.h) against an independent oracle, CGAL's
// AABB tree with exact-predicate double arithmetic, on a synthetic town; ties
// and degenerate input; and answers that do not depend on Embree's threads.
#include "atlas/raycast.h"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "ingest/synth/town.h"

namespace cityatlas::atlas {
namespace {

using K = CGAL::Simple_cartesian<double>;
using CgalTriangle = K::Triangle_3;
using Iterator = std::vector<CgalTriangle>::const_iterator;
using Primitive = CGAL::AABB_triangle_primitive<K, Iterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, Primitive>>;

std::vector<std::array<Vec3d, 3>> townTriangles(uint32_t buildings, uint64_t seed) {
    synth::TownSettings s;
    s.buildings = buildings;
    s.seed = seed;
    s.texture_size_px = 16;
    const Scene scene = synth::townToScene(synth::generateTown(s), "/nonexistent");
    std::vector<std::array<Vec3d, 3>> out;
    for (const Triangle& t : scene.triangles) out.push_back(t.position_local);
    return out;
}

K::Point_3 point(const Vec3d& v) { return {v.x, v.y, v.z}; }

// Distance from p to the triangle's boundary, in the triangle's plane (p on it).
double toBoundary(const std::array<Vec3d, 3>& t, const Vec3d& p) {
    double d = 1e300;
    for (int k = 0; k < 3; ++k) {
        const Vec3d a = t[static_cast<size_t>(k)], b = t[static_cast<size_t>((k + 1) % 3)];
        const Vec3d ab = b - a;
        const double s = std::clamp(dot(p - a, ab) / dot(ab, ab), 0.0, 1.0);
        d = std::min(d, length(p - (a + s * ab)));
    }
    return d;
}

TEST(RayCaster, AgreesWithCgalsAabbTreeOnATown) {
    const auto tris = townTriangles(60, 3);
    const auto caster = RayCaster::build(tris);
    ASSERT_EQ(caster->triangles(), tris.size());
    std::vector<CgalTriangle> cgal;
    Box3d box;
    for (const auto& t : tris) {
        cgal.emplace_back(point(t[0]), point(t[1]), point(t[2]));
        for (const Vec3d& p : t) box.extend(p);
    }
    Tree tree(cgal.begin(), cgal.end());
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(0, 1), sphere(-1, 1);
    int hits = 0, near_edges = 0, compared = 0;
    double worst_distance = 0;
    for (int i = 0; i < 20000; ++i) {
        const Vec3d o{box.min.x + u(rng) * (box.max.x - box.min.x), box.min.y + u(rng) * (box.max.y - box.min.y),
                      box.min.z + u(rng) * (box.max.z - box.min.z + 30)};
        Vec3d d{sphere(rng), sphere(rng), sphere(rng)};
        if (length(d) < 0.1) continue;
        d = (1.0 / length(d)) * d;
        const auto cg = tree.first_intersection(K::Ray_3(point(o), K::Vector_3(d.x, d.y, d.z)));
        const RayHit ours = caster->nearest(o, d);
        ++compared;
        const K::Point_3* q = cg ? boost::get<K::Point_3>(&cg->first) : nullptr;
        if (cg && !q) continue;  // a segment: the ray lies in a triangle's plane
        if (q) {
            const Vec3d hit{q->x(), q->y(), q->z()};
            const auto& t = tris[static_cast<size_t>(cg->second - cgal.begin())];
            // Within float precision of an edge (1 mm here: coordinates of a few hundred
            // metres round to 0.03 mm), the two may name either neighbour or, at a
            // silhouette, disagree on hit or miss.
            if (toBoundary(t, hit) < 1e-3) {
                ++near_edges;
                continue;
            }
            ASSERT_TRUE(ours.hit) << "ray " << i << ": CGAL hits triangle " << (cg->second - cgal.begin());
            ++hits;
            const double distance = length(hit - o);
            worst_distance = std::max(worst_distance, std::abs(ours.distance - distance));
            EXPECT_NEAR(ours.distance, distance, 1e-3) << "ray " << i;
            EXPECT_EQ(ours.triangle, static_cast<uint32_t>(cg->second - cgal.begin())) << "ray " << i;
            EXPECT_TRUE(caster->occluded(o, d)) << "ray " << i;
            EXPECT_FALSE(caster->occluded(o, d, 0, distance - 1e-2)) << "ray " << i << " stops short of the hit";
        } else {
            if (ours.hit && toBoundary(tris[ours.triangle], o + ours.distance * d) < 1e-3) {
                ++near_edges;  // grazing a silhouette edge
                continue;
            }
            EXPECT_FALSE(ours.hit) << "ray " << i << ": ours hits triangle " << ours.triangle << ", CGAL nothing";
            EXPECT_FALSE(caster->occluded(o, d)) << "ray " << i;
        }
    }
    std::printf("  %d rays: %d hits compared, worst distance difference %.2g m, %d within 1 mm of an edge\n", compared,
                hits, worst_distance, near_edges);
    EXPECT_GT(hits, 2000);
    EXPECT_LT(near_edges, compared / 100);
}

TEST(RayCaster, TiesNameTheLowestIndexAndDegenerateTrianglesAreLeftOut) {
    // Two coincident squares (four triangles, the same two twice) and a
    // degenerate triangle; a ray through their shared diagonal hits all four
    // at one distance.
    const std::vector<std::array<Vec3d, 3>> tris = {
        {{{0, 0, 0}, {0, 0, 0}, {1, 1, 0}}},                    // 0: zero area
        {{{-1, -1, 5}, {1, -1, 5}, {1, 1, 5}}},                 // 1
        {{{-1, -1, 5}, {1, 1, 5}, {-1, 1, 5}}},                 // 2
        {{{-1, -1, 5}, {1, -1, 5}, {1, 1, 5}}},                 // 3: 1 again
        {{{-1, -1, 5}, {1, 1, 5}, {-1, 1, 5}}},                 // 4: 2 again
        {{{0, 0, 1e308 * 10}, {1, 0, 0}, {0, 1, 0}}},           // 5: not finite
    };
    for (const int threads : {1, 2}) {
        const auto caster = RayCaster::build(tris, threads);
        EXPECT_EQ(caster->triangles(), 4u);
        const RayHit diagonal = caster->nearest({0.25, 0.25, 0}, {0, 0, 1});
        ASSERT_TRUE(diagonal.hit);
        EXPECT_DOUBLE_EQ(diagonal.distance, 5);
        EXPECT_EQ(diagonal.triangle, 1u);  // lowest of 1 and 3 (the point is in triangle 1's half)
        const RayHit edge = caster->nearest({0.5, 0.5, 0}, {0, 0, 1});  // on the shared diagonal: 1, 2, 3, 4
        ASSERT_TRUE(edge.hit);
        EXPECT_EQ(edge.triangle, 1u);
        const RayHit other = caster->nearest({-0.5, 0.5, 0}, {0, 0, 1});
        ASSERT_TRUE(other.hit);
        EXPECT_EQ(other.triangle, 2u);
        EXPECT_FALSE(caster->occluded({0.25, 0.25, 0}, {0, 0, 1}, 0, 4.99));
        EXPECT_FALSE(caster->occluded({0.25, 0.25, 0}, {0, 0, -1}));
        EXPECT_FALSE(caster->occluded({0.25, 0.25, 0}, {0, 0, 0}));  // no direction: nothing
    }
    EXPECT_FALSE(RayCaster::build({})->occluded({0, 0, 0}, {0, 0, 1}));

    // Many coincident copies, after other triangles: whichever Embree's tree
    // meets first, the lowest index of the copies is named.
    std::vector<std::array<Vec3d, 3>> stack;
    for (int k = 0; k < 200; ++k) {
        const double x = 10.0 * (k % 20);
        stack.push_back({{{x, 0, 1}, {x + 1, 0, 1}, {x, 1, 1}}});
    }
    for (int k = 0; k < 64; ++k) stack.push_back({{{-1, -1, 5}, {1, -1, 5}, {1, 1, 5}}});
    for (const int threads : {1, 2}) {
        const auto caster = RayCaster::build(stack, threads);
        for (const double x : {0.1, 0.3, 0.5, 0.7, 0.9}) {
            const RayHit h = caster->nearest({x, -0.5, 10}, {0, 0, -1});
            ASSERT_TRUE(h.hit);
            EXPECT_EQ(h.triangle, 200u) << "x " << x;
        }
    }
}

TEST(RayCaster, AnswersDoNotDependOnEmbreesThreads) {
    const auto tris = townTriangles(120, 5);
    const auto one = RayCaster::build(tris, 1), two = RayCaster::build(tris, 2);
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(-300, 300), z(0, 60), sphere(-1, 1);
    int hits = 0;
    for (int i = 0; i < 20000; ++i) {
        const Vec3d o{u(rng), u(rng), z(rng)}, d{sphere(rng), sphere(rng), sphere(rng)};
        const RayHit a = one->nearest(o, d), b = two->nearest(o, d);
        ASSERT_EQ(a.hit, b.hit) << i;
        if (!a.hit) continue;
        ++hits;
        ASSERT_EQ(a.distance, b.distance) << i;
        ASSERT_EQ(a.triangle, b.triangle) << i;
        ASSERT_EQ(one->occluded(o, d), two->occluded(o, d)) << i;
    }
    EXPECT_GT(hits, 1000);
}

}  // namespace
}  // namespace cityatlas::atlas
