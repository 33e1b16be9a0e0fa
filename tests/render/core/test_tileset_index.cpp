// SPDX-License-Identifier: GPL-3.0-or-later
// The client's view of a tile folder written by the tiles stage: every block
// with the size of its file on disk, the tree as the atlas tree built it, the
// build parameters the selection scales by; and clear one-line refusals of
// tilesets the client cannot use.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "atlas/atlas_tree.h"
#include "render/core/tileset_index.h"
#include "tests/ingest/test_support.h"
#include "tests/render/town_fixture.h"
#include "tiles/tileset.h"

namespace cityatlas::render {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;

TEST(TilesetIndex, ReadsABuiltFolder) {
    const test::BuiltTown& t = test::builtTown();
    ASSERT_FALSE(t.text.empty());
    TilesetIndex ix;
    const Status st = parseTilesetIndex(t.text, "tileset.json", &ix);
    ASSERT_TRUE(st.ok()) << st.error;
    EXPECT_EQ(ix.tileset_version, "00112233445566ff");
    ASSERT_EQ(ix.nodes.size(), t.tree.nodes.size());
    EXPECT_EQ(ix.build.atlas_size_px, 256);
    EXPECT_NEAR(ix.build.focal_px, t.tree.projection.focal_px, 1e-9);
    EXPECT_NEAR(ix.build.corner_factor, t.tree.projection.corner_factor, 1e-12);
    uint64_t sum = 0;
    for (const BlockInfo& b : ix.blocks) {
        // Every block is a file of exactly the size the index gives.
        const fs::path p = t.dir / "tiles" / b.uri;
        ASSERT_TRUE(fs::exists(p)) << b.uri;
        EXPECT_EQ(fs::file_size(p), b.bytes) << b.uri;
        sum += b.bytes;
    }
    EXPECT_EQ(ix.bytes_total, sum);
    EXPECT_EQ(ix.bytes_by_kind[0] + ix.bytes_by_kind[1] + ix.bytes_by_kind[2], sum);
    for (size_t i = 0; i < ix.nodes.size(); ++i) {
        const TileNode& n = ix.nodes[i];
        const atlas::AtlasNode& a = t.tree.nodes[i];
        EXPECT_EQ(n.level, a.level) << i;
        EXPECT_DOUBLE_EQ(n.min_distance_m, a.min_distance_m) << i;
        EXPECT_EQ(n.leaf(), a.leaf()) << i;
        // Boxes: the atlas tree's bounds (3D Tiles half axes round-trip through JSON).
        EXPECT_NEAR(n.bounds.min.x, a.bounds.min.x, 1e-9);
        EXPECT_NEAR(n.bounds.max.z, a.bounds.max.z, 1e-9);
        for (const int32_t c : n.children) EXPECT_EQ(ix.nodes[static_cast<size_t>(c)].parent, static_cast<int32_t>(i));
        for (int l = 0; l < kLayerCount; ++l) {
            const NodeLayer& nl = n.layers[static_cast<size_t>(l)];
            EXPECT_EQ(nl.present, a.layers[static_cast<size_t>(l)].range.count > 0) << i;
            if (!nl.present) continue;
            EXPECT_EQ(ix.blocks[nl.geometry].kind, BlockKind::Geometry);
            EXPECT_EQ(ix.blocks[nl.geometry].node, static_cast<int32_t>(i));
            if (nl.atlas != kNoBlock) {
                EXPECT_EQ(ix.blocks[nl.atlas].kind, BlockKind::Atlas);
                EXPECT_EQ(nl.atlas_channels, l == 1 ? 4 : 3);
            }
        }
        if (!n.leaf()) {
            EXPECT_TRUE(n.texture_blocks.empty());
        }
        for (const BlockId b : n.texture_blocks) EXPECT_EQ(ix.blocks[b].kind, BlockKind::Textures);
    }
    // Every texture that was written lies inside its block.
    for (const TextureInfo& tx : ix.textures) {
        if (tx.block < 0) continue;
        EXPECT_LE(tx.offset + tx.bytes, ix.blocks[ix.texture_block_ids[static_cast<size_t>(tx.block)]].bytes);
    }
}

std::string edited(const std::function<void(json&)>& edit) {
    json j = json::parse(test::builtTown().text);
    edit(j);
    return j.dump();
}

TEST(TilesetIndex, RefusesWhatTheClientCannotUse) {
    const struct {
        const char* what;
        std::function<void(json&)> edit;
        const char* expect;
    } cases[] = {
        {"not json", nullptr, "not JSON"},
        {"no root", [](json& j) { j.erase("root"); }, "\"root\" missing"},
        {"format 2", [](json& j) { j["extras"]["cityatlas"]["format_version"] = 2; }, "format_version 2"},
        {"escaping uri",
         [](json& j) { j["root"]["extras"]["cityatlas"]["layers"]["opaque"]["geometry"]["uri"] = "../../etc/passwd"; },
         "not a relative path inside the folder"},
        {"absolute url",
         [](json& j) { j["root"]["extras"]["cityatlas"]["layers"]["opaque"]["atlas"]["uri"] = "http://evil/x.dds"; },
         "not a relative path"},
        {"texture past its block",
         [](json& j) {
             json& t = j["extras"]["cityatlas"]["textures"];
             for (json& e : t)
                 if (e["block"] >= 0) {
                     e["offset"] = 1u << 30;
                     break;
                 }
         },
         "run past the end of texture block"},
        {"box of 11 numbers", [](json& j) { j["root"]["boundingVolume"]["box"].erase(0); }, "12 numbers"},
        {"negative bytes",
         [](json& j) { j["root"]["extras"]["cityatlas"]["layers"]["opaque"]["geometry"]["bytes"] = -5; }, "outside"},
        {"missing texture block",
         [](json& j) {
             // A leaf naming a texture block that does not exist.
             std::function<bool(json&)> leaf = [&](json& t) {
                 if (!t.contains("children")) {
                     t["extras"]["cityatlas"]["texture_blocks"] = json::array({999999});
                     return true;
                 }
                 for (json& c : t["children"])
                     if (leaf(c)) return true;
                 return false;
             };
             leaf(j["root"]);
         },
         "texture block 999999 does not exist"},
    };
    for (const auto& c : cases) {
        const std::string text = c.edit ? edited(c.edit) : std::string("{\"asset\": ");
        TilesetIndex ix;
        const Status st = parseTilesetIndex(text, "http://host/tiles/tileset.json", &ix);
        ASSERT_FALSE(st.ok()) << c.what;
        EXPECT_NE(st.error.find(c.expect), std::string::npos) << c.what << ": " << st.error;
        EXPECT_EQ(st.error.rfind("http://host/tiles/tileset.json: ", 0), 0u) << st.error;
        EXPECT_EQ(st.error.find('\n'), std::string::npos) << "one line: " << st.error;
        EXPECT_TRUE(ix.nodes.empty() && ix.blocks.empty()) << "a refused index is left empty";
    }
}

// Found by fuzz_tileset_json: a number beyond double made json::parse throw
// out_of_range past the parse_error handler (the client aborted on open).
TEST(TilesetIndex, NumberBeyondDoubleIsOneLineNotAnException) {
    for (const char* text : {"77.4E555", R"({"asset": {"version": "1.1"}, "geometricError": 1e999})"}) {
        TilesetIndex ix;
        Status st;
        ASSERT_NO_THROW(st = parseTilesetIndex(text, "http://host/tiles/tileset.json", &ix)) << text;
        ASSERT_FALSE(st.ok()) << text;
        EXPECT_EQ(st.error.rfind("http://host/tiles/tileset.json: not JSON", 0), 0u) << st.error;
        EXPECT_EQ(st.error.find('\n'), std::string::npos) << st.error;
        EXPECT_TRUE(ix.nodes.empty() && ix.blocks.empty());
    }
}

}  // namespace
}  // namespace cityatlas::render
