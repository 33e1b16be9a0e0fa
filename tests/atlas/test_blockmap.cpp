// SPDX-License-Identifier: GPL-3.0-or-later
// A BlockMap's geometry planes (atlas/blockmap.h) against exact truth
// (../shared/SEED-FEATURES.md §1.3): on a synthetic LOD1 town, every cell
// whose centre is strictly inside a footprint (CGAL's exact point-in-polygon
// on the generator's own footprints, holes included) holds that building's
// base and eave height and id, and every other cell is empty (B1); the
// exposed sides and their columns equal a brute-force set from the cells
// and the wall image's columns do not overlap (B2); the distance plane
// equals a brute-force Chebyshev distance (B3); every building that holds a
// cell centre is in the feature list, and only those (B5); per building,
// the mean colour of its wall texels and of its roof cells is that of its
// facade and roof as textured (B6), the oracle sampling each surface's
// texture densely over its own uv triangles.
#include "atlas/blockmap.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_2_algorithms.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <set>

#include <OpenImageIO/imageio.h>
#include <fmt/format.h>

#include "core/srgb.h"
#include "ingest/synth/town.h"
#include "ingest/synth/write_town.h"
#include "../ingest/test_support.h"

namespace cityatlas::atlas {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using format::BlockMap;
using format::kBlockMapNone;

struct LodOneTown {
    synth::Town town;
    Scene scene;
    std::vector<int> building_of_feature;  // scene feature -> town building
};

LodOneTown lodOneTown(uint32_t buildings, uint64_t seed) {
    LodOneTown t;
    synth::TownSettings s;
    s.buildings = buildings;
    s.seed = seed;
    s.lod = 1;
    s.texture_size_px = 16;
    t.town = synth::generateTown(s);
    t.scene = synth::townToScene(t.town, "/nonexistent");
    std::map<std::string, int> by_id;
    for (size_t b = 0; b < t.town.buildings.size(); ++b) by_id[t.town.buildings[b].gml_id] = static_cast<int>(b);
    for (const Feature& f : t.scene.features) t.building_of_feature.push_back(by_id.count(f.gml_id) ? by_id[f.gml_id] : -1);
    return t;
}

double toSegment(const Vec2d& p, const Vec2d& a, const Vec2d& b) {
    const double abx = b.x - a.x, aby = b.y - a.y;
    const double s = std::clamp(((p.x - a.x) * abx + (p.y - a.y) * aby) / (abx * abx + aby * aby), 0.0, 1.0);
    return std::hypot(p.x - (a.x + s * abx), p.y - (a.y + s * aby));
}

// -1: on (within 1e-6 m of) an edge; 1: strictly inside the footprint (outside its holes); 0: outside.
int classify(const synth::SynthBuilding& b, const Vec2d& p) {
    std::vector<const std::vector<Vec2d>*> rings{&b.outer};
    for (const auto& h : b.holes) rings.push_back(&h);
    for (const auto* ring : rings)
        for (size_t i = 0; i < ring->size(); ++i)
            if (toSegment(p, (*ring)[i], (*ring)[(i + 1) % ring->size()]) <= 1e-6) return -1;
    auto inside = [&](const std::vector<Vec2d>& ring) {
        std::vector<K::Point_2> pts;
        for (const Vec2d& v : ring) pts.emplace_back(v.x, v.y);
        return CGAL::bounded_side_2(pts.begin(), pts.end(), K::Point_2(p.x, p.y), K()) == CGAL::ON_BOUNDED_SIDE;
    };
    if (!inside(b.outer)) return 0;
    for (const auto& h : b.holes)
        if (inside(h)) return 0;
    return 1;
}

class LodOneBlockMap : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        town_ = new LodOneTown(lodOneTown(150, 7));
        bm_ = new BlockMap;
        BlockMapParams p;
        p.cell_m = 1.25;
        ASSERT_TRUE(buildBlockMap(town_->scene.triangles, p, bm_).ok());
    }
    static void TearDownTestSuite() { delete town_, delete bm_; }
    static LodOneTown* town_;
    static BlockMap* bm_;
};
LodOneTown* LodOneBlockMap::town_ = nullptr;
BlockMap* LodOneBlockMap::bm_ = nullptr;

TEST_F(LodOneBlockMap, CellsHoldTheFootprintTheirCentreIsIn) {
    const BlockMap& bm = *bm_;
    const LodOneTown& t = *town_;
    // The grid nests: its corner on multiples of the cell side.
    EXPECT_DOUBLE_EQ(std::remainder(bm.origin.x, bm.cell_m), 0.0);
    EXPECT_DOUBLE_EQ(std::remainder(bm.origin.y, bm.cell_m), 0.0);
    size_t checked = 0, on_edge = 0, inside = 0, wrong = 0;
    std::set<int> holding;  // buildings with a cell centre strictly inside
    for (int y = 0; y < bm.ny; ++y)
        for (int x = 0; x < bm.nx; ++x) {
            const Vec2d c{bm.origin.x + (x + 0.5) * bm.cell_m, bm.origin.y + (y + 0.5) * bm.cell_m};
            int in = -2;  // the building whose footprint holds c
            bool edge = false;
            for (size_t b = 0; b < t.town.buildings.size() && !edge; ++b) {
                const int k = classify(t.town.buildings[b], c);
                edge = k < 0;
                if (k == 1) in = static_cast<int>(b);
            }
            if (edge) {
                ++on_edge;
                continue;
            }
            ++checked;
            const format::BlockMapCell& cell = bm.cells[bm.index(x, y)];
            if (in < 0) {
                wrong += cell.occupied() || cell.top != 0;
                continue;
            }
            ++inside;
            holding.insert(in);
            const synth::SynthBuilding& b = t.town.buildings[static_cast<size_t>(in)];
            const bool ok = cell.occupied() && cell.top == bm.quantize(b.base_height_m + b.eave_height_m) &&
                            cell.base == bm.quantize(b.base_height_m) &&
                            t.building_of_feature[bm.features[cell.feature]] == in;
            if (!ok && wrong < 5)
                ADD_FAILURE() << "cell " << x << "," << y << " in " << b.gml_id << ": top " << cell.top << " want "
                              << bm.quantize(b.base_height_m + b.eave_height_m) << ", base " << cell.base << " want "
                              << bm.quantize(b.base_height_m);
            wrong += !ok;
        }
    EXPECT_EQ(wrong, 0u) << "of " << checked << " cells";
    EXPECT_GT(inside, 10000u);
    // The synthetic footprints lie on a fine grid, and about 2 % of the centres on their edges.
    EXPECT_LT(on_edge, checked / 25) << "cells on a footprint edge are not checked";
    // B5: exactly the buildings holding a cell centre are listed (none lost at 1.25 m).
    std::set<int> listed;
    for (uint32_t f : bm.features) listed.insert(t.building_of_feature[f]);
    EXPECT_EQ(listed, holding);
    EXPECT_EQ(listed.size(), t.town.buildings.size());
}

TEST_F(LodOneBlockMap, ColumnsAreTheExposedSidesAndDoNotOverlap) {
    const BlockMap& bm = *bm_;
    // Brute force from the cells: (cell, side) -> the wall span's base.
    std::map<std::pair<size_t, int>, uint16_t> want;
    for (int y = 0; y < bm.ny; ++y)
        for (int x = 0; x < bm.nx; ++x) {
            const format::BlockMapCell& c = bm.cells[bm.index(x, y)];
            if (!c.occupied()) continue;
            for (int k = 0; k < 4; ++k) {
                const int ex = x + format::kSideDx[static_cast<size_t>(k)], ey = y + format::kSideDy[static_cast<size_t>(k)];
                const bool in = ex >= 0 && ey >= 0 && ex < bm.nx && ey < bm.ny;
                const format::BlockMapCell* n = in ? &bm.cells[bm.index(ex, ey)] : nullptr;
                const bool occupied = n && n->occupied();
                if (occupied && n->top >= c.top && n->base <= c.base) continue;  // covered
                want[{bm.index(x, y), k}] = occupied && n->base <= c.base ? std::max(c.base, n->top) : c.base;
            }
        }
    ASSERT_EQ(bm.columns.size(), want.size());
    std::vector<uint8_t> used(static_cast<size_t>(bm.wall_width) * static_cast<size_t>(bm.wall_height), 0);
    size_t overlaps = 0, mismatched = 0;
    for (const auto& [key, base] : want) {
        const int x = static_cast<int>(key.first % static_cast<size_t>(bm.nx)), y = static_cast<int>(key.first / static_cast<size_t>(bm.nx));
        const uint32_t i = bm.columnOf(x, y, key.second);
        ASSERT_NE(i, kBlockMapNone);
        const format::BlockMapColumn& col = bm.columns[i];
        const double span = bm.height(bm.cells[key.first].top) - bm.height(base);
        mismatched += col.cell != key.first || col.side != key.second || col.base != base ||
                      col.rows != std::max(1, static_cast<int>(std::ceil(span / bm.cell_m - 1e-9)));
        ASSERT_LE(col.x, bm.wall_width - 1);
        ASSERT_LE(col.y + col.rows, bm.wall_height);
        for (int r = 0; r < col.rows; ++r) overlaps += used[static_cast<size_t>(col.y + r) * static_cast<size_t>(bm.wall_width) + col.x]++ > 0;
    }
    EXPECT_EQ(mismatched, 0u);
    EXPECT_EQ(overlaps, 0u);
}

TEST_F(LodOneBlockMap, ErrorIsWithinHalfAVoxelDiagonal) {
    // B4, LOD1: flat roofs and vertical walls are within half a voxel's diagonal of the prisms.
    const BlockMap& bm = *bm_;
    const double q = (bm.z_hi - bm.origin.z) / 65535;
    const double bound = 0.5 * std::sqrt(2 * bm.cell_m * bm.cell_m + q * q);
    const BlockMapError e = measureBlockMapError(town_->scene.triangles, bm);
    EXPECT_LE(e.hausdorff_m, bound + 1e-6) << "triangles -> prisms " << e.triangles_to_prisms_m << ", prisms -> triangles "
                                           << e.prisms_to_triangles_m;
    EXPECT_GT(e.hausdorff_m, 0.5 * bound) << "footprints off the grid leave a real error";
    std::printf("LOD1 e_geo %.4f m (triangles -> prisms %.4f, prisms -> triangles %.4f), bound %.4f\n", e.hausdorff_m,
                e.triangles_to_prisms_m, e.prisms_to_triangles_m, bound);
}

// A closed box's triangles (12), [x0, x1] x [y0, y1] x [z0, z1].
std::vector<Triangle> boxTriangles(const Vec3d& lo, const Vec3d& hi) {
    const Vec3d c[8] = {{lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {lo.x, hi.y, lo.z}, {hi.x, hi.y, lo.z},
                        {lo.x, lo.y, hi.z}, {hi.x, lo.y, hi.z}, {lo.x, hi.y, hi.z}, {hi.x, hi.y, hi.z}};
    const int f[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                          {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
    std::vector<Triangle> out;
    for (const auto& t : f) {
        Triangle tri;
        tri.position_local = {c[t[0]], c[t[1]], c[t[2]]};
        out.push_back(tri);
    }
    return out;
}

TEST(BlockMap, ErrorOfABoxOffTheGridIsItsCornerOffset) {
    // A 10 m box a quarter cell off the 1.25 m grid: its cells span [0, 10] where it spans
    // [0.3125, 10.3125], so both one-sided distances are the corners' 0.3125 * sqrt(2).
    const auto tris = boxTriangles({0.3125, 0.3125, 2}, {10.3125, 10.3125, 12});
    BlockMap bm;
    BlockMapParams p;
    p.cell_m = 1.25;
    ASSERT_TRUE(buildBlockMap(tris, p, &bm).ok());
    ASSERT_EQ(bm.nx, 9);  // the grid starts at 0: the box's corner cell
    const BlockMapError e = measureBlockMapError(tris, bm);
    EXPECT_NEAR(e.triangles_to_prisms_m, 0.3125 * std::sqrt(2.0), 1e-9);
    EXPECT_NEAR(e.prisms_to_triangles_m, 0.3125 * std::sqrt(2.0), 1e-9);
    EXPECT_NEAR(e.hausdorff_m, 0.3125 * std::sqrt(2.0), 1e-9);
}

TEST_F(LodOneBlockMap, DistanceIsTheChebyshevDistanceToTheNearestBuilding) {
    const BlockMap& bm = *bm_;
    std::vector<std::pair<int, int>> occupied;
    for (int y = 0; y < bm.ny; ++y)
        for (int x = 0; x < bm.nx; ++x)
            if (bm.cells[bm.index(x, y)].occupied()) occupied.emplace_back(x, y);
    size_t wrong = 0, far = 0;
    for (int y = 0; y < bm.ny; ++y)
        for (int x = 0; x < bm.nx; ++x) {
            int d = 1 << 30;
            for (const auto& [ox, oy] : occupied) d = std::min(d, std::max(std::abs(ox - x), std::abs(oy - y)));
            wrong += bm.dist[bm.index(x, y)] != std::min(d, 255);
            far += d >= 2;
        }
    EXPECT_EQ(wrong, 0u);
    EXPECT_GT(far, 1000u) << "space leaping has room to leap";
}

// Linear RGB image of a texture file (the oracle's own read, OpenImageIO).
struct LinearImage {
    int w = 0, h = 0;
    std::vector<double> px;  // w * h * 3
    std::array<double, 3> at(double u, double v) const {  // nearest texel, repeated
        const int x = ((static_cast<int>(std::floor(u * w)) % w) + w) % w;
        const int y = ((static_cast<int>(std::floor((1 - v) * h)) % h) + h) % h;
        const size_t i = (static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x)) * 3;
        return {px[i], px[i + 1], px[i + 2]};
    }
};

LinearImage readLinear(const std::string& path) {
    LinearImage img;
    auto in = OIIO::ImageInput::open(path);
    if (!in) return img;
    const OIIO::ImageSpec& spec = in->spec();
    std::vector<float> raw(static_cast<size_t>(spec.width) * static_cast<size_t>(spec.height) * static_cast<size_t>(spec.nchannels));
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeFloat, raw.data())) return img;
    img.w = spec.width, img.h = spec.height;
    for (size_t i = 0; i < raw.size(); i += static_cast<size_t>(spec.nchannels))
        for (size_t k = 0; k < 3; ++k) img.px.push_back(linearFromSrgb(raw[i + std::min<size_t>(k, static_cast<size_t>(spec.nchannels) - 1)]));
    return img;
}

// B6 at `cell_m` over textures of `texture_px`; with `reduced`, the samples
// read the textures' reduced mip levels where their spacing allows.
void expectColourMeans(double cell_m, int texture_px, bool reduced, double min_roof_cells) {
    synth::TownSettings settings;
    settings.buildings = 40;
    settings.seed = 11;
    settings.lod = 1;
    settings.texture_size_px = texture_px;
    const synth::Town town = synth::generateTown(settings);
    const auto dir = test::scratchPath("cityatlas_test_blockmap", fmt::format("town{}", texture_px));
    ASSERT_TRUE(synth::writeTextures(town, dir, {}).ok());
    const Scene scene = synth::townToScene(town, dir);
    BlockMap bm;
    BlockMapParams params;
    params.cell_m = cell_m;
    const std::shared_ptr<ReducedTextures> kept = makeReducedTextures(scene.textures.size());
    SurfaceTables tables{scene.textures, scene.materials, 256, reduced ? kept.get() : nullptr};
    BlockMapColourStats stats;
    ASSERT_TRUE(buildBlockMap(scene.triangles, params, &bm, &tables, &stats).ok());
    EXPECT_EQ(stats.unreadable_samples, 0u);
    EXPECT_LT(stats.texels_without_hit, bm.columns.size() / 20) << "wall texels whose rays found no wall";

    // Oracle: per feature and surface kind, the area-weighted mean colour of its triangles as textured,
    // each triangle sampled at 4,000 uniform random points (or its material's colour).
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> u01(0, 1);
    std::map<int32_t, LinearImage> images;
    auto image = [&](int32_t t) -> const LinearImage& {
        if (!images.count(t)) images[t] = readLinear(scene.textures.path(static_cast<size_t>(t)));
        return images[t];
    };
    struct Sum {
        std::array<double, 3> rgb{0, 0, 0};
        double weight = 0;
        void add(const std::array<double, 3>& c, double w) {
            for (size_t k = 0; k < 3; ++k) rgb[k] += w * c[k];
            weight += w;
        }
        std::array<double, 3> mean() const { return {rgb[0] / weight, rgb[1] / weight, rgb[2] / weight}; }
    };
    std::map<uint32_t, Sum> want_wall, want_roof, got_wall, got_roof;
    for (const Triangle& t : scene.triangles) {
        const bool wall = t.semantic == SurfaceSemantic::Wall, roof = t.semantic == SurfaceSemantic::Roof;
        if (!wall && !roof) continue;
        const double area = triangleArea(t.position_local);
        Sum& sum = (wall ? want_wall : want_roof)[t.feature];
        if (t.texture < 0) {
            const auto& d = scene.materials[static_cast<size_t>(t.material)].diffuse;
            sum.add({d[0], d[1], d[2]}, area);
            continue;
        }
        const LinearImage& img = image(t.texture);
        ASSERT_GT(img.w, 0);
        // Uniform random points (a regular grid would alias with the paving's repeat).
        for (int i = 0; i < 4000; ++i) {
            double b1 = u01(rng), b2 = u01(rng);
            if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
            const double b0 = 1 - b1 - b2;
            sum.add(img.at(b0 * t.uv[0].x + b1 * t.uv[1].x + b2 * t.uv[2].x, b0 * t.uv[0].y + b1 * t.uv[1].y + b2 * t.uv[2].y), area);
        }
    }
    auto linear = [](const uint8_t* p) { return std::array<double, 3>{linearFromSrgb(p[0] / 255.0), linearFromSrgb(p[1] / 255.0), linearFromSrgb(p[2] / 255.0)}; };
    for (size_t c = 0; c < bm.cells.size(); ++c)
        if (bm.cells[c].occupied()) got_roof[bm.features[bm.cells[c].feature]].add(linear(&bm.roof[c * 3]), 1);
    for (const format::BlockMapColumn& col : bm.columns) {
        const double texel_m2 = bm.cell_m * (bm.height(bm.cells[col.cell].top) - bm.height(col.base)) / col.rows;
        for (int r = 0; r < col.rows; ++r)
            got_wall[bm.features[bm.cells[col.cell].feature]].add(
                linear(&bm.walls[((col.y + r) * static_cast<size_t>(bm.wall_width) + col.x) * 3]), texel_m2);
    }
    double worst_wall = 0, worst_roof = 0;
    size_t compared = 0;
    for (const auto& [f, got] : got_wall) {
        if (got.weight < 40 * bm.cell_m * bm.cell_m || got_roof[f].weight < min_roof_cells) continue;  // small ones are noisy
        ++compared;
        for (size_t k = 0; k < 3; ++k) {
            worst_wall = std::max(worst_wall, std::abs(got.mean()[k] - want_wall[f].mean()[k]));
            worst_roof = std::max(worst_roof, std::abs(got_roof[f].mean()[k] - want_roof[f].mean()[k]));
        }
    }
    EXPECT_GT(compared, bm.features.size() / 2);
    EXPECT_LE(worst_wall, 0.02) << "linear, per channel";
    EXPECT_LE(worst_roof, 0.02);
    EXPECT_EQ(stats.reduced_samples > 0, reduced);
    std::printf("cell %.2f m, %d px textures, reduced levels %s: buildings compared %zu of %zu, worst wall %.4f, "
                "worst roof %.4f, rays %llu, hits %llu (%llu from reduced levels)\n",
                cell_m, texture_px, reduced ? "on" : "off", compared, bm.features.size(), worst_wall, worst_roof,
                static_cast<unsigned long long>(stats.rays), static_cast<unsigned long long>(stats.hits),
                static_cast<unsigned long long>(stats.reduced_samples));
}

TEST(BlockMap, WallAndRoofColoursAreTheBuildingsTextureMeans) { expectColourMeans(1.25, 64, false, 40); }

// An upper node's cell: 2.5 m over 256 px facades puts the samples 10 texels
// apart, so they read the 32 px level; the means hold as at full resolution.
TEST(BlockMap, ColoursFromReducedLevelsAreTheTextureMeansToo) { expectColourMeans(2.5, 256, true, 10); }

TEST(BlockMap, MaxSamplingKeepsEveryBuildingAndCoversTheCentreCells) {
    // At 6 m cells some of the town's buildings hold no cell centre; with 4 x 4
    // samples a cell every building wider than 1.5 m both ways is present, and
    // every cell the centre sampling fills is filled, at least as high.
    const LodOneTown t = lodOneTown(150, 7);
    BlockMap centre, max;
    BlockMapParams p;
    p.cell_m = 6;
    p.keep_small = false;
    ASSERT_TRUE(buildBlockMap(t.scene.triangles, p, &centre).ok());
    p.sample = BlockMapSample::Max;
    ASSERT_TRUE(buildBlockMap(t.scene.triangles, p, &max).ok());
    EXPECT_LT(centre.features.size(), t.scene.features.size()) << "the test needs buildings that centres miss";
    EXPECT_EQ(max.features.size(), t.scene.features.size());
    ASSERT_EQ(centre.cells.size(), max.cells.size());
    size_t grown = 0;
    for (size_t c = 0; c < centre.cells.size(); ++c) {
        if (!centre.cells[c].occupied()) {
            grown += max.cells[c].occupied();
            continue;
        }
        ASSERT_TRUE(max.cells[c].occupied());
        EXPECT_GE(max.cells[c].top, centre.cells[c].top);
        EXPECT_LE(max.cells[c].base, centre.cells[c].base);
    }
    EXPECT_GT(grown, 0u);
}

TEST(BlockMap, BuildingsNoCentreHitsTakeTheFreeCellUnderTheirBox) {
    // keep_small (the default) against the samples alone, at 6 m cells: the
    // cells the samples fill are the same; each building they miss holds
    // exactly the cell under its box's centre, at its box's top and base,
    // unless another building holds that cell (or one missed building
    // with a lower id claimed it first).
    const LodOneTown t = lodOneTown(150, 7);
    BlockMapParams p;
    p.cell_m = 6;
    p.keep_small = false;
    BlockMap plain, kept;
    ASSERT_TRUE(buildBlockMap(t.scene.triangles, p, &plain).ok());
    p.keep_small = true;
    ASSERT_TRUE(buildBlockMap(t.scene.triangles, p, &kept).ok());
    ASSERT_EQ(plain.cells.size(), kept.cells.size());
    std::map<uint32_t, Box3d> box;
    for (const Triangle& tri : t.scene.triangles)
        for (const Vec3d& q : tri.position_local) box[tri.feature].extend(q);
    const std::set<uint32_t> held(plain.features.begin(), plain.features.end());
    std::map<size_t, uint32_t> expected;  // cell -> the missed building that should hold it
    for (const auto& [f, b] : box) {
        if (held.count(f)) continue;
        const int x = static_cast<int>(std::floor((0.5 * (b.min.x + b.max.x) - plain.origin.x) / p.cell_m));
        const int y = static_cast<int>(std::floor((0.5 * (b.min.y + b.max.y) - plain.origin.y) / p.cell_m));
        ASSERT_TRUE(plain.inside(x, y));
        const size_t c = plain.index(x, y);
        if (!plain.cells[c].occupied() && !expected.count(c)) expected[c] = f;  // ascending ids: the first claims it
    }
    ASSERT_GT(expected.size(), 0u) << "the test needs buildings that centres miss";
    for (size_t c = 0; c < kept.cells.size(); ++c) {
        const format::BlockMapCell& k = kept.cells[c];
        if (plain.cells[c].occupied()) {
            ASSERT_TRUE(k.occupied());
            EXPECT_EQ(kept.features[k.feature], plain.features[plain.cells[c].feature]);
            EXPECT_EQ(k.top, plain.cells[c].top);
            EXPECT_EQ(k.base, plain.cells[c].base);
            continue;
        }
        const auto it = expected.find(c);
        ASSERT_EQ(k.occupied(), it != expected.end()) << "cell " << c;
        if (it == expected.end()) continue;
        EXPECT_EQ(kept.features[k.feature], it->second);
        EXPECT_EQ(k.top, kept.quantize(box[it->second].max.z));
        EXPECT_EQ(k.base, kept.quantize(box[it->second].min.z));
    }
    EXPECT_EQ(kept.features.size(), plain.features.size() + expected.size());
    std::printf("centres hold %zu of %zu buildings; %zu more take a free cell\n", plain.features.size(), box.size(),
                expected.size());
}

TEST(BlockMap, NothingToBuildAndBadParameters) {
    BlockMap bm;
    bm.nx = 3;
    ASSERT_TRUE(buildBlockMap({}, BlockMapParams{}, &bm).ok());
    EXPECT_EQ(bm.nx, 0);
    EXPECT_TRUE(bm.cells.empty());
    Triangle t;
    t.position_local = {Vec3d{0, 0, 0}, Vec3d{1, 0, 0}, Vec3d{0, 1, 0}};
    for (double cell : {0.0, -1.0, std::nan("")}) {
        BlockMapParams p;
        p.cell_m = cell;
        EXPECT_FALSE(buildBlockMap(std::span<const Triangle>(&t, 1), p, &bm).ok()) << cell;
    }
    // A grid the file could not hold is refused before any memory is asked for; so is a corner at infinity.
    std::vector<Triangle> far(2, t);
    far[1].position_local = {Vec3d{1e5, 1e5, 0}, Vec3d{1e5 + 1, 1e5, 0}, Vec3d{1e5, 1e5 + 1, 0}};
    BlockMapParams fine;
    fine.cell_m = 0.01;
    const Status big = buildBlockMap(far, fine, &bm);
    EXPECT_EQ(big.code, StatusCode::kUnsupported) << big.error;
    far[1].position_local[0].x = std::numeric_limits<double>::infinity();
    EXPECT_EQ(buildBlockMap(far, BlockMapParams{}, &bm).code, StatusCode::kInvalidInput);
}

TEST(BlockMap, ExposedSidesFollowTheNeighboursHeights) {
    // A 4 x 1 grid: tall, low, empty, floating -> the tall cell shows +x
    // (over the low one) and the three sides to the outside; the low one its
    // +x side and the two outside ones, not -x (its neighbour is taller and
    // stands as low); the floating cell all four.
    BlockMap bm;
    bm.nx = 4, bm.ny = 1, bm.cell_m = 1, bm.z_hi = 10;
    bm.cells.resize(4);
    bm.cells[0] = {40000, 0, 0, 0};
    bm.cells[1] = {20000, 0, 1, 4};
    bm.cells[3] = {60000, 1000, 2, 7};
    EXPECT_EQ(bm.exposedSides(0, 0), 0b1111);
    EXPECT_EQ(bm.exposedSides(1, 0), 0b1101);
    EXPECT_EQ(bm.exposedSides(2, 0), 0);
    EXPECT_EQ(bm.exposedSides(3, 0), 0b1111);
    EXPECT_EQ(bm.columnOf(1, 0, format::kPlusX), 4u);
    EXPECT_EQ(bm.columnOf(1, 0, format::kMinusX), kBlockMapNone);
    EXPECT_EQ(bm.columnOf(1, 0, format::kPlusY), 5u);
    EXPECT_EQ(bm.columnOf(1, 0, format::kMinusY), 6u);
    EXPECT_EQ(bm.quantize(5), 32768);
    EXPECT_EQ(bm.quantize(-3), 0);
    EXPECT_EQ(bm.quantize(11), 65535);
    // Under a taller neighbour standing higher, the side shows; not once the cell stands as high.
    bm.cells[0].base = 5000;
    EXPECT_EQ(bm.exposedSides(1, 0), 0b1111);
    bm.cells[1].base = 5000;
    EXPECT_EQ(bm.exposedSides(1, 0), 0b1101);
}

}  // namespace
}  // namespace cityatlas::atlas
