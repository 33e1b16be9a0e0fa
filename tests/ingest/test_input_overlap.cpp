// SPDX-License-Identifier: GPL-3.0-or-later
// OverlapWatch: inputs that hold the same buildings are named, pairwise;
// inputs that merely touch, or reuse numbered ids elsewhere, are not.
#include "ingest/input_overlap.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <string>
#include <vector>

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

// A county in 7 files, written through the watch twice: with its defaults
// (everything in memory) and with a window of 3 buildings and sorts of one
// record (every record and every sort through scratch files). Both name the
// pairs a brute-force count over every pair of buildings names, with the
// same numbers: footprint copies (0, 1), id copies with other geometry
// (2, 3), numbered ids repeated far away (4: none), copies of too few
// (5 of 0 and of 1, 6 of 0: none), building parts, and buildings without
// geometry.
TEST(InputOverlap, ThroughScratchFilesTheSamePairsAsABruteForceCount) {
    struct Box {
        std::string id;
        uint32_t file;
        double x, y, w, d;
        bool geometry = true;
    };
    std::vector<Box> boxes;
    uint32_t seed = 12345;
    auto rnd = [&] { return (seed = seed * 1103515245u + 12345u) >> 8; };
    const auto jitter = [&](double m) { return (static_cast<double>(rnd() % 2001) / 1000.0 - 1.0) * m; };
    for (int i = 0; i < 150; ++i)  // file 0: a grid of houses
        boxes.push_back({id("A", i), 0, (i % 15) * 25.0 + jitter(3), (i / 15) * 25.0 + jitter(3), 10 + jitter(2), 8});
    for (int i = 0; i < 150; ++i) {  // file 1: 70 % of them again, within the tolerance, under other ids
        const Box& a = boxes[static_cast<size_t>(i)];
        if (i % 10 < 7) boxes.push_back({id("B", i), 1, a.x + jitter(0.45), a.y + jitter(0.45), a.w, a.d});
    }
    for (int i = 0; i < 60; ++i)  // file 2: an LOD1 tile elsewhere
        boxes.push_back({id("DENW_", i), 2, 2000 + (i % 10) * 30.0, (i / 10) * 30.0, 12, 10});
    for (int i = 0; i < 60; ++i)  // file 3: its LOD2, same ids, footprints a few metres off
        boxes.push_back({id("DENW_", i), 3, 2003 + (i % 10) * 30.0, 2 + (i / 10) * 30.0, 14, 12});
    for (int i = 0; i < 40; ++i)  // file 4: numbered ids that file 2 also uses, 5 km away
        boxes.push_back({id("DENW_", i), 4, 7000 + i * 20.0, 0, 10, 8});
    for (int i = 0; i < 100; ++i) {  // file 5: 20 of its 100 are file 0's (and 1's): not heavily
        if (i < 20) {
            const Box& a = boxes[static_cast<size_t>(5 * i)];
            boxes.push_back({id("C", i), 5, a.x, a.y, a.w, a.d});
        } else {
            boxes.push_back({id("C", i), 5, 4000 + i * 20.0, 500, 10, 8});
        }
    }
    for (int i = 0; i < 5; ++i)  // file 6: no geometry at all, and a copy of file 0's first house
        boxes.push_back({id("E", i), 6, 0, 0, 0, 0, false});
    boxes.push_back({"E_copy", 6, boxes[0].x, boxes[0].y, boxes[0].w, boxes[0].d});

    // The brute force: every pair of buildings, as input_overlap.h defines a match.
    std::map<std::pair<uint32_t, uint32_t>, std::pair<uint64_t, uint64_t>> pairs;  // (by id, by footprint)
    std::vector<uint64_t> per_file(7, 0);
    auto fl = [](double v) { return static_cast<double>(static_cast<float>(v)); };
    for (size_t i = 0; i < boxes.size(); ++i) {
        const Box& b = boxes[i];
        ++per_file[b.file];
        std::set<uint32_t> matched;
        size_t first_same_id = i;
        for (size_t j = 0; j < i; ++j)
            if (boxes[j].id == b.id) {
                first_same_id = j;
                break;
            }
        const Box& o = boxes[first_same_id];
        if (first_same_id < i && o.file != b.file && o.geometry && b.geometry) {
            const double dx = (fl(o.x) + fl(o.x + o.w) - fl(b.x) - fl(b.x + b.w)) / 2,
                         dy = (fl(o.y) + fl(o.y + o.d) - fl(b.y) - fl(b.y + b.d)) / 2;
            if (dx * dx + dy * dy <= 50.0 * 50.0) pairs[{o.file, b.file}].first++;
        }
        if (!b.geometry) continue;
        for (size_t j = 0; j < i; ++j) {
            const Box& c = boxes[j];
            if (!c.geometry || c.file == b.file || matched.count(c.file)) continue;
            const auto within = [&](double u, double v) { return std::abs(fl(u) - fl(v)) <= kOverlapTolerance_m; };
            if (within(c.x, b.x) && within(c.x + c.w, b.x + b.w) && within(c.y, b.y) && within(c.y + c.d, b.y + b.d)) {
                pairs[{c.file, b.file}].second++;
                matched.insert(c.file);
            }
        }
    }
    std::set<std::string> expected;
    const char* names[] = {"f0.gml", "f1.shp", "f2.gml", "f3.gml", "f4.gml", "f5.gml", "f6.gml"};
    for (const auto& [p, n] : pairs) {
        const uint64_t shared = std::max(n.first, n.second);
        if (static_cast<double>(shared) < kOverlapShare * static_cast<double>(std::min(per_file[p.first], per_file[p.second])))
            continue;
        expected.insert(std::string(names[p.second]) + ": " + std::to_string(shared) + " of its " +
                        std::to_string(per_file[p.second]) + " buildings are also in " + names[p.first] + " (" +
                        std::to_string(n.first) + " by gml:id, " + std::to_string(n.second) + " by footprint");
    }
    ASSERT_EQ(expected.size(), 2u) << "the county should overlap as (0, 1) and (2, 3)";

    for (const bool through_files : {false, true}) {
        SceneCollector scene;
        OverlapWatch watch = through_files ? OverlapWatch(scene, {}, 3, 1) : OverlapWatch(scene);
        Diagnostics diagnostics(20);
        uint32_t file = 99;
        for (const Box& b : boxes) {
            if (b.file != file) watch.beginFile(names[file = b.file]);
            if (!b.geometry) {
                Feature f;
                f.gml_id = b.id;
                watch.addFeature(f);
                continue;
            }
            // A house of two parts (its parent first), as CityGML's building parts come.
            Feature parent;
            parent.gml_id = b.id;
            const uint32_t p = watch.addFeature(parent);
            for (int k = 0; k < 2; ++k) {
                Feature part;
                part.gml_id = b.id + "_part";
                part.parent = static_cast<int32_t>(p);
                const uint32_t index = watch.addFeature(part);
                std::vector<Triangle> t(1);
                const double x0 = b.x + k * b.w / 2, x1 = b.x + (k + 1) * b.w / 2;
                t[0].position_local = {Vec3d{x0, b.y, 0}, Vec3d{x1, b.y, 0}, Vec3d{k ? x1 : x0, b.y + b.d, 3}};
                t[0].feature = index;
                watch.addTriangles(t);
            }
        }
        ASSERT_TRUE(watch.report(diagnostics).ok());
        std::set<std::string> named;
        if (diagnostics.entries().count("inputs_overlap"))
            for (const auto& ex : diagnostics.entries().at("inputs_overlap").examples)
                named.insert(ex.file + ": " + ex.detail.substr(0, ex.detail.find(" within")));
        EXPECT_EQ(named, expected) << (through_files ? "through scratch files" : "in memory");
    }
}

}  // namespace
}  // namespace cityatlas
