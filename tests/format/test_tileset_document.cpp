// SPDX-License-Identifier: GPL-3.0-or-later
// One model of tileset.json: what the writer writes, the document reader
// reads completely (writing it again gives the same bytes), and the reader
// is strict where the client depends on a field and lenient where only
// reports do.
#include <gtest/gtest.h>

#include <sstream>

#include <nlohmann/json.hpp>

#include "format/tileset_document.h"
#include "format/tileset_document_json.h"
#include "tests/render/town_fixture.h"

namespace cityatlas::format {
namespace {
using nlohmann::json;

const std::string& townText() { return render::test::builtTown().text; }

TEST(TilesetDocument, WritingWhatWasReadGivesTheWritersBytes) {
    TilesetDocument doc;
    const Status st = readTilesetDocument(townText(), "tileset.json", &doc);
    ASSERT_TRUE(st.ok()) << st.error;
    ASSERT_EQ(doc.tiles.size(), render::test::builtTown().tree.nodes.size());
    // Every field the writer wrote is in the model: a field the reader
    // skipped would come back as its default and differ here.
    const std::string again = writeTilesetDocument(doc);
    ASSERT_EQ(again.size(), townText().size());
    EXPECT_TRUE(again == townText()) << "the first difference is at byte "
                                     << std::mismatch(again.begin(), again.end(), townText().begin()).first - again.begin();
}

TEST(TilesetDocument, TreeAndTablesAsTheFileGivesThem) {
    TilesetDocument doc;
    ASSERT_TRUE(readTilesetDocument(townText(), "tileset.json", &doc).ok());
    const json j = json::parse(townText());
    const atlas::AtlasTree& tree = render::test::builtTown().tree;
    for (size_t i = 0; i < doc.tiles.size(); ++i) {
        const TileEntry& t = doc.tiles[i];
        EXPECT_EQ(t.id, static_cast<int32_t>(i));
        EXPECT_EQ(t.level, tree.nodes[i].level);
        EXPECT_EQ(t.leaf(), tree.nodes[i].leaf());
        EXPECT_DOUBLE_EQ(t.min_distance_m, tree.nodes[i].min_distance_m);
        for (const int32_t c : t.children) EXPECT_EQ(doc.tiles[static_cast<size_t>(c)].parent, static_cast<int32_t>(i));
        EXPECT_EQ(t.transform.has_value(), i == 0 && j["root"].contains("transform"));
        size_t layers = 0;
        for (const auto& l : t.layers) layers += l ? 1 : 0;
        EXPECT_EQ(t.contents.size(), layers) << "one content per present layer";
    }
    EXPECT_EQ(doc.textures.size(), j["extras"]["cityatlas"]["textures"].size());
    EXPECT_EQ(doc.feature_count, j["extras"]["cityatlas"]["features"]["count"].get<uint64_t>());
    EXPECT_EQ(doc.totals.nodes, doc.tiles.size());
    EXPECT_EQ(doc.build.atlas_size_px, 256);
}

// The fields a non-georeferenced test town leaves null round-trip too.
TEST(TilesetDocument, GeoreferenceAndTransformRoundTrip) {
    TilesetDocument doc;
    ASSERT_TRUE(readTilesetDocument(townText(), "tileset.json", &doc).ok());
    std::array<double, 16> m{};
    for (size_t k = 0; k < 16; ++k) m[k] = 1e6 * static_cast<double>(k) + 0.1 / static_cast<double>(k + 3);
    doc.georeference.local_to_ecef = m;
    doc.georeference.enu_to_ecef = m;
    doc.georeference.source_crs = "EPSG:25832";
    doc.georeference.origin_source = {356000.25, 5645000.5, 41.125};
    doc.georeference.grid_frame = true;
    doc.tiles[0].transform = m;
    TilesetDocument back;
    const std::string text = writeTilesetDocument(doc);
    ASSERT_TRUE(readTilesetDocument(text, "tileset.json", &back).ok());
    EXPECT_EQ(back.georeference.local_to_ecef, m);
    EXPECT_EQ(back.georeference.enu_to_ecef, m);
    EXPECT_EQ(back.tiles[0].transform, m);
    EXPECT_EQ(back.georeference.source_crs, "EPSG:25832");
    EXPECT_EQ(back.georeference.origin_source.y, 5645000.5);
    EXPECT_TRUE(back.georeference.grid_frame);
    EXPECT_EQ(writeTilesetDocument(back), text);
}

// Long dropped lists and the textures are written into the text as it goes
// out (format/json_splice.h): the file must be nlohmann's dump of the whole
// document all the same (the oracle), streamed or as a string.
TEST(TilesetDocument, SplicedListsGiveTheWholeDocumentsDump) {
    TilesetDocument doc;
    ASSERT_TRUE(readTilesetDocument(townText(), "tileset.json", &doc).ok());
    ASSERT_GE(doc.tiles.size(), 2u);
    for (uint32_t k = 0; k < 5000; ++k) doc.tiles[0].features_dropped.push_back(k * 7u + 4000000000u % (k + 1));
    doc.tiles.back().features_dropped = {UINT32_MAX, 0};
    doc.tiles[1].features_dropped.clear();
    const std::string text = writeTilesetDocument(doc);
    EXPECT_EQ(text, json::parse(text).dump(1) + "\n");
    std::ostringstream streamed;
    writeTilesetDocument(doc, streamed);
    EXPECT_EQ(streamed.str(), text);
    TilesetDocument back;
    ASSERT_TRUE(readTilesetDocument(text, "tileset.json", &back).ok());
    EXPECT_EQ(back.tiles[0].features_dropped, doc.tiles[0].features_dropped);
    EXPECT_EQ(back.tiles.back().features_dropped, doc.tiles.back().features_dropped);
    EXPECT_TRUE(back.tiles[1].features_dropped.empty());
}

std::string edited(const std::function<void(json&)>& edit) {
    json j = json::parse(townText());
    edit(j);
    return j.dump();
}

TEST(TilesetDocument, StatisticsMayBeMissingButNotIllTyped) {
    // Missing report-only fields take their defaults.
    TilesetDocument doc;
    const std::string lean = edited([](json& j) {
        json& ca = j["root"]["extras"]["cityatlas"];
        ca.erase("quadrant");
        ca.erase("sharp_from_m");
        ca["layers"]["opaque"].erase("position_bits");
        ca["layers"]["opaque"]["atlas"].erase("psnr_db");
        j["extras"]["cityatlas"].erase("totals");
        j["extras"]["cityatlas"]["build"].erase("packing");
    });
    ASSERT_TRUE(readTilesetDocument(lean, "tileset.json", &doc).ok());
    EXPECT_EQ(doc.tiles[0].quadrant, -1);
    EXPECT_EQ(doc.tiles[0].layers[0]->atlas->psnr_db, 0.0);
    EXPECT_EQ(doc.totals.nodes, 0u);
    // Present but of the wrong type: an error naming the node and the field.
    const std::string bad = edited([](json& j) { j["root"]["extras"]["cityatlas"]["layers"]["opaque"]["atlas"]["psnr_db"] = "high"; });
    const Status st = readTilesetDocument(bad, "http://host/tileset.json", &doc);
    ASSERT_FALSE(st.ok());
    EXPECT_EQ(st.error.rfind("http://host/tileset.json: node 0 layer opaque atlas: \"psnr_db\"", 0), 0u) << st.error;
    EXPECT_TRUE(doc.tiles.empty()) << "a refused document is left empty";
    const std::string flag = edited([](json& j) { j["root"]["extras"]["cityatlas"]["layers"]["opaque"]["simplified"] = 1; });
    EXPECT_FALSE(readTilesetDocument(flag, "tileset.json", &doc).ok());
}

// An atlas BC reproduces exactly has an infinite PSNR, which JSON writes as
// null (tests/cli/exact_atlases.sh builds such a folder).
TEST(TilesetDocument, ExactAtlasIsNullInTheFileAndInfiniteInTheModel) {
    const std::string text = edited([](json& j) { j["root"]["extras"]["cityatlas"]["layers"]["opaque"]["atlas"]["psnr_db"] = nullptr; });
    TilesetDocument doc;
    ASSERT_TRUE(readTilesetDocument(text, "tileset.json", &doc).ok());
    EXPECT_EQ(doc.tiles[0].layers[0]->atlas->psnr_db, std::numeric_limits<double>::infinity());
    const json back = json::parse(writeTilesetDocument(doc));
    EXPECT_TRUE(back["root"]["extras"]["cityatlas"]["layers"]["opaque"]["atlas"]["psnr_db"].is_null());
}

TEST(TilesetDocument, TileEntryReadsOneTileWithoutItsChildren) {
    const json j = json::parse(townText());
    TileEntry t;
    ASSERT_TRUE(readTileEntry(j["root"], "root", &t).ok());
    EXPECT_TRUE(t.children.empty());
    EXPECT_EQ(t.id, 0);
    json broken = j["root"];
    broken["boundingVolume"]["box"].erase(0);
    const Status st = readTileEntry(broken, "/root", &t);
    ASSERT_FALSE(st.ok());
    EXPECT_EQ(st.error, "/root: boundingVolume.box is not 12 numbers");
}

}  // namespace
}  // namespace cityatlas::format
