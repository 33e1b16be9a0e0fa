// SPDX-License-Identifier: GPL-3.0-or-later
// build --blockmaps complement in-process (tiles/node_blockmaps.h): which
// nodes get a BlockMap, what the root's holds (B5: every building its
// geometry leaves out), what tileset.json says of them, and inspect (B7).
#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <gtest/gtest.h>

#include "format/blockmap_file.h"
#include "format/tileset_document.h"
#include "tests/tiles/built_town.h"
#include "tiles/inspect.h"
#include "tiles/node_blockmaps.h"

namespace cityatlas::tiles {
namespace {

TEST(BlockMapRule, PaysWhenNoLargerThanTheNodeOrTheNodeDroppedBuildings) {
    EXPECT_TRUE(blockMapPays(100, {200, false}));
    EXPECT_TRUE(blockMapPays(200, {200, false}));
    EXPECT_FALSE(blockMapPays(201, {200, false}));
    EXPECT_TRUE(blockMapPays(5000, {200, true}));
}

struct Decoded {
    format::BlockMapEntry entry;
    format::BlockMap bm;
};

class BuiltBlockMaps : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        // A small node budget: the upper nodes leave sub-texel buildings out.
        TilesParams p;
        p.threads = 2;
        p.node_triangles = 300;
        p.blockmaps = BlockMapMode::Complement;
        built_ = buildTown("blockmaps", 60, {}, p, 100).release();
        std::ifstream f(built_->dir / "tiles" / "tileset.json");
        std::stringstream text;
        text << f.rdbuf();
        text_ = new std::string(text.str());
        doc_ = new format::TilesetDocument;
        ASSERT_TRUE(format::readTilesetDocument(*text_, "tileset.json", doc_).ok());
    }
    static void TearDownTestSuite() {
        delete built_;
        delete text_;
        delete doc_;
    }
    static Decoded decode(const format::TileEntry& t) {
        Decoded d;
        d.entry = *t.blockmap;
        const std::vector<uint8_t> bytes = readFile(built_->dir / "tiles" / d.entry.file.uri);
        const Status s = format::decodeBlockMapFile(bytes, d.entry.file.uri, &d.bm);
        EXPECT_TRUE(s.ok()) << s.error;
        return d;
    }
    static Built* built_;
    static std::string* text_;
    static format::TilesetDocument* doc_;
};
Built* BuiltBlockMaps::built_ = nullptr;
std::string* BuiltBlockMaps::text_ = nullptr;
format::TilesetDocument* BuiltBlockMaps::doc_ = nullptr;

// B5: the root's BlockMap holds every building its geometry dropped; one it
// does not hold (listed as missing) has no free cell under its box's centre.
TEST_F(BuiltBlockMaps, RootHoldsTheBuildingsItsGeometryDrops) {
    const format::TileEntry& root = doc_->tiles[0];
    ASSERT_TRUE(root.blockmap) << "no BlockMap at the root";
    ASSERT_FALSE(root.features_dropped.empty()) << "the test needs a root that drops buildings";
    const Decoded d = decode(root);
    const std::set<uint32_t> held(d.bm.features.begin(), d.bm.features.end());
    std::map<uint32_t, Box3d> box;
    for (const atlas::TreeTriangle& t : built_->tree.triangles)
        for (const Vec3d& q : t.tri.position_local) box[t.tri.feature].extend(q);
    size_t present = 0;
    for (const uint32_t f : root.features_dropped) {
        if (held.count(f)) {
            ++present;
            continue;
        }
        const Box3d& b = box[f];
        const int x = static_cast<int>(std::floor((0.5 * (b.min.x + b.max.x) - d.bm.origin.x) / d.bm.cell_m));
        const int y = static_cast<int>(std::floor((0.5 * (b.min.y + b.max.y) - d.bm.origin.y) / d.bm.cell_m));
        ASSERT_TRUE(d.bm.inside(x, y));
        const format::BlockMapCell& c = d.bm.cells[d.bm.index(x, y)];
        ASSERT_TRUE(c.occupied()) << "dropped feature " << f << " is missing though its cell is free";
        EXPECT_NE(d.bm.features[c.feature], f);
    }
    std::set<uint32_t> listed(d.entry.features_missing.begin(), d.entry.features_missing.end());
    for (const uint32_t f : root.features_dropped) EXPECT_EQ(held.count(f) + listed.count(f), 1u) << f;
    EXPECT_EQ(d.entry.features, held.size());
    std::printf("root: %zu buildings dropped by its geometry, %zu of them in its BlockMap (%d x %d cells of %.2f m), "
                "%zu missing\n",
                root.features_dropped.size(), present, d.bm.nx, d.bm.ny, d.bm.cell_m, d.entry.features_missing.size());
    EXPECT_GE(present * 10, root.features_dropped.size() * 9) << "fewer than 90 % of the dropped buildings kept";
}

// The rule, top-down: a node has a BlockMap only below a node that has one,
// down to the level cap (kDefaultBlockMapLevels); each is no larger than its
// node or its node dropped buildings; the stats account for every node
// tried, level by level.
TEST_F(BuiltBlockMaps, NodesFollowTheRuleTopDown) {
    const NodeBlockMapStats& s = built_->stats.blockmaps;
    EXPECT_EQ(s.tried, s.built + s.declined_bytes + s.declined_grid);
    std::vector<int> level(doc_->tiles.size(), 0);
    for (const format::TileEntry& t : doc_->tiles)  // preorder: the parent first
        if (t.parent >= 0) level[static_cast<size_t>(t.id)] = level[static_cast<size_t>(t.parent)] + 1;
    ASSERT_GT(*std::max_element(level.begin(), level.end()), kDefaultBlockMapLevels) << "the town does not test the cap";
    uint64_t built = 0, bytes = 0, tried = 1;
    std::vector<BlockMapLevelStats> by_level(s.levels.size());
    if (!by_level.empty()) by_level[0].tried = 1;
    for (const format::TileEntry& t : doc_->tiles) {
        if (!t.blockmap) continue;
        const int l = level[static_cast<size_t>(t.id)];
        EXPECT_LE(l, kDefaultBlockMapLevels) << "node " << t.id;
        ++built;
        bytes += t.blockmap->file.bytes;
        if (static_cast<size_t>(l) < by_level.size()) {
            ++by_level[static_cast<size_t>(l)].built;
            by_level[static_cast<size_t>(l)].bytes += t.blockmap->file.bytes;
            by_level[static_cast<size_t>(l)].node_bytes += t.bytes;
        }
        if (l < kDefaultBlockMapLevels) {
            tried += t.children.size();
            if (static_cast<size_t>(l + 1) < by_level.size()) by_level[static_cast<size_t>(l + 1)].tried += t.children.size();
        }
        if (t.parent >= 0) {
            EXPECT_TRUE(doc_->tiles[static_cast<size_t>(t.parent)].blockmap) << "node " << t.id;
        }
        EXPECT_TRUE(t.blockmap->file.bytes <= t.bytes || !t.features_dropped.empty()) << "node " << t.id;
        EXPECT_DOUBLE_EQ(t.blockmap->min_distance_m, t.min_distance_m);
        EXPECT_DOUBLE_EQ(t.blockmap->texel_m, t.world_texel_m);
        // The voxel bound: half the diagonal of a cell and a height quantum.
        const double q = (t.blockmap->z_top_m - t.blockmap->origin.z) / 65535.0;
        EXPECT_NEAR(t.blockmap->voxel_bound_m, 0.5 * std::sqrt(2 * t.world_texel_m * t.world_texel_m + q * q), 1e-12);
        EXPECT_GT(t.blockmap->hausdorff_m, 0.0);
        const Decoded d = decode(t);
        EXPECT_EQ(t.blockmap->gpu_bytes, d.bm.gpuBytes(true));
        EXPECT_FALSE(d.bm.roof.empty()) << "no colour planes";
    }
    EXPECT_EQ(built, s.built);
    EXPECT_EQ(tried, s.tried);
    ASSERT_LE(s.levels.size(), static_cast<size_t>(kDefaultBlockMapLevels + 1));
    for (size_t l = 0; l < s.levels.size(); ++l) {
        EXPECT_EQ(s.levels[l].tried, by_level[l].tried) << "level " << l;
        EXPECT_EQ(s.levels[l].built, by_level[l].built) << "level " << l;
        EXPECT_EQ(s.levels[l].bytes, by_level[l].bytes) << "level " << l;
        EXPECT_EQ(s.levels[l].node_bytes, by_level[l].node_bytes) << "level " << l;
    }
    EXPECT_EQ(bytes, s.bytes);
    EXPECT_EQ(doc_->totals.bytes_blockmaps, s.bytes);
    EXPECT_EQ(doc_->build.blockmaps, "complement");
    std::printf("%llu BlockMaps of %llu nodes tried (%llu larger than their node), %llu bytes\n",
                static_cast<unsigned long long>(s.built), static_cast<unsigned long long>(s.tried),
                static_cast<unsigned long long>(s.declined_bytes), static_cast<unsigned long long>(s.bytes));
}

// The index's reader and writer agree on the new entries (the round trip is
// the identity on the writer's text), and inspect passes the folder.
TEST_F(BuiltBlockMaps, TilesetRoundTripsAndInspectPasses) {
    EXPECT_EQ(format::writeTilesetDocument(*doc_), *text_);
    const InspectResult r = inspectTileFolder(built_->dir / "tiles", 2);
    for (const std::string& d : r.defects) ADD_FAILURE() << d;
    EXPECT_EQ(r.blockmap_files, built_->stats.blockmaps.built);
}

// B7 through inspect: an entry that disagrees with its file is a defect naming the file.
TEST_F(BuiltBlockMaps, InspectFindsAnEntryThatDisagreesWithItsFile) {
    const fs::path copy = built_->dir / "tampered";
    fs::remove_all(copy);
    fs::copy(built_->dir / "tiles", copy, fs::copy_options::recursive);
    format::TilesetDocument doc = *doc_;
    doc.tiles[0].blockmap->columns += 1;
    doc.tiles[0].blockmap->features_missing.clear();
    std::ofstream(copy / "tileset.json", std::ios::binary) << format::writeTilesetDocument(doc);
    const InspectResult r = inspectTileFolder(copy, 2);
    ASSERT_FALSE(r.ok());
    bool named = false;
    for (const std::string& d : r.defects) named |= d.find("blockmap/0.bin") != std::string::npos;
    EXPECT_TRUE(named) << r.defects.front();
}

}  // namespace
}  // namespace cityatlas::tiles
