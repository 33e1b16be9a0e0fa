// SPDX-License-Identifier: GPL-3.0-or-later
// Split originals (tiles/texture_tiles.h): the grid, the crops and the cut of
// triangles at the core lines, checked against the whole texture: a piece
// samples from its tile exactly the texels the triangle samples there from
// the whole texture, the pieces cover the triangle, and a shared edge is cut
// at the same points from both sides. The seams on screen: GlTest.SplitOriginals...
#include "tiles/texture_tiles.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace cityatlas::tiles {
namespace {

TEST(TileGrid, CoresAndOverlapsClippedUnlessTheTextureWraps) {
    const TileGrid g = tileGridFor(1300, 1000, WrapMode::Clamp, 512, 16);
    EXPECT_EQ(g.columns(), 3);
    EXPECT_EQ(g.rows(), 2);
    EXPECT_EQ(g.count(), 6);
    EXPECT_EQ(g.coreOf(0), (TexelRect{0, 0, 512, 512}));
    EXPECT_EQ(g.coreOf(5), (TexelRect{1024, 512, 1300, 1000}));
    EXPECT_EQ(g.rectOf(0), (TexelRect{0, 0, 528, 528}));
    EXPECT_EQ(g.rectOf(4), (TexelRect{496, 496, 1040, 1000}));
    EXPECT_EQ(g.rectOf(5), (TexelRect{1008, 496, 1300, 1000}));
    const TileGrid w = tileGridFor(1300, 1000, WrapMode::Wrap, 512, 16);
    EXPECT_EQ(w.rectOf(0), (TexelRect{-16, -16, 528, 528}));
    EXPECT_EQ(w.rectOf(5), (TexelRect{1008, 496, 1316, 1016}));
    EXPECT_EQ(tileOverlap(0), 4);
    EXPECT_EQ(kDefaultTileOverlap, 16);
}

TEST(TileGrid, SplitsTexturesAboveTwoAtlasesOfTexels) {
    EXPECT_FALSE(splitsTexture(512, 512, 512));
    EXPECT_FALSE(splitsTexture(1024, 512, 512)) << "exactly two atlases";
    EXPECT_TRUE(splitsTexture(1024, 513, 512));
    EXPECT_TRUE(splitsTexture(4096, 4096, 2048));
    EXPECT_FALSE(splitsTexture(4096, 4096, 4096));
    EXPECT_FALSE(splitsTexture(100000, 1, 512)) << "texels, not sides";
}

TEST(TileGrid, TilesetEntriesAreTheWholeImageThenItsTiles) {
    // 1202 x 532 at 512: 3 x 2 tiles, clamped, cores of 512 (the last ones smaller), 16 texels of overlap.
    TextureRef ortho{"o.png", 1202, 532, 3, WrapMode::Clamp};
    const std::vector<TexelRect> e = tilesetEntries(ortho, 512, true);
    ASSERT_EQ(e.size(), 7u);
    EXPECT_EQ(e[0].width(), 1202);
    EXPECT_EQ(e[0].height(), 532);
    const int x0[3] = {0, 512 - 16, 1024 - 16}, x1[3] = {512 + 16, 1024 + 16, 1202};
    const int y0[2] = {0, 512 - 16}, y1[2] = {512 + 16, 532};
    for (int k = 0; k < 6; ++k) {
        const TexelRect& r = e[static_cast<size_t>(k + 1)];
        EXPECT_EQ(r.width(), x1[k % 3] - x0[k % 3]) << k;
        EXPECT_EQ(r.height(), y1[k / 3] - y0[k / 3]) << k;
    }
    EXPECT_EQ(tilesetEntries(ortho, 512, false).size(), 1u);  // split off: the whole image only
    EXPECT_EQ(tilesetEntries(TextureRef{"f.png", 1024, 512, 3, WrapMode::Wrap}, 512, true).size(), 1u);  // two atlases: whole
}

// Each texel holds its own coordinates: (x, y, x ^ y) modulo 256.
format::Image8 coordinates(int w, int h) {
    format::Image8 img{w, h, 3, std::vector<uint8_t>(static_cast<size_t>(w) * static_cast<size_t>(h) * 3)};
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            uint8_t* p = img.pixels.data() + (static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x)) * 3;
            p[0] = static_cast<uint8_t>(x), p[1] = static_cast<uint8_t>(y), p[2] = static_cast<uint8_t>(x ^ (y * 7));
        }
    return img;
}

std::array<uint8_t, 3> at(const format::Image8& img, int x, int y) {
    const uint8_t* p = img.pixels.data() + (static_cast<size_t>(y) * static_cast<size_t>(img.width) + static_cast<size_t>(x)) * 3;
    return {p[0], p[1], p[2]};
}

TEST(TileGrid, CropsWrapAroundOrClampAtTheBorder) {
    const format::Image8 img = coordinates(5, 4);
    const TexelRect r{-2, -1, 3, 2};
    const format::Image8 wrapped = cropTile(img, r, true), clamped = cropTile(img, r, false);
    ASSERT_EQ(wrapped.width, 5);
    ASSERT_EQ(wrapped.height, 3);
    EXPECT_EQ(at(wrapped, 0, 0), at(img, 3, 3));
    EXPECT_EQ(at(wrapped, 2, 1), at(img, 0, 0));
    EXPECT_EQ(at(clamped, 0, 0), at(img, 0, 0));
    EXPECT_EQ(at(clamped, 1, 2), at(img, 0, 1));
    EXPECT_EQ(at(clamped, 4, 2), at(img, 2, 1));
}

// Nearest texel of an image at texel-space point (s, t) (s right, t down), as
// GL_REPEAT or GL_CLAMP_TO_EDGE would pick it.
std::array<uint8_t, 3> nearest(const format::Image8& img, double s, double t, bool wraps) {
    auto index = [&](double c, int size) {
        const auto i = static_cast<int64_t>(std::floor(c));
        if (wraps) return static_cast<int>(((i % size) + size) % size);
        return static_cast<int>(std::clamp<int64_t>(i, 0, size - 1));
    };
    return at(img, index(s, img.width), index(t, img.height));
}

double area(const Vec3d& a, const Vec3d& b, const Vec3d& c) { return 0.5 * length(cross(b - a, c - a)); }

// Random triangles with uvs over several periods, on a 1300 x 1000 texture
// in 512 cores: the pieces cover the triangle (areas add up), each lies in
// its tile's core, and at random points of each piece the tile gives the
// texel the whole texture gives at the same point of the triangle.
TEST(ClipToTiles, PiecesSampleFromTheirTileWhatTheWholeTextureGives) {
    const format::Image8 image = coordinates(1300, 1000);
    std::mt19937_64 rng(17);
    // Centres over several periods, corners within 0.95 of them (less than two periods across).
    std::uniform_real_distribution<double> centre(-1.3, 2.4), spread(-0.95, 0.95), pos(-20, 20), bary(0, 1);
    for (const WrapMode wrap : {WrapMode::Wrap, WrapMode::Clamp}) {
        const TileGrid grid = tileGridFor(image.width, image.height, wrap, 512, 16);
        std::vector<format::Image8> tiles;
        for (int k = 0; k < grid.count(); ++k) tiles.push_back(cropTile(image, grid.rectOf(k), grid.wraps));
        int pieces_total = 0, samples = 0;
        for (int trial = 0; trial < 200; ++trial) {
            std::array<ClipVertex, 3> tri;
            const double cu = centre(rng), cv = centre(rng);
            for (ClipVertex& v : tri) v = {{pos(rng), pos(rng), pos(rng)}, {cu + spread(rng), cv + spread(rng)}, {bary(rng), bary(rng)}};
            std::vector<TilePiece> pieces;
            ASSERT_TRUE(clipToTiles(grid, tri, &pieces));
            pieces_total += static_cast<int>(pieces.size());
            double sum = 0;
            // The triangle's affine map from position to whole-texture texel space, via barycentrics.
            const Vec3d e1 = tri[1].position - tri[0].position, e2 = tri[2].position - tri[0].position;
            const Vec3d n = cross(e1, e2);
            auto texelOf = [&](const Vec3d& p) {
                const Vec3d d = p - tri[0].position;
                const double b1 = dot(cross(d, e2), n) / dot(n, n), b2 = dot(cross(e1, d), n) / dot(n, n);
                const double u = tri[0].uv.x + b1 * (tri[1].uv.x - tri[0].uv.x) + b2 * (tri[2].uv.x - tri[0].uv.x);
                const double v = tri[0].uv.y + b1 * (tri[1].uv.y - tri[0].uv.y) + b2 * (tri[2].uv.y - tri[0].uv.y);
                return std::array<double, 2>{u * image.width, (1 - v) * image.height};
            };
            for (const TilePiece& p : pieces) {
                sum += area(p.corners[0].position, p.corners[1].position, p.corners[2].position);
                const TexelRect r = grid.rectOf(p.tile), core = grid.coreOf(p.tile);
                for (int k = 0; k < 20; ++k) {
                    double a = bary(rng), b = bary(rng);
                    if (a + b > 1) a = 1 - a, b = 1 - b;
                    auto mix = [&](auto get) {
                        return get(p.corners[0]) + a * (get(p.corners[1]) - get(p.corners[0])) +
                               b * (get(p.corners[2]) - get(p.corners[0]));
                    };
                    const Vec3d point = mix([](const ClipVertex& c) { return c.position; });
                    const double ut = mix([](const ClipVertex& c) { return c.uv.x; });
                    const double vt = mix([](const ClipVertex& c) { return c.uv.y; });
                    const double x = r.x0 + ut * r.width(), y = r.y0 + (1 - vt) * r.height();  // texels of the image
                    const auto [s, t] = texelOf(point);
                    // Skip points within a hair of a texel edge, where rounding may pick either.
                    const double fs = s - std::floor(s), ft = t - std::floor(t);
                    if (fs < 1e-6 || fs > 1 - 1e-6 || ft < 1e-6 || ft > 1 - 1e-6) continue;
                    ++samples;
                    // Inside the core: except past the image border of a clamped texture.
                    const bool inner_x = grid.wraps || (x >= 0 && x <= image.width);
                    const bool inner_y = grid.wraps || (y >= 0 && y <= image.height);
                    ASSERT_TRUE(!inner_x || (x >= core.x0 - 1e-6 && x <= core.x1 + 1e-6)) << x << " outside core " << p.tile;
                    ASSERT_TRUE(!inner_y || (y >= core.y0 - 1e-6 && y <= core.y1 + 1e-6)) << y << " outside core " << p.tile;
                    ASSERT_EQ(nearest(tiles[static_cast<size_t>(p.tile)], x - r.x0, y - r.y0, false), nearest(image, s, t, grid.wraps))
                        << "trial " << trial << " tile " << p.tile << " at texel (" << s << ", " << t << ")";
                }
            }
            const double whole = area(tri[0].position, tri[1].position, tri[2].position);
            ASSERT_NEAR(sum, whole, 1e-9 * whole) << "trial " << trial;
        }
        EXPECT_GT(pieces_total, 200 * 2) << "the triangles were cut";
        EXPECT_GT(samples, 10000);
    }
}

// Two triangles sharing an edge that crosses core lines: every cut point on
// that edge is the same point, bit for bit, from both sides (no cracks); a
// triangle inside one core is one piece with its corners unchanged.
TEST(ClipToTiles, SharedEdgesAreCutAtTheSamePointsAndInnerTrianglesStayWhole) {
    const TileGrid grid = tileGridFor(2048, 2048, WrapMode::Wrap, 512, 16);
    const ClipVertex p0{{0, 0, 0}, {0.1, 0.1}, {}}, p1{{10.3, 0.7, 1.1}, {1.37, 0.2}, {1, 0}},
        p2{{3.1, 9.7, 2.9}, {0.3, 1.61}, {0, 1}}, p3{{12, 11, 3}, {1.9, 1.8}, {1, 1}};
    std::vector<TilePiece> a, b;
    ASSERT_TRUE(clipToTiles(grid, {p0, p1, p2}, &a));
    ASSERT_TRUE(clipToTiles(grid, {p2, p1, p3}, &b));
    auto onEdge = [&](const Vec3d& q) {
        const Vec3d d = p2.position - p1.position, e = q - p1.position;
        return length(cross(d, e)) < 1e-9 * dot(d, d) && dot(e, d) >= 0 && dot(e, d) <= dot(d, d);
    };
    std::vector<std::array<double, 3>> from_a, from_b;
    for (const auto* side : {&a, &b})
        for (const TilePiece& p : *side)
            for (const ClipVertex& v : p.corners)
                if (onEdge(v.position)) (side == &a ? from_a : from_b).push_back({v.position.x, v.position.y, v.position.z});
    auto unique = [](std::vector<std::array<double, 3>> v) {
        std::sort(v.begin(), v.end());
        v.erase(std::unique(v.begin(), v.end()), v.end());
        return v;
    };
    from_a = unique(from_a), from_b = unique(from_b);
    EXPECT_GE(from_a.size(), 6U) << "the edge crosses several core lines";
    EXPECT_EQ(from_a, from_b);

    std::vector<TilePiece> inner;
    const ClipVertex q0{{0, 0, 0}, {0.30, 0.70}, {}}, q1{{1, 0, 0}, {0.45, 0.70}, {}}, q2{{0, 1, 0}, {0.30, 0.55}, {}};
    ASSERT_TRUE(clipToTiles(grid, {q0, q1, q2}, &inner));
    ASSERT_EQ(inner.size(), 1U);
    EXPECT_EQ(inner[0].tile, 1 * 4 + 1) << "texels 614..922 lie in core column 1 and row 1 of a 4 x 4 grid";
    EXPECT_EQ(inner[0].corners[0].position, q0.position);
    EXPECT_EQ(inner[0].corners[1].position, q1.position);
    EXPECT_EQ(inner[0].corners[2].position, q2.position);
    const TexelRect r = grid.rectOf(inner[0].tile);
    EXPECT_NEAR(r.x0 + inner[0].corners[1].uv.x * r.width(), 0.45 * 2048, 1e-9);
    EXPECT_NEAR(r.y0 + (1 - inner[0].corners[2].uv.y) * r.height(), 0.45 * 2048, 1e-9);
}

// A triangle repeating a wrapping texture over two periods or more (a tiled
// roof), or with an infinite or NaN coordinate, is not cut: false and no
// pieces (the caller keeps the whole texture). Just under two periods it is
// cut; a clamped texture's triangle is cut however far its uv reach (its
// cells are bounded). A triangle of no area in either space leaves nothing.
TEST(ClipToTiles, RepeatsOverTwoPeriodsAndNonFiniteCoordinatesAreNotCut) {
    const TileGrid wrap = tileGridFor(2048, 2048, WrapMode::Wrap, 512, 16);
    const TileGrid clamp = tileGridFor(2048, 2048, WrapMode::Clamp, 512, 16);
    auto tri = [](double u) {
        return std::array<ClipVertex, 3>{ClipVertex{{0, 0, 0}, {0, 0}, {}}, ClipVertex{{1, 0, 0}, {u, 0}, {}},
                                         ClipVertex{{0, 1, 0}, {0, 1}, {}}};
    };
    const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
    for (const double u : {2.0, 1e6, 1e300, inf, nan}) {
        std::vector<TilePiece> pieces;
        EXPECT_FALSE(clipToTiles(wrap, tri(u), &pieces)) << u;
        EXPECT_TRUE(pieces.empty()) << u;
    }
    std::vector<TilePiece> pieces;
    EXPECT_TRUE(clipToTiles(wrap, tri(1.99), &pieces));
    EXPECT_GT(pieces.size(), 4U);
    pieces.clear();
    EXPECT_TRUE(clipToTiles(clamp, tri(1e300), &pieces)) << "clamped: bounded cells";
    for (const TilePiece& p : pieces) EXPECT_TRUE(p.tile >= 0 && p.tile < clamp.count());
    EXPECT_FALSE(clipToTiles(clamp, tri(nan), &pieces));
    std::vector<TilePiece> none;
    EXPECT_TRUE(clipToTiles(wrap, {ClipVertex{{0, 0, 0}, {0.1, 0.1}, {}}, ClipVertex{{0, 0, 0}, {0.9, 0.9}, {}},
                                   ClipVertex{{0, 0, 0}, {0.5, 0.5}, {}}},
                            &none));
    EXPECT_TRUE(none.empty());
}

}  // namespace
}  // namespace cityatlas::tiles
