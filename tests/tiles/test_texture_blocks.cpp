// SPDX-License-Identifier: GPL-3.0-or-later
// What the merge keeps of a city's textures (tiles/texture_blocks.h): 12
// bytes a texture in memory, and the written entries in a scratch file, read
// back a chunk at a time. The towns of test_tileset have a few hundred
// textures, one chunk; here there are several, with holes (exact and
// unreadable textures) inside chunks, at a chunk's end and at the table's end,
// read in tileset order (as tileset.json is written) and in random order.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <random>
#include <string>

#include "tiles/texture_blocks.h"

namespace cityatlas::tiles {
namespace {
namespace fs = std::filesystem;

// n whole textures (none split), each its own tileset texture; every
// `every`-th one before `written_until` written (block t / 100), the others
// exact or unreadable. `truth`: what was written, by tileset number.
struct Written {
    TextureTable table;
    TextureBlocks blocks;
    std::vector<WrittenTexture> truth;  // bytes == 0: not written
};

void makeBlocks(size_t n, size_t every, size_t written_until, Written* w) {
    for (size_t t = 0; t < n; ++t)
        w->table.push_back({"tex/" + std::to_string(t) + ".png", 64 + static_cast<int>(t % 7), 32, t % 3 ? 3 : 4,
                            WrapMode::Wrap});
    TextureBlocks& b = w->blocks;
    b.atlas_size_px = 1024;
    b.written = RecordFile<WrittenTexture>(fs::temp_directory_path(), "test textures");
    w->truth.assign(n, {});
    for (size_t t = 0; t < n; ++t) {
        b.texture_index.push_back(static_cast<int32_t>(t));
        b.scene_texture.push_back(static_cast<int32_t>(t));
        const bool written = t % every == 0 && t < written_until;
        b.block.push_back(written ? static_cast<int32_t>(t / 100) : t % 2 ? TextureBlocks::kExact : TextureBlocks::kUnreadable);
        if (!written) continue;
        WrittenTexture& r = w->truth[t];
        r.offset = t * 1000, r.bytes = 500 + t;
        r.width = static_cast<int32_t>(t % 5000) + 1, r.height = 7, r.mips = static_cast<int32_t>(t % 9) + 1;
        ASSERT_TRUE(b.written.write(t, &r, 1).ok());
    }
}

void expectEntry(const Written& w, size_t t, const TextureEntry& e) {
    const TextureInfo& info = w.table[t];
    const WrittenTexture& r = w.truth[t];
    EXPECT_EQ(e.scene_texture, static_cast<int32_t>(t));
    EXPECT_EQ(e.tile, -1);
    EXPECT_EQ(e.channels, info.channels == 4 ? 4 : 3);
    if (r.bytes == 0) {
        // Not written: the size recorded at ingest, no place in a block.
        EXPECT_EQ(e.block, -1) << t;
        EXPECT_EQ(e.exact, w.blocks.block[t] == TextureBlocks::kExact) << t;
        EXPECT_EQ(e.width, info.width_px) << t;
        EXPECT_EQ(e.offset, 0u) << t;
        return;
    }
    EXPECT_EQ(e.block, static_cast<int32_t>(t / 100)) << t;
    EXPECT_FALSE(e.exact);
    EXPECT_EQ(e.offset, r.offset) << t;
    EXPECT_EQ(e.bytes, r.bytes) << t;
    EXPECT_EQ(e.width, r.width) << t;  // the encoded size, not the ingest's
    EXPECT_EQ(e.height, r.height) << t;
    EXPECT_EQ(e.mips, r.mips) << t;
}

TEST(TextureBlocks, WrittenEntriesReadBackInTilesetOrderAcrossChunks) {
    // 10,000 textures: chunks of 4,096; every third written up to 9,000, so
    // the last chunk ends in holes and chunk borders fall on holes and on
    // written ones.
    Written w;
    makeBlocks(10000, 3, 9000, &w);
    ASSERT_FALSE(HasFailure());
    for (size_t t = 0; t < w.blocks.size(); ++t) expectEntry(w, t, w.blocks.entry(w.table, t));
    EXPECT_TRUE(w.blocks.written.status().ok()) << w.blocks.written.status().error;
}

TEST(TextureBlocks, WrittenEntriesReadBackInAnyOrder) {
    Written w;
    makeBlocks(9001, 2, 9001, &w);  // the last texture written, alone in its chunk
    ASSERT_FALSE(HasFailure());
    std::vector<size_t> order(w.blocks.size());
    for (size_t t = 0; t < order.size(); ++t) order[t] = t;
    std::shuffle(order.begin(), order.end(), std::mt19937(7));
    for (const size_t t : order) expectEntry(w, t, w.blocks.entry(w.table, t));
    EXPECT_TRUE(w.blocks.written.status().ok()) << w.blocks.written.status().error;
}

TEST(TextureBlocks, NothingWrittenNeedsNoScratchFile) {
    Written w;
    makeBlocks(5000, 1, 0, &w);
    for (size_t t = 0; t < w.blocks.size(); ++t) expectEntry(w, t, w.blocks.entry(w.table, t));
    EXPECT_TRUE(w.blocks.written.status().ok()) << w.blocks.written.status().error;
}

TEST(TextureBlocks, AnEntryThatCannotBeWrittenIsAnError) {
    Written w;
    makeBlocks(100, 1, 0, &w);
    w.blocks.block.set(42, 0);
    // Nothing in the file: record 42 reads as a hole, with no offset.
    EXPECT_EQ(w.blocks.entry(w.table, 42).bytes, 0u);
    // A file that cannot be made: the error names what it was for.
    w.blocks.written = RecordFile<WrittenTexture>("/nonexistent/folder", "the written textures' entries");
    const WrittenTexture r{1, 2, 3, 4, 5, 0};
    EXPECT_FALSE(w.blocks.written.write(42, &r, 1).ok());
    const TextureEntry e = w.blocks.entry(w.table, 42);
    EXPECT_FALSE(w.blocks.written.status().ok());
    EXPECT_NE(w.blocks.written.status().error.find("written textures"), std::string::npos) << w.blocks.written.status().error;
    EXPECT_EQ(e.offset, 0u);
}

TEST(TextureBlocks, PlannedTilesOfASplitTexture) {
    // A 3000 x 1000 texture with 1024-texel atlases splits into 3 x 1 tiles
    // (texture_tiles.h): four tileset textures, the whole first.
    Written w;
    w.table.push_back({"small.png", 64, 64, 3, WrapMode::Wrap});
    w.table.push_back({"ortho.png", 3000, 1000, 3, WrapMode::Clamp});
    TextureBlocks& b = w.blocks;
    b.atlas_size_px = 1024;
    b.split = true;
    std::vector<uint8_t> used{1, 1};
    b.texture_index = tilesetTextureIndex(used, w.table, 1024, true);
    const std::vector<TexelRect> tiles = tilesetEntries(w.table[1], 1024, true);
    ASSERT_EQ(tiles.size(), 4u);
    ASSERT_EQ(b.texture_index.size(), 2u);
    ASSERT_EQ(b.texture_index[0], 0);
    ASSERT_EQ(b.texture_index[1], 1);
    for (const int32_t st : {0, 1, 1, 1, 1}) b.scene_texture.push_back(st), b.block.push_back(TextureBlocks::kExact);
    for (size_t k = 0; k < 4; ++k) {
        const TextureEntry e = b.planned(w.table, 1 + k);
        EXPECT_EQ(e.scene_texture, 1);
        EXPECT_EQ(e.tile, static_cast<int32_t>(k) - 1);
        if (k == 0) {
            EXPECT_EQ(e.width, 3000);
            EXPECT_EQ(e.wrap, WrapMode::Clamp);
            continue;
        }
        EXPECT_EQ(e.tile_rect.x0, tiles[k].x0);
        EXPECT_EQ(e.tile_rect.x1, tiles[k].x1);
        EXPECT_EQ(e.width, tiles[k].width());
        EXPECT_EQ(e.height, tiles[k].height());
        EXPECT_EQ(e.wrap, WrapMode::Clamp);  // a tile is sampled clamped
    }
}

}  // namespace
}  // namespace cityatlas::tiles
