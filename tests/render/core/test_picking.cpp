// SPDX-License-Identifier: GPL-3.0-or-later
// Picking: the ray through a pixel, and the nearest building it hits among
// the drawn nodes' meshes, also with node centres at ECEF magnitudes.
#include <gtest/gtest.h>

#include <cmath>

#include "render/core/picking.h"

namespace cityatlas::render {
namespace {

// A wall 2 * `half` wide and 10 m high facing -y at y = `y` (relative to the centre), feature `f`.
MeshData wall(double y, uint32_t f, float half) {
    MeshData m;
    const float fy = static_cast<float>(y);
    m.positions = {-half, fy, 0, half, fy, 0, half, fy, 10, -half, fy, 10};
    m.feature_id = {f, f, f, f};
    m.indices = {0, 1, 2, 0, 2, 3};
    return m;
}

Camera looking(const Vec3d& position) {
    Camera c;
    c.position = position;
    c.direction = {0, 1, 0};
    c.up = {0, 0, 1};
    c.vertical_fov_deg = 60;
    c.width_px = 400;
    c.height_px = 200;
    return c;
}

TEST(Picking, PixelRaysFollowTheFrustum) {
    const Camera c = looking({0, 0, 0});
    const Vec3d centre = pixelRay(c, 200, 100);
    EXPECT_NEAR(centre.y, 1.0, 1e-12);
    // The top edge's middle is half the vertical fov above the axis.
    const Vec3d top = pixelRay(c, 200, 0);
    EXPECT_NEAR(std::atan2(top.z, top.y) * 180 / M_PI, 30.0, 1e-9);
    // The right edge: tan = tan(30 deg) * aspect.
    const Vec3d right = pixelRay(c, 400, 100);
    EXPECT_NEAR(right.x / right.y, std::tan(M_PI / 6) * 2.0, 1e-9);
}

TEST(Picking, NearestBuildingWinsAtAnyMagnitude) {
    for (const Vec3d& origin : {Vec3d{0, 0, 0}, Vec3d{3783265.18, 901649.80, 5038246.08}}) {
        const MeshData near_wall = wall(20, 7, 5), far_wall = wall(50, 9, 20);
        const Camera c = looking(origin + Vec3d{0, -10, 5});
        const std::vector<PickMesh> meshes = {{2, &far_wall, origin}, {1, &near_wall, origin}};
        PickHit hit = pickRay(c.position, pixelRay(c, 200, 100), meshes);
        ASSERT_TRUE(hit.hit);
        EXPECT_EQ(hit.feature, 7u);
        EXPECT_EQ(hit.node, 1);
        EXPECT_NEAR(hit.distance_m, 30.0, 1e-6);
        // Past the near wall's edge (x = 7 > 5 at 30 m) only the wider far wall (x = 14 <= 20 at 60 m) is hit.
        const double px = 200 + 200 * (7.0 / 30.0) / (std::tan(M_PI / 6) * 2.0);
        hit = pickRay(c.position, pixelRay(c, px, 100), meshes);
        ASSERT_TRUE(hit.hit);
        EXPECT_EQ(hit.feature, 9u);
        // Looking away: nothing.
        Camera back = c;
        back.direction = {0, -1, 0};
        EXPECT_FALSE(pickRay(back.position, pixelRay(back, 200, 100), meshes).hit);
    }
}

// A BlockMap drawn in the frame is picked as its shader draws it (the
// traversal of render/core/blockmap_ray.h): a 3 x 3 grid of 2 m cells at
// (10, 20), one building of scene id 77 in the middle cell, 6 m high. A ray
// straight down through the cell's centre hits its roof 44 m below the eye;
// a triangle nearer on the same ray wins; a ray beside the building misses.
TEST(Picking, BlockMapPixelsNameTheirBuilding) {
    format::BlockMap bm;
    bm.nx = bm.ny = 3;
    bm.cell_m = 2;
    bm.origin = {10, 20, 0};
    bm.z_hi = 6;
    bm.cells.resize(9);
    bm.cells[bm.index(1, 1)] = {65535, 0, 0, format::kBlockMapNone};
    bm.features = {77};
    bm.dist = format::chebyshevDistances(bm);
    const std::vector<PickBlockMap> blockmaps{{3, &bm}};
    PickHit h = pickRay({13, 23, 50}, {0, 0, -1}, {}, blockmaps);
    ASSERT_TRUE(h.hit);
    EXPECT_EQ(h.feature, 77u);
    EXPECT_EQ(h.node, 3);
    EXPECT_NEAR(h.distance_m, 44.0, 1e-9);
    EXPECT_NEAR(h.point.z, 6.0, 1e-9);
    // A wall: from the side at 3 m height, the prism's west face at x = 12.
    h = pickRay({0, 23, 3}, {1, 0, 0}, {}, blockmaps);
    ASSERT_TRUE(h.hit);
    EXPECT_NEAR(h.distance_m, 12.0, 1e-9);
    EXPECT_FALSE(pickRay({11, 21, 50}, {0, 0, -1}, {}, blockmaps).hit);
    // A triangle at z = 8 over the building, nearer: it wins.
    MeshData m;
    m.positions = {-10, -10, 0, 10, -10, 0, 0, 10, 0};
    m.indices = {0, 1, 2};
    m.feature_id = {5, 5, 5};
    const std::vector<PickMesh> meshes{{1, &m, {13, 23, 8}}};
    h = pickRay({13, 23, 50}, {0, 0, -1}, meshes, blockmaps);
    ASSERT_TRUE(h.hit);
    EXPECT_EQ(h.feature, 5u);
    EXPECT_NEAR(h.distance_m, 42.0, 1e-9);
}

}  // namespace
}  // namespace cityatlas::render
