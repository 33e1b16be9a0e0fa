// SPDX-License-Identifier: GPL-3.0-or-later
// The synthetic town generator checked against closed forms computed here,
// independently of the generator's own arithmetic.
#include "ingest/synth/town.h"
#include "ingest/synth/write_town.h"

#include <gtest/gtest.h>

#include "truth_check.h"

#include <cmath>
#include <map>
#include <set>
#include <tuple>

namespace cityatlas::synth {
namespace {

Town makeTown(uint32_t n, int lod, uint64_t seed = 1) {
    TownSettings s;
    s.buildings = n;
    s.lod = lod;
    s.seed = seed;
    s.texture_size_px = 64;
    return generateTown(s);
}

// Triangles of one feature.
std::vector<const Triangle*> trianglesOf(const Scene& scene, uint32_t feature) {
    std::vector<const Triangle*> out;
    for (const Triangle& t : scene.triangles)
        if (t.feature == feature) out.push_back(&t);
    return out;
}

// Divergence theorem: for a closed, outward-oriented surface the signed volume
// is sum over triangles of p0 . (p1 x p2) / 6. Wrong orientation or a hole in
// the surface gives a wrong (or meaningless) number.
double signedVolume(const std::vector<const Triangle*>& tris, const Vec3d& ref) {
    double v = 0;
    for (const Triangle* t : tris) {
        const Vec3d a = t->position_local[0] - ref, b = t->position_local[1] - ref, c = t->position_local[2] - ref;
        v += dot(a, cross(b, c)) / 6.0;
    }
    return v;
}

double area(const std::vector<const Triangle*>& tris, SurfaceSemantic sem) {
    double a = 0;
    for (const Triangle* t : tris)
        if (t->semantic == sem) a += triangleArea(t->position_local);
    return a;
}

double dist(Vec2d a, Vec2d b) { return std::hypot(a.x - b.x, a.y - b.y); }

double ringLength(const std::vector<Vec2d>& r) {
    double l = 0;
    for (size_t i = 0; i < r.size(); ++i) l += dist(r[i], r[(i + 1) % r.size()]);
    return l;
}

double shoelace(const std::vector<Vec2d>& r) {
    double a = 0;
    for (size_t i = 0; i < r.size(); ++i) a += r[i].x * r[(i + 1) % r.size()].y - r[(i + 1) % r.size()].x * r[i].y;
    return a / 2;
}

TEST(SynthTown, SameSeedSameTownDifferentSeedDifferentTown) {
    const Town a = makeTown(60, 2, 7), b = makeTown(60, 2, 7), c = makeTown(60, 2, 8);
    ASSERT_EQ(a.buildings.size(), 60u);
    auto signature = [](const Town& t) {
        std::vector<std::tuple<int, int, int, double, double>> s;
        for (const auto& b : t.buildings)
            s.emplace_back(int(b.shape), int(b.roof), b.storeys, b.footprint_area_m2, b.outer[0].x);
        return s;
    };
    EXPECT_EQ(signature(a), signature(b));
    EXPECT_NE(signature(a), signature(c));
    EXPECT_EQ(makeTruth(a).dump(), makeTruth(b).dump());
}

TEST(SynthTown, HasEveryFootprintShapeAndRoofTypeAndHoles) {
    const Town town = makeTown(200, 2);
    std::set<FootprintShape> shapes;
    std::set<RoofType> roofs;
    size_t courtyards_with_holes = 0, rgba = 0;
    for (const auto& b : town.buildings) {
        shapes.insert(b.shape);
        roofs.insert(b.roof);
        if (b.shape == FootprintShape::Courtyard) {
            EXPECT_EQ(b.holes.size(), 1u) << b.gml_id;
            courtyards_with_holes += !b.holes.empty();
        } else {
            EXPECT_TRUE(b.holes.empty()) << b.gml_id;
        }
    }
    for (const auto& t : town.textures) rgba += t.channels == 4;
    EXPECT_EQ(shapes.size(), 4u);
    EXPECT_EQ(roofs.size(), 4u);
    EXPECT_GT(courtyards_with_holes, 0u);
    EXPECT_GT(rgba, 0u);
    EXPECT_EQ(town.textures.size(), town.buildings.size() + 1);  // a facade each + the paving
}

TEST(SynthTown, Lod1TownIsFlatBlocksWithTheSameFootprints) {
    const Town lod1 = makeTown(80, 1), lod2 = makeTown(80, 2);
    for (size_t i = 0; i < lod1.buildings.size(); ++i) {
        EXPECT_EQ(lod1.buildings[i].roof, RoofType::Flat);
        EXPECT_EQ(lod1.buildings[i].ridge_height_m, lod1.buildings[i].eave_height_m);
        EXPECT_EQ(lod1.buildings[i].outer.size(), lod2.buildings[i].outer.size());
        EXPECT_EQ(lod1.buildings[i].outer[0], lod2.buildings[i].outer[0]);
    }
}

// Every coordinate must be a multiple of 1/32 m (town.h): then it is exact in
// double, both locally and after adding a whole-metre origin below 2^26 m.
TEST(SynthTown, CoordinatesAreExactBinaryFractions) {
    for (int lod : {1, 2}) {
        const Town town = makeTown(120, lod);
        for (const auto& b : town.buildings)
            for (const auto& s : b.surfaces)
                for (const auto& r : s.rings)
                    for (const Vec3d& p : r)
                        for (double c : {p.x, p.y, p.z}) {
                            ASSERT_EQ(c * 32, std::round(c * 32)) << b.gml_id << " " << s.gml_id;
                            const double far = 9900000.0 + c;
                            ASSERT_EQ(far - 9900000.0, c);  // no rounding at extreme northings
                        }
    }
}

TEST(SynthTown, FootprintAreaAndOrientation) {
    const Town town = makeTown(150, 2);
    for (const auto& b : town.buildings) {
        const double outer = shoelace(b.outer);
        EXPECT_GT(outer, 0) << b.gml_id << " outer ring must be counter-clockwise";
        double a = outer;
        for (const auto& h : b.holes) {
            EXPECT_LT(shoelace(h), 0) << b.gml_id << " holes must be clockwise";
            a += shoelace(h);
        }
        EXPECT_NEAR(a, b.footprint_area_m2, 1e-9 * a) << b.gml_id;
    }
}

// Watertight and consistently oriented: in each building's triangle mesh,
// every directed edge a->b is matched by exactly one b->a.
TEST(SynthTown, EveryBuildingIsAClosedConsistentlyOrientedSurface) {
    for (int lod : {1, 2}) {
        const Town town = makeTown(150, lod);
        const Scene scene = townToScene(town, "/tmp");
        for (uint32_t f = 0; f < town.buildings.size(); ++f) {
            std::map<std::pair<std::tuple<double, double, double>, std::tuple<double, double, double>>, int> edges;
            auto key = [](const Vec3d& p) { return std::make_tuple(p.x, p.y, p.z); };
            for (const Triangle* t : trianglesOf(scene, f))
                for (int k = 0; k < 3; ++k)
                    edges[{key(t->position_local[k]), key(t->position_local[(k + 1) % 3])}]++;
            for (const auto& [e, n] : edges) {
                EXPECT_EQ(n, 1) << town.buildings[f].gml_id << ": directed edge used " << n << " times";
                const auto rev = edges.find({e.second, e.first});
                ASSERT_TRUE(rev != edges.end()) << town.buildings[f].gml_id << ": open edge (LOD" << lod << ")";
                EXPECT_EQ(rev->second, 1);
            }
        }
    }
}

// Volume, roof and wall areas against closed forms for each roof type. The
// rectangle's side lengths w >= d are read from its footprint, the rise from
// ridge - eave; formulas: gable volume w d r / 2, roof 2 w sqrt((d/2)^2 + r^2);
// hip volume d r (3w - d) / 6, roof w d sqrt(1 + (2r/d)^2); pyramid volume
// w d r / 3, roof w sqrt((d/2)^2 + r^2) + d sqrt((w/2)^2 + r^2).
TEST(SynthTown, VolumesAndAreasMatchClosedForms) {
    const Town town = makeTown(300, 2);
    const Scene scene = townToScene(town, "/tmp");
    std::map<RoofType, int> checked;
    for (uint32_t f = 0; f < town.buildings.size(); ++f) {
        const SynthBuilding& b = town.buildings[f];
        const auto tris = trianglesOf(scene, f);
        const double H = b.eave_height_m, r = b.ridge_height_m - b.eave_height_m;
        double perimeter = ringLength(b.outer);
        for (const auto& h : b.holes) perimeter += ringLength(h);
        const double A = b.footprint_area_m2;
        double volume = A * H, roof_area = A, wall_area = perimeter * H;
        if (b.shape == FootprintShape::Rectangle && b.roof != RoofType::Flat) {
            double w = dist(b.outer[0], b.outer[1]), d = dist(b.outer[1], b.outer[2]);
            ASSERT_GE(w, d) << b.gml_id;
            switch (b.roof) {
                case RoofType::Gable:
                    volume += w * d * r / 2;
                    roof_area = 2 * w * std::sqrt(d * d / 4 + r * r);
                    wall_area += d * r;  // two gable triangles, d r / 2 each
                    break;
                case RoofType::Hip:
                    volume += d * r * (3 * w - d) / 6;
                    roof_area = w * d * std::sqrt(1 + 4 * r * r / (d * d));
                    break;
                case RoofType::Pyramid:
                    volume += w * d * r / 3;
                    roof_area = w * std::sqrt(d * d / 4 + r * r) + d * std::sqrt(w * w / 4 + r * r);
                    break;
                case RoofType::Flat: break;
            }
        }
        const Vec3d ref = tris.front()->position_local[0];
        EXPECT_NEAR(signedVolume(tris, ref), volume, 1e-9 * volume) << b.gml_id << " " << roofTypeName(b.roof);
        EXPECT_NEAR(area(tris, SurfaceSemantic::Roof), roof_area, 1e-9 * roof_area) << b.gml_id;
        EXPECT_NEAR(area(tris, SurfaceSemantic::Wall), wall_area, 1e-9 * wall_area) << b.gml_id;
        EXPECT_NEAR(area(tris, SurfaceSemantic::Ground), A, 1e-9 * A) << b.gml_id;
        checked[b.roof]++;
    }
    EXPECT_EQ(checked.size(), 4u) << "every roof type must be exercised";
}

// truth.json's counts come from the rings (V + 2H - 2 per polygon, Newell
// areas); the Scene comes from CGAL's triangulation. They must agree.
TEST(SynthTown, SceneAgreesWithTruth) {
    for (int lod : {1, 2}) {
        const Town town = makeTown(200, lod);
        const Scene scene = townToScene(town, "/out");
        const auto truth = makeTruth(town);
        expectStatsMatchTruth(computeStats(scene), truth);
        // Every textured triangle points at a texture the town writes.
        for (const Triangle& t : scene.triangles)
            if (t.texture >= 0) {
                ASSERT_LT(static_cast<size_t>(t.texture), scene.textures.size());
            }
    }
}

TEST(SynthTown, PavingRepeatsAboutAThousandTimesAndWallsWrap) {
    const Town town = makeTown(200, 2);
    const auto truth = makeTruth(town);
    const double max_uv = truth["max_abs_uv"].get<double>();
    EXPECT_GT(max_uv, 500);   // "texture coordinates up to ~1000"
    EXPECT_LT(max_uv, 2000);
    EXPECT_GT(truth["surfaces"]["roof"]["textured_polygons"].get<int>(), 0);
    EXPECT_GT(truth["surfaces"]["roof"]["coloured_polygons"].get<int>(), 0);
}

TEST(SynthTown, ExactDecimalRoundTrips) {
    for (double v : {0.0, -0.0, 1.0, 0.1, 5336000.15625, 9900000.03125, -12.5, 1e-7, 123456789.125}) {
        const std::string s = exactDecimal(v);
        EXPECT_EQ(std::stod(s), v) << s;
        EXPECT_EQ(s.find('e'), std::string::npos) << s;
    }
    EXPECT_EQ(exactDecimal(-0.0), "0");
    EXPECT_EQ(exactDecimal(690000.5), "690000.5");
}

TEST(SynthTown, RejectsImpossibleSettings) {
    TownSettings s;
    s.buildings = 0;
    EXPECT_THROW(generateTown(s), std::invalid_argument);
    s.buildings = 1;
    s.lod = 3;
    EXPECT_THROW(generateTown(s), std::invalid_argument);
}

}  // namespace
}  // namespace cityatlas::synth
