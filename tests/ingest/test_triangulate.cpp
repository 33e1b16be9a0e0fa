// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/triangulate.h"

#include <gtest/gtest.h>

#include <cmath>

namespace cityatlas {
namespace {

double triangulatedArea(const std::vector<Vec3d>& all, const PolygonTriangulation& t) {
    double a = 0;
    for (const auto& tri : t.triangles) a += triangleArea({all[tri[0]], all[tri[1]], all[tri[2]]});
    return a;
}

Vec3d triangleNormal(const std::vector<Vec3d>& all, const std::array<uint32_t, 3>& tri) {
    return cross(all[tri[1]] - all[tri[0]], all[tri[2]] - all[tri[0]]);
}

TEST(Triangulate, SquareWithHoleGivesEightTrianglesAndExactArea) {
    // 10x10 square with a 3x3 hole, lying in a tilted plane far from the origin.
    auto place = [](double u, double v) { return Vec3d{1e6 + u * 0.6, 5e6 + v, 300 + u * 0.8}; };
    std::vector<Vec3d> outer{place(0, 0), place(10, 0), place(10, 10), place(0, 10)};
    std::vector<Vec3d> hole{place(4, 4), place(4, 7), place(7, 7), place(7, 4)};
    PolygonRings rings{{outer, hole}, {}};
    const PolygonTriangulation t = triangulatePolygon(rings);
    ASSERT_FALSE(t.degenerate);
    EXPECT_EQ(t.triangles.size(), 8u + 2u * 1u - 2u);  // V + 2H - 2 with V = 8
    std::vector<Vec3d> all = outer;
    all.insert(all.end(), hole.begin(), hole.end());
    // Closed form: 100 - 9 (the plane's metric is exact: u maps with unit length).
    EXPECT_NEAR(triangulatedArea(all, t), 91.0, 1e-6);
    EXPECT_NEAR(polygonArea(rings), 91.0, 1e-6);
    EXPECT_LT(t.max_plane_deviation_m, 1e-6);
}

TEST(Triangulate, OutputFacesTheWayTheExteriorRingDoes) {
    std::vector<Vec3d> ccw{{0, 0, 0}, {4, 0, 0}, {4, 3, 0}, {2, 5, 0}, {0, 3, 0}};
    for (bool flip : {false, true}) {
        std::vector<Vec3d> ring = ccw;
        if (flip) std::reverse(ring.begin(), ring.end());
        const PolygonTriangulation t = triangulatePolygon(PolygonRings{{ring}, {}});
        ASSERT_EQ(t.triangles.size(), 3u);
        for (const auto& tri : t.triangles) {
            const double z = triangleNormal(ring, tri).z;
            EXPECT_TRUE(flip ? z < 0 : z > 0) << "triangle faces the wrong way (flip=" << flip << ")";
        }
        EXPECT_NEAR(t.unit_normal.z, flip ? -1.0 : 1.0, 1e-12);
    }
}

TEST(Triangulate, ConcaveUShapeStaysInsideThePolygon) {
    // U shape: a triangulation that ignored the constraint would cover the notch.
    std::vector<Vec3d> u{{0, 0, 0}, {9, 0, 0}, {9, 6, 0}, {6, 6, 0}, {6, 2, 0}, {3, 2, 0}, {3, 6, 0}, {0, 6, 0}};
    const PolygonTriangulation t = triangulatePolygon(PolygonRings{{u}, {}});
    EXPECT_EQ(t.triangles.size(), 6u);
    EXPECT_NEAR(triangulatedArea(u, t), 9 * 6 - 3 * 4, 1e-9);
}

TEST(Triangulate, ReportsHowFarANonPlanarRingIsFromItsPlane) {
    std::vector<Vec3d> warped{{0, 0, 0}, {10, 0, 0}, {10, 10, 0.2}, {0, 10, 0}};
    const PolygonTriangulation t = triangulatePolygon(PolygonRings{{warped}, {}});
    EXPECT_EQ(t.triangles.size(), 2u);
    EXPECT_GT(t.max_plane_deviation_m, 0.04);  // 0.2 m lifted corner: 0.05 from the best-fit plane through the centroid
    EXPECT_LT(t.max_plane_deviation_m, 0.2);
}

TEST(Triangulate, CollinearAndTinyRingsAreDegenerateNotACrash) {
    std::vector<Vec3d> line{{0, 0, 0}, {1, 1, 1}, {2, 2, 2}};
    EXPECT_TRUE(triangulatePolygon(PolygonRings{{line}, {}}).degenerate);
    std::vector<Vec3d> two{{0, 0, 0}, {1, 0, 0}};
    EXPECT_TRUE(triangulatePolygon(PolygonRings{{two}, {}}).degenerate);
    EXPECT_TRUE(triangulatePolygon(PolygonRings{{}, {}}).degenerate);
    std::vector<Vec3d> nan{{0, 0, 0}, {1, 0, 0}, {0, std::nan(""), 0}};
    EXPECT_TRUE(triangulatePolygon(PolygonRings{{nan}, {}}).degenerate);
}

TEST(Triangulate, RepeatedPointsKeepTheFirstIndex) {
    // The closing point repeated (as GML writes rings) must not add a triangle.
    std::vector<Vec3d> closed{{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {0, 2, 0}, {0, 0, 0}};
    const PolygonTriangulation t = triangulatePolygon(PolygonRings{{closed}, {}});
    EXPECT_EQ(t.triangles.size(), 2u);
    for (const auto& tri : t.triangles)
        for (uint32_t i : tri) EXPECT_LT(i, 4u);
    EXPECT_NEAR(triangulatedArea(closed, t), 4.0, 1e-12);
}

TEST(Triangulate, NewellAreaIsIndependentOfPlacement) {
    // The same 3x4 rectangle near the origin and at UTM-like magnitudes.
    for (double offset : {0.0, 5.0e5, 9.9e6}) {
        std::vector<Vec3d> r{{offset, offset, 0}, {offset + 3, offset, 0}, {offset + 3, offset, 4}, {offset, offset, 4}};
        EXPECT_DOUBLE_EQ(polygonArea(PolygonRings{{r}, {}}), 12.0) << "offset " << offset;
    }
}

TEST(Triangulate, BowTieGetsAnAddedCrossingPointWithInterpolatedUv) {
    // Edges 1-2 (y = 3 - 3x/4) and 3-0 (y = 4x) cross at (12/19, 48/19). The
    // lobes differ in size (a symmetric bow-tie has zero net area and is
    // degenerate). uv = position / 4 is affine, so the added point must get
    // its position / 4.
    std::vector<Vec3d> bow{{0, 0, 0}, {4, 0, 0}, {0, 3, 0}, {1, 4, 0}};
    std::vector<Vec2d> uv;
    for (const Vec3d& p : bow) uv.push_back({p.x / 4, p.y / 4});
    PolygonRings rings{{bow}, {uv}};
    const PolygonTriangulation t = triangulatePolygon(rings);
    ASSERT_FALSE(t.degenerate);
    ASSERT_EQ(t.added_points.size(), 1u);
    EXPECT_NEAR(t.added_points[0].x, 12.0 / 19, 1e-9);
    EXPECT_NEAR(t.added_points[0].y, 48.0 / 19, 1e-9);
    EXPECT_NEAR(t.added_uv[0].x, 3.0 / 19, 1e-9);
    EXPECT_NEAR(t.added_uv[0].y, 12.0 / 19, 1e-9);
    for (const auto& tri : t.triangles)
        for (uint32_t i : tri) EXPECT_LT(i, 5u);
}

TEST(Triangulate, CountsAVertexThatTheRingVisitsTwice) {
    // Two squares touching at (2, 2): a self-touching ring (figure eight).
    std::vector<Vec3d> eight{{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {4, 2, 0}, {4, 4, 0}, {2, 4, 0}, {2, 2, 0}, {0, 2, 0}};
    const PolygonTriangulation t = triangulatePolygon(PolygonRings{{eight}, {}});
    EXPECT_EQ(t.repeated_vertices, 1u);
    double area = 0;
    for (const auto& tri : t.triangles) area += triangleArea({eight[tri[0]], eight[tri[1]], eight[tri[2]]});
    EXPECT_NEAR(area, 8.0, 1e-9);
}

}  // namespace
}  // namespace cityatlas
