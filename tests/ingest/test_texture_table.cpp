// SPDX-License-Identifier: GPL-3.0-or-later
// The scene's texture table (ingest/texture_table.h): every path and field
// comes back as added, whatever the folder, across its name chunks and after
// set(); firstOfPath finds repeated paths exactly; and a city's table costs a
// fraction of what the vector of TextureRefs it replaced did.
#include "ingest/texture_table.h"

#include <gtest/gtest.h>

#include <map>
#include <random>
#include <string>
#include <vector>

namespace cityatlas {
namespace {

std::vector<TextureRef> samples() {
    return {
        {"/data/berlin/3890_5819_appearance/tex0001.jpg", 512, 256, 3, WrapMode::Wrap},
        {"/data/berlin/3890_5819_appearance/tex0002.png", 33, 17, 4, WrapMode::Clamp},
        {"relative/one.png", 1, 1, 3, WrapMode::None},
        {"no_folder.jpg", 7, 9, 3, WrapMode::Mirror},
        {"", 0, 0, 0, WrapMode::Border},                                  // no path at all
        {"/", 2, 2, 3, WrapMode::Wrap},                                   // a folder, no name
        {"/data/berlin/3890_5819_appearance/tex0001.jpg", 512, 256, 3, WrapMode::Clamp},  // same path, other wrap
        {"/data/other/tex0001.jpg", 64, 64, 3, WrapMode::Wrap},           // same name, other folder
        {"/data/berlin/" + std::string(3u << 20, 'x') + ".png", 8, 8, 4, WrapMode::Wrap},  // longer than a chunk
        {"/data/berlin/3890_5819_appearance/after_the_long_one.jpg", 5, 6, 3, WrapMode::Wrap},
    };
}

void expectSame(const TextureTable& table, size_t i, const TextureRef& want) {
    const TextureRef got = table.ref(i);
    EXPECT_EQ(got.path, want.path) << i;
    EXPECT_EQ(table.path(i), want.path) << i;
    EXPECT_EQ(got.width_px, want.width_px) << i;
    EXPECT_EQ(table[i].height_px, want.height_px) << i;
    EXPECT_EQ(table[i].channels, want.channels) << i;
    EXPECT_EQ(table[i].wrap, want.wrap) << i;
}

TEST(TextureTable, EveryEntryComesBackAsAdded) {
    TextureTable table;
    const std::vector<TextureRef> want = samples();
    for (const TextureRef& t : want) table.push_back(t);
    ASSERT_EQ(table.size(), want.size());
    for (size_t i = 0; i < want.size(); ++i) expectSame(table, i, want[i]);
}

TEST(TextureTable, ManyNamesSpanSeveralChunks) {
    // 200,000 names of ~20 bytes fill four 1 MiB chunks; each must still be
    // found where it was put.
    TextureTable table;
    const auto name = [](size_t i) { return "/city/appearance/" + std::to_string(i % 97) + "/tex" + std::to_string(i) + ".jpg"; };
    for (size_t i = 0; i < 200'000; ++i)
        table.push_back({name(i), static_cast<int>(i % 4096), static_cast<int>(i / 4096), 3, WrapMode::Wrap});
    for (size_t i = 0; i < 200'000; i += 997) {
        EXPECT_EQ(table.path(i), name(i));
        EXPECT_EQ(table[i].width_px, static_cast<int>(i % 4096));
    }
    EXPECT_EQ(table.path(199'999), name(199'999));
    // ~60 bytes a texture against ~150 for a vector of TextureRefs whose
    // paths (over 15 characters) live on the heap.
    EXPECT_LT(table.bytes(), 60u * 200'000);
}

TEST(TextureTable, SetReplacesOneEntryAndKeepsTheOthers) {
    TextureTable table;
    const std::vector<TextureRef> want = samples();
    for (const TextureRef& t : want) table.push_back(t);
    const TextureRef stylised{"/tmp/build/stylised/3.png", 40, 30, 4, WrapMode::Clamp};
    table.set(3, stylised);
    for (size_t i = 0; i < want.size(); ++i) expectSame(table, i, i == 3 ? stylised : want[i]);
}

TEST(TextureTable, FirstOfPathFindsEachRepeatedPathsFirstEntry) {
    TextureTable table;
    for (const TextureRef& t : samples()) table.push_back(t);
    table.push_back({"/data/other/tex0001.jpg", 64, 64, 3, WrapMode::Mirror});
    const std::vector<uint32_t> first = table.firstOfPath();
    const std::vector<uint32_t> want{0, 1, 2, 3, 4, 5, 0, 7, 8, 9, 7};
    EXPECT_EQ(first, want);
}


TEST(TextureTable, FirstOfPathAgreesWithAMapOfPathsOnACity) {
    // 30,000 entries drawing from 4,000 paths in 7 folders (a path repeated
    // up to ~20 times, with other wrap modes), against a map of whole paths.
    TextureTable table;
    std::mt19937 rng(3);
    std::map<std::string, uint32_t> first_seen;
    std::vector<uint32_t> want;
    for (uint32_t t = 0; t < 30'000; ++t) {
        const uint32_t k = rng() % 4'000;
        const std::string path = "/city/d" + std::to_string(k % 7) + "/wall_" + std::to_string(k) + ".jpg";
        table.push_back({path, 64, 64, 3, rng() % 2 ? WrapMode::Wrap : WrapMode::Clamp});
        want.push_back(first_seen.emplace(path, t).first->second);
    }
    EXPECT_EQ(table.firstOfPath(), want);
    EXPECT_EQ(table.firstOfPath({}, 4096), want) << "sorted on disk, 256 pairs a run";
    EXPECT_EQ(table.firstOfPath("/nonexistent/folder", 4096), want) << "no room for the runs: in memory";
}

}  // namespace
}  // namespace cityatlas
