// SPDX-License-Identifier: GPL-3.0-or-later
// CityGML as real producers write it (tests/data/citygml_quirks): every file
// is the 12-triangle box of citygml_broken/valid_box.gml written one
// producer's way, and must read to the same box, with exactly the warnings
// EXPECTED.tsv lists.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>

#include "ingest/citygml/citygml_reader.h"
#include "ingest/scene_sink.h"
#include "read_citygml.h"
#include "test_support.h"

namespace cityatlas {
namespace {
namespace fs = std::filesystem;

fs::path corpus() {
    const char* data = std::getenv("CITYATLAS_TEST_DATA");
    return fs::path(data ? data : "tests/data") / "citygml_quirks";
}

std::unique_ptr<test::Ingested> read(const fs::path& file) { return test::ingest(file); }

struct Row {
    std::string file;
    size_t triangles = 0;
    std::set<std::string> warnings;
    std::string version;
};

std::vector<Row> expected() {
    std::ifstream in(corpus() / "EXPECTED.tsv");
    std::vector<Row> rows;
    std::string line;
    std::getline(in, line);  // header
    while (std::getline(in, line)) {
        std::istringstream fields(line);
        Row r;
        std::string triangles, warnings;
        std::getline(fields, r.file, '\t');
        std::getline(fields, triangles, '\t');
        std::getline(fields, warnings, '\t');
        std::getline(fields, r.version, '\t');
        r.triangles = std::stoul(triangles);
        std::istringstream codes(warnings);
        for (std::string c; std::getline(codes, c, ',');)
            if (c != "-") r.warnings.insert(c);
        rows.push_back(r);
    }
    return rows;
}

TEST(CityGmlQuirks, EveryFileReadsToTheBoxWithExactlyItsWarnings) {
    const auto rows = expected();
    ASSERT_GE(rows.size(), 13u) << "corpus table missing or short: " << (corpus() / "EXPECTED.tsv");
    std::set<std::string> listed;
    for (const Row& row : rows) {
        SCOPED_TRACE(row.file);
        listed.insert(row.file);
        const auto r = read(corpus() / row.file);
        ASSERT_TRUE(r->status.ok()) << r->status.error;
        EXPECT_EQ(r->scene.triangles.size(), row.triangles);
        EXPECT_EQ(r->scene.features.size(), 1u);
        std::set<std::string> got;
        for (const auto& [code, entry] : r->state.diagnostics.entries()) got.insert(code);
        EXPECT_EQ(got, row.warnings);
        ASSERT_EQ(r->state.files.size(), 1u);
        EXPECT_EQ(r->state.files[0].citygml_version, row.version);
        // The box lies where valid_box.gml puts it, whatever the encoding.
        Box3d box;
        for (const Triangle& t : r->scene.triangles)
            for (const Vec3d& p : t.position_local) box.extend(p);
        EXPECT_NEAR(box.max.x - box.min.x, 10.0, 1e-9);
        EXPECT_NEAR(box.max.y - box.min.y, 8.0, 1e-9);
        EXPECT_NEAR(box.max.z - box.min.z, 6.0, 1e-9);
    }
    // Every fixture is in the table.
    for (const auto& e : fs::directory_iterator(corpus()))
        if (e.path().extension() == ".gml") {
            EXPECT_TRUE(listed.count(e.path().filename().string())) << e.path();
        }
}

TEST(CityGmlQuirks, EncodingsGiveTheSameUtf8Name) {
    for (const char* f : {"utf8_bom.gml", "utf16le_bom.gml", "latin1_encoding.gml"}) {
        SCOPED_TRACE(f);
        const auto r = read(corpus() / f);
        ASSERT_TRUE(r->status.ok()) << r->status.error;
        ASSERT_EQ(r->scene.features.size(), 1u);
        EXPECT_EQ(r->scene.features[0].name, "B\xc3\xbcrohaus Nord");
    }
}

TEST(CityGmlQuirks, AdeContentIsNeitherGeometryNorAttributes) {
    const auto r = read(corpus() / "ade_inside_building.gml");
    ASSERT_TRUE(r->status.ok()) << r->status.error;
    ASSERT_EQ(r->scene.features.size(), 1u);
    const auto& attributes = r->scene.features[0].attributes;
    EXPECT_EQ(attributes.count("ade_key"), 0u) << "an ADE element named *Attribute is not a generic attribute";
    ASSERT_EQ(attributes.count("kept"), 1u);
    EXPECT_EQ(attributes.at("kept"), "yes");
    // Three ADE elements: qualityAttribute, energyVolume (with a polygon 100 m away), uValue in a wall.
    EXPECT_EQ(r->state.diagnostics.count("ade_ignored"), 3u);
}

TEST(CityGmlQuirks, RootInAForeignNamespaceIsStillRefused) {
    // The no-namespace CityModel is accepted; a CityModel in a namespace that
    // is not CityGML's is not a CityGML file.
    const fs::path f = fs::temp_directory_path() / ("cityatlas_quirk_foreign_" + std::to_string(::getpid()) + ".gml");
    std::ofstream(f) << "<?xml version=\"1.0\"?><CityModel xmlns=\"http://example.org/not-citygml\"/>";
    const auto r = read(f);
    EXPECT_FALSE(r->status.ok());
    EXPECT_NE(r->status.error.find("not_citygml"), std::string::npos) << r->status.error;
    fs::remove(f);
}

}  // namespace
}  // namespace cityatlas
