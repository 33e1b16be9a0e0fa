// SPDX-License-Identifier: GPL-3.0-or-later
// The BlockMap file (format/blockmap_file.h, tiles/blockmap_writer.h): a
// coloured BlockMap of a synthetic town reads back with the same cells,
// columns and buildings, the distance plane computed again, its colours
// within BC1's error; a file cut short anywhere or with any one byte changed
// is refused in one line naming the file (B7); files whose checksum is made
// right again but whose planes disagree are refused by the plane checks.
#include <gtest/gtest.h>

#include <xxhash.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <random>

#include "atlas/blockmap.h"
#include "format/blockmap_file.h"
#include "ingest/synth/town.h"
#include "ingest/synth/write_town.h"
#include "tiles/blockmap_writer.h"
#include "../ingest/test_support.h"

namespace cityatlas::tiles {
namespace {

format::BlockMap townBlockMap() {
    synth::TownSettings s;
    s.buildings = 30;
    s.seed = 3;
    s.texture_size_px = 32;
    const synth::Town town = synth::generateTown(s);
    const auto dir = test::scratchPath("cityatlas_test_blockmap_file", "town");
    EXPECT_TRUE(synth::writeTextures(town, dir, {}).ok());
    const Scene scene = synth::townToScene(town, dir);
    format::BlockMap bm;
    atlas::BlockMapParams p;
    p.cell_m = 2;
    const atlas::SurfaceTables tables{scene.textures, scene.materials};
    EXPECT_TRUE(atlas::buildBlockMap(scene.triangles, p, &bm, &tables).ok());
    return bm;
}

// The checksum made right again after a change (to reach the plane checks).
void reseal(std::vector<uint8_t>* bytes) {
    const uint64_t h = XXH64(bytes->data(), bytes->size() - 8, 0);
    std::memcpy(bytes->data() + bytes->size() - 8, &h, 8);
}

TEST(BlockMapFile, RoundTripsAndComputesTheDistancePlane) {
    const format::BlockMap bm = townBlockMap();
    ASSERT_FALSE(bm.roof.empty());
    const std::vector<uint8_t> bytes = blockMapFileBytes(bm, BcQuality::Fast);
    format::BlockMap back;
    ASSERT_TRUE(format::decodeBlockMapFile(bytes, "town.bin", &back).ok());
    EXPECT_EQ(back.nx, bm.nx);
    EXPECT_EQ(back.ny, bm.ny);
    EXPECT_EQ(back.cell_m, bm.cell_m);
    EXPECT_EQ(back.origin.x, bm.origin.x);
    EXPECT_EQ(back.z_hi, bm.z_hi);
    ASSERT_EQ(back.cells.size(), bm.cells.size());
    for (size_t i = 0; i < bm.cells.size(); ++i) {
        EXPECT_EQ(back.cells[i].top, bm.cells[i].top);
        EXPECT_EQ(back.cells[i].base, bm.cells[i].base);
        EXPECT_EQ(back.cells[i].feature, bm.cells[i].feature);
        EXPECT_EQ(back.cells[i].first_column, bm.cells[i].first_column);
    }
    ASSERT_EQ(back.columns.size(), bm.columns.size());
    for (size_t i = 0; i < bm.columns.size(); ++i) {
        const auto &a = back.columns[i], &b = bm.columns[i];
        EXPECT_TRUE(a.cell == b.cell && a.side == b.side && a.base == b.base && a.rows == b.rows && a.x == b.x && a.y == b.y) << i;
    }
    EXPECT_EQ(back.features, bm.features);
    EXPECT_EQ(back.dist, bm.dist);
    // BC1: each channel within the codec's usual error on these textures.
    ASSERT_EQ(back.roof.size(), bm.roof.size());
    ASSERT_EQ(back.walls.size(), bm.walls.size());
    double se = 0;
    for (size_t i = 0; i < bm.walls.size(); ++i) se += std::pow(back.walls[i] - bm.walls[i], 2);
    const double psnr = 10 * std::log10(255.0 * 255.0 / (se / static_cast<double>(bm.walls.size())));
    EXPECT_GT(psnr, 28) << "walls, dB";
    // Smaller than the planes raw (zstd) plus BC1's 4 bits a texel.
    EXPECT_LT(bytes.size(), bm.cells.size() * 12 / 2 + bm.columns.size() * 14 + bm.roof.size() / 6 + bm.walls.size() / 6 + 200);
    std::printf("%zu cells, %zu columns: %zu bytes; walls %.1f dB\n", bm.cells.size(), bm.columns.size(), bytes.size(), psnr);
    // Without colour: no colour sections, and none read back.
    format::BlockMap plain = bm;
    plain.roof.clear(), plain.walls.clear();
    const std::vector<uint8_t> plain_bytes = blockMapFileBytes(plain, BcQuality::Fast);
    ASSERT_TRUE(format::decodeBlockMapFile(plain_bytes, "plain.bin", &back).ok());
    EXPECT_TRUE(back.roof.empty());
    // CITYATLAS_BLOCKMAP_SEEDS=DIR: both files as the fuzz target's seeds (tests/fuzz/corpus/fuzz_blockmap).
    if (const char* dir = std::getenv("CITYATLAS_BLOCKMAP_SEEDS"))
        for (const auto& [name, b] : {std::pair{"town.bin", &bytes}, std::pair{"plain.bin", &plain_bytes}})
            std::ofstream(std::string(dir) + "/" + name, std::ios::binary)
                .write(reinterpret_cast<const char*>(b->data()), static_cast<std::streamsize>(b->size()));
}

TEST(BlockMapFile, RefusesTruncatedAndDamagedFilesInOneLine) {
    const format::BlockMap bm = townBlockMap();
    const std::vector<uint8_t> good = blockMapFileBytes(bm, BcQuality::Fast);
    format::BlockMap back;
    auto refused = [&](const std::vector<uint8_t>& bytes) {
        const Status s = format::decodeBlockMapFile(bytes, "blockmap/7.bin", &back);
        return !s.ok() && s.code == StatusCode::kInvalidInput && s.error.rfind("blockmap/7.bin: BlockMap: ", 0) == 0 &&
               s.error.find('\n') == std::string::npos;
    };
    for (size_t cut = 0; cut < good.size(); cut += std::max<size_t>(1, good.size() / 97))
        EXPECT_TRUE(refused({good.begin(), good.begin() + static_cast<long>(cut)})) << "cut at " << cut;
    std::mt19937_64 rng(1);
    for (int i = 0; i < 300; ++i) {
        std::vector<uint8_t> bad = good;
        bad[rng() % bad.size()] ^= static_cast<uint8_t>(1u << (rng() % 8));
        EXPECT_TRUE(refused(bad)) << "flip " << i;
    }
    // Resealed damage in the header reaches the field checks.
    std::vector<uint8_t> bad = good;
    const uint32_t huge = 1u << 30;
    std::memcpy(bad.data() + 8, &huge, 4);  // nx
    reseal(&bad);
    EXPECT_TRUE(refused(bad));
    bad = good;
    const double tiny = 1e-300;  // fuzz_blockmap's regress-nan-ray: a cell size that overflows grid coordinates
    std::memcpy(bad.data() + 16, &tiny, 8);
    reseal(&bad);
    EXPECT_TRUE(refused(bad));
    bad = good;
    const double nan = std::nan("");
    std::memcpy(bad.data() + 16, &nan, 8);  // cell_m
    reseal(&bad);
    EXPECT_TRUE(refused(bad));
    // Planes that disagree, written by the encoder itself: a cell naming a building past the list,
    // a column of the wrong side, a column outside the wall image.
    format::BlockMap wrong = bm;
    for (auto& c : wrong.cells)
        if (c.occupied()) {
            c.feature = static_cast<uint32_t>(wrong.features.size());
            break;
        }
    EXPECT_TRUE(refused(blockMapFileBytes(wrong, BcQuality::Fast)));
    wrong = bm;
    wrong.columns[0].side = static_cast<uint8_t>((wrong.columns[0].side + 1) % 4);
    EXPECT_TRUE(refused(blockMapFileBytes(wrong, BcQuality::Fast)));
    wrong = bm;
    wrong.columns.back().y = static_cast<uint16_t>(wrong.wall_height);
    EXPECT_TRUE(refused(blockMapFileBytes(wrong, BcQuality::Fast)));
    EXPECT_TRUE(format::decodeBlockMapFile(good, "ok.bin", &back).ok());
}

}  // namespace
}  // namespace cityatlas::tiles
