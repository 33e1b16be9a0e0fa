// SPDX-License-Identifier: GPL-3.0-or-later
// OverlapWatch: inputs that hold the same buildings are named, pairwise;
// inputs that merely touch, or reuse numbered ids elsewhere, are not.
#include "ingest/input_overlap.h"

#include <gtest/gtest.h>

#include <cstdio>

namespace cityatlas {
namespace {

// A building as two triangles covering the box [x, x + w] x [y, y + d].
void addBox(OverlapWatch& w, const std::string& id, double x, double y, double wd = 10, double d = 8) {
    Feature f;
    f.gml_id = id;
    const uint32_t index = w.addFeature(f);
    std::vector<Triangle> t(2);
    t[0].position_local = {Vec3d{x, y, 0}, Vec3d{x + wd, y, 0}, Vec3d{x + wd, y + d, 5}};
    t[1].position_local = {Vec3d{x, y, 0}, Vec3d{x + wd, y + d, 5}, Vec3d{x, y + d, 5}};
    for (Triangle& tri : t) tri.feature = index;
    w.addTriangles(t);
}

// "prefix<i>" (snprintf: GCC 12's -Wrestrict misfires on string + to_string).
std::string id(const char* prefix, int i) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%s%d", prefix, i);
    return buf;
}

struct Fixture {
    SceneCollector scene;
    OverlapWatch watch{scene};
    Diagnostics diagnostics;
};

TEST(InputOverlap, SameFootprintsUnderOtherIdsAreNamed) {
    Fixture f;
    f.watch.beginFile("a.gml");
    for (int i = 0; i < 10; ++i) addBox(f.watch, id("A", i), i * 20.0, 0);
    f.watch.beginFile("b.shp");
    for (int i = 0; i < 10; ++i) addBox(f.watch, id("B", i), i * 20.0 + 0.4, -0.3);  // within 1 m
    f.watch.report(f.diagnostics);
    ASSERT_EQ(f.diagnostics.count("inputs_overlap"), 1u);
    const auto& ex = f.diagnostics.entries().at("inputs_overlap").examples.at(0);
    EXPECT_EQ(ex.file, "b.shp");
    EXPECT_NE(ex.detail.find("a.gml"), std::string::npos) << ex.detail;
    EXPECT_NE(ex.detail.find("10 of its 10"), std::string::npos) << ex.detail;
    // Everything still reaches the sink: the watch warns, it does not choose.
    EXPECT_EQ(f.scene.scene.features.size(), 20u);
    EXPECT_EQ(f.scene.scene.triangles.size(), 40u);
}

TEST(InputOverlap, SameIdsNearbyAreNamedEvenWithOtherGeometry) {
    Fixture f;  // an LOD1 and an LOD2 export of one tile: same ids, footprints a little off
    f.watch.beginFile("lod1.gml");
    for (int i = 0; i < 4; ++i) addBox(f.watch, id("DENW_", i), i * 30.0, 0);
    f.watch.beginFile("lod2.gml");
    for (int i = 0; i < 4; ++i) addBox(f.watch, id("DENW_", i), i * 30.0 + 3, 2, 14, 12);
    f.watch.report(f.diagnostics);
    EXPECT_EQ(f.diagnostics.count("inputs_overlap"), 1u);
}

TEST(InputOverlap, NeighbouringTilesWithNumberedIdsAreNot) {
    Fixture f;
    f.watch.beginFile("tile_1.gml");
    for (int i = 0; i < 10; ++i) addBox(f.watch, id("BLDG_", i), i * 20.0, 0);
    f.watch.beginFile("tile_2.gml");  // 1 km east, same numbering; one building on the shared edge in both
    for (int i = 0; i < 10; ++i) addBox(f.watch, id("BLDG_", i), 1000 + i * 20.0, 0);
    addBox(f.watch, "EDGE", 0, 0);
    f.watch.report(f.diagnostics);
    EXPECT_EQ(f.diagnostics.count("inputs_overlap"), 0u);
}

TEST(InputOverlap, EveryHeavilyOverlappingPairIsNamed) {
    Fixture f;
    for (const char* file : {"x.gml", "y.gml", "z.gml"}) {
        f.watch.beginFile(file);
        for (int i = 0; i < 6; ++i) {
            addBox(f.watch, id(file, i), i * 20.0, 0);
        }
    }
    f.watch.report(f.diagnostics);
    EXPECT_EQ(f.diagnostics.count("inputs_overlap"), 3u);  // (x,y) (x,z) (y,z)
}

TEST(InputOverlap, BuildingPartsCountWithTheirBuilding) {
    Fixture f;
    f.watch.beginFile("parts.gml");
    Feature parent;
    parent.gml_id = "P";
    const uint32_t p = f.watch.addFeature(parent);
    for (int k = 0; k < 2; ++k) {  // two parts side by side make one 20 x 8 building
        Feature part;
        part.gml_id = id("P_part", k);
        part.parent = static_cast<int32_t>(p);
        const uint32_t index = f.watch.addFeature(part);
        std::vector<Triangle> t(1);
        t[0].position_local = {Vec3d{k * 10.0, 0, 0}, Vec3d{k * 10.0 + 10, 0, 0}, Vec3d{k * 10.0 + 10, 8, 0}};
        t[0].feature = index;
        f.watch.addTriangles(t);
    }
    f.watch.beginFile("whole.shp");
    addBox(f.watch, "W", 0, 0, 20, 8);
    f.watch.report(f.diagnostics);
    EXPECT_EQ(f.diagnostics.count("inputs_overlap"), 1u);
}

}  // namespace
}  // namespace cityatlas
