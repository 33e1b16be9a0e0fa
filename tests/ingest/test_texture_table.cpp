// SPDX-License-Identifier: GPL-3.0-or-later
// The scene's texture table (ingest/texture_table.h): every path and field
// comes back as added, whatever the folder, across its name chunks and after
// set(); forEachFirstOfPath finds repeated paths exactly; and a city's table costs a
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
    // The paths (~6.5 MB) went to the scratch file but for the newest MiB:
    // 20 bytes a texture in memory (by pages of 16,384), and that MiB (~26
    // in all here), against ~43 with the paths packed in memory and ~150
    // for a vector of TextureRefs whose paths live on the heap.
    EXPECT_GT(table.bytesOnDisk(), 5'000'000u);
    EXPECT_LT(table.bytes(), 27u * 200'000);
}

// 60,000 paths of ~50 bytes: two chunks sealed (a MiB each, less the
// path that did not fit), the newest in memory.
std::vector<TextureRef> cityOfPaths(size_t n) {
    std::vector<TextureRef> city;
    for (size_t i = 0; i < n; ++i)
        city.push_back({"/city/appearance/district_" + std::to_string(i % 13) + "/building_" + std::to_string(i) +
                            "_wall.jpg",
                        static_cast<int>(i % 512 + 1), static_cast<int>(i % 77 + 1), 3 + static_cast<int>(i % 2),
                        static_cast<WrapMode>(i % 5)});
    return city;
}

TEST(TextureTable, PathsOnDiskAndKeptInMemoryReadBackTheSame) {
    const std::vector<TextureRef> city = cityOfPaths(60'000);
    TextureTable on_disk, kept("/nonexistent/folder");
    for (const TextureRef& t : city) on_disk.push_back(t), kept.push_back(t);
    EXPECT_GT(on_disk.bytesOnDisk(), 2'000'000u);
    EXPECT_EQ(kept.bytesOnDisk(), 0u) << "no folder for the file: the paths stay in memory";
    EXPECT_GE(kept.bytes(), on_disk.bytes() + on_disk.bytesOnDisk()) << "what the file holds, held in memory";
    for (size_t i = 0; i < city.size(); ++i) {
        expectSame(on_disk, i, city[i]);
        expectSame(kept, i, city[i]);
    }
    // The same at random (pread at any offset; a kept chunk found by its start).
    std::mt19937 rng(5);
    for (int k = 0; k < 5'000; ++k) {
        const size_t i = rng() % city.size();
        ASSERT_EQ(on_disk.path(i), city[i].path) << i;
        ASSERT_EQ(kept.path(i), city[i].path) << i;
    }
}

TEST(TextureTable, SetAndCopyAfterThePathsWentToDisk) {
    std::vector<TextureRef> city = cityOfPaths(40'000);
    TextureTable table;
    for (const TextureRef& t : city) table.push_back(t);
    ASSERT_GT(table.bytesOnDisk(), 0u);
    // Replaced entries (the stylised facades' way), one on disk, one in memory.
    for (const size_t i : {size_t{7}, size_t{39'999}}) {
        city[i] = {"/build/stylised/" + std::to_string(i) + ".png", 40, 30, 4, WrapMode::Clamp};
        table.set(i, city[i]);
    }
    TextureTable copy = table;
    copy.push_back({"/only/in/the/copy.png", 1, 1, 3, WrapMode::Wrap});
    copy.set(8, {"/only/in/the/copy/too.png", 2, 2, 3, WrapMode::Wrap});
    ASSERT_EQ(table.size(), city.size());
    for (size_t i = 0; i < city.size(); ++i) expectSame(table, i, city[i]);
    EXPECT_EQ(copy.path(7), city[7].path);
    EXPECT_EQ(copy.path(8), "/only/in/the/copy/too.png");
    EXPECT_EQ(copy.path(city.size()), "/only/in/the/copy.png");
    EXPECT_EQ(copy.path(20'000), city[20'000].path);
    // A folder named once the paths have gone is too late: they stay.
    table.setScratchDir("/nonexistent/folder");
    EXPECT_EQ(table.path(100), city[100].path);
    TextureTable fresh;
    fresh.setScratchDir("/nonexistent/folder");
    for (const TextureRef& t : city) fresh.push_back(t);
    EXPECT_EQ(fresh.bytesOnDisk(), 0u) << "the folder named before the first MiB is the one used";
    EXPECT_EQ(fresh.path(12'345), city[12'345].path);
}

TEST(TextureTable, EntriesPastTheBudgetGoToDiskAndComeBack) {
    // The least budget (three pages of 16,384 entries, ~1 MB): 200,000
    // textures keep ~1 MB of entries and the newest MiB of paths in memory
    // (5.3 MB at the default budget), every one found as added, at random
    // too, and replaced where its page is on disk.
    std::vector<TextureRef> city = cityOfPaths(200'000);
    TextureTable table({}, 0);
    for (const TextureRef& t : city) table.push_back(t);
    EXPECT_LT(table.bytes(), 2'200'000u);
    EXPECT_GT(table.bytesOnDisk(), 200'000u * 20 / 2) << "entries and paths in the files";
    for (size_t i = 0; i < city.size(); i += 7) expectSame(table, i, city[i]);
    std::mt19937 rng(9);
    for (int k = 0; k < 5'000; ++k) {
        const size_t i = rng() % city.size();
        if (k % 4 == 0) {
            city[i] = {"/build/stylised/" + std::to_string(i) + ".png", 40, 30, 4, WrapMode::Clamp};
            table.set(i, city[i]);
        }
        ASSERT_EQ(table[i].width_px, city[i].width_px) << i;
        ASSERT_EQ(table.path(i), city[i].path) << i;
    }
    const TextureTable copy = table;
    EXPECT_LT(copy.bytes(), 2'200'000u) << "a copy keeps the budget";
    for (size_t i = 0; i < city.size(); ++i) expectSame(copy, i, city[i]);
    EXPECT_LT(table.bytes(), 2'200'000u);
}

TEST(TextureTable, SetReplacesOneEntryAndKeepsTheOthers) {
    TextureTable table;
    const std::vector<TextureRef> want = samples();
    for (const TextureRef& t : want) table.push_back(t);
    const TextureRef stylised{"/tmp/build/stylised/3.png", 40, 30, 4, WrapMode::Clamp};
    table.set(3, stylised);
    for (size_t i = 0; i < want.size(); ++i) expectSame(table, i, i == 3 ? stylised : want[i]);
}

// forEachFirstOfPath's answers as a vector, checking they come in texture order.
std::vector<uint32_t> firstOfPath(const TextureTable& table, const std::filesystem::path& dir = {},
                                  size_t memory_bytes = size_t{32} << 20) {
    std::vector<uint32_t> first;
    table.forEachFirstOfPath(
        [&](size_t t, size_t f) {
            EXPECT_EQ(t, first.size()) << "not in texture order";
            first.push_back(static_cast<uint32_t>(f));
        },
        dir, memory_bytes);
    return first;
}

TEST(TextureTable, FirstOfPathFindsEachRepeatedPathsFirstEntry) {
    TextureTable table;
    for (const TextureRef& t : samples()) table.push_back(t);
    table.push_back({"/data/other/tex0001.jpg", 64, 64, 3, WrapMode::Mirror});
    const std::vector<uint32_t> first = firstOfPath(table);
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
    EXPECT_EQ(firstOfPath(table), want);
    EXPECT_EQ(firstOfPath(table, {}, 4096), want) << "sorted on disk, 128 pairs a run";
    EXPECT_EQ(firstOfPath(table, "/nonexistent/folder", 4096), want) << "no room for the runs: in memory";
}

}  // namespace
}  // namespace cityatlas
