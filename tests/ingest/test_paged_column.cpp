// SPDX-License-Identifier: GPL-3.0-or-later
// core/paged_column.h against a vector given the same pushes and sets: read
// back in order, at random and from several threads at once while pages
// come and go; its memory stays at its budget whatever its size; a copy is
// its own; and a folder that cannot take the pages keeps them in memory (a
// vector's behaviour) and says why.
#include "core/paged_column.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <thread>
#include <vector>

namespace cityatlas {
namespace {

struct Rec {
    uint64_t a = 0;
    int32_t b = 0, c = 0;
    friend bool operator==(const Rec&, const Rec&) = default;
};

Rec recordOf(size_t i, int32_t version = 0) { return {i * 2654435761u, static_cast<int32_t>(i), version}; }

constexpr size_t kPage = PagedColumn<Rec>::kPageRecords;

// What a column may hold beyond its budget: its list of pages (32 bytes a
// page, with a vector's spare room).
size_t pageList(size_t records, size_t page_records = kPage) { return 2 * 32 * (records / page_records + 1) + 4096; }

TEST(PagedColumn, ReadsBackWhatWasPushedAndSetWhilePagesComeAndGo) {
    // Budgets: the least (three pages: one in memory for good, two cached),
    // a few pages, and one the column never passes (a vector, no file).
    for (const size_t budget : {size_t{0}, 8 * PagedColumn<Rec>::kPageBytes, size_t{64} << 20}) {
        PagedColumn<Rec> column({}, "test records", budget);
        // Pages of 16,384 records but for a budget under three of them.
        EXPECT_EQ(column.pageRecords(), budget == 0 ? 16u : kPage) << budget;
        std::vector<Rec> truth;
        const size_t n = 20 * kPage + 123;  // 20 full pages and a partial one (20,480 of 16 records)
        for (size_t i = 0; i < n; ++i) {
            truth.push_back(recordOf(i));
            column.push_back(truth.back());
        }
        ASSERT_EQ(column.size(), n);
        for (size_t i = 0; i < n; ++i) ASSERT_EQ(column.get(i), truth[i]) << budget << " " << i;
        // Sets at random (on pages in memory and on pages in the file),
        // interleaved with reads that evict the pages just set.
        std::mt19937 rng(7);
        for (int k = 0; k < 20'000; ++k) {
            const size_t i = rng() % n;
            if (k % 3 == 0) {
                truth[i] = recordOf(i, k + 1);
                column.set(i, truth[i]);
            } else {
                ASSERT_EQ(column.get(i), truth[i]) << budget << " " << i;
            }
        }
        for (size_t i = 0; i < n; ++i) ASSERT_EQ(column[i], truth[i]) << budget << " " << i;
        // More pushes after the sets (the last page, partial, goes on filling).
        for (size_t i = n; i < n + 2 * kPage; ++i) {
            truth.push_back(recordOf(i, -1));
            column.push_back(truth.back());
        }
        for (size_t i = 0; i < truth.size(); i += 97) ASSERT_EQ(column.get(i), truth[i]) << budget << " " << i;
        EXPECT_TRUE(column.status().ok());
        if (budget >= (size_t{64} << 20)) {
            EXPECT_EQ(column.bytesOnDisk(), 0u) << "a column under its budget makes no file";
        } else {
            EXPECT_GT(column.bytesOnDisk(), 0u);
            EXPECT_LE(column.bytes(), column.memoryBytes() + pageList(truth.size(), column.pageRecords()))
                << "the budget holds whatever the size";
        }
    }
}

TEST(PagedColumn, MemoryStaysAtItsBudgetForAColumnTwentyTimesLarger) {
    const size_t budget = 16 * PagedColumn<Rec>::kPageBytes;  // 4 MiB of 16-byte records
    PagedColumn<Rec> column({}, "test records", budget);
    size_t most = 0;
    const size_t n = 20 * budget / sizeof(Rec);
    for (size_t i = 0; i < n; ++i) {
        column.push_back(recordOf(i));
        if (i % kPage == 0) most = std::max(most, column.bytes());
    }
    EXPECT_LE(most, budget + pageList(n));
    EXPECT_GE(column.bytesOnDisk(), 18 * budget) << "the rest went to the file";
    std::mt19937 rng(11);
    for (int k = 0; k < 5'000; ++k) {
        const size_t i = rng() % n;
        ASSERT_EQ(column.get(i), recordOf(i)) << i;
    }
    EXPECT_LE(column.bytes(), budget + pageList(n)) << "reading at random brings pages back within the cache";
}

TEST(PagedColumn, ManyThreadsReadAndSetAtOnce) {
    PagedColumn<Rec> column({}, "test records", 0);  // the smallest cache: every thread evicts the others' pages
    const size_t n = 12 * kPage;
    for (size_t i = 0; i < n; ++i) column.push_back(recordOf(i));
    // Each thread sets its own records (i % 4 == its number) and reads everyone's.
    std::vector<std::thread> threads;
    std::vector<int> wrong(4, 0);
    for (int t = 0; t < 4; ++t) {
        threads.emplace_back([&, t] {
            std::mt19937 rng(static_cast<unsigned>(t));
            for (int k = 0; k < 20'000; ++k) {
                const size_t i = rng() % n;
                const Rec r = column.get(i);
                // A record is as pushed, or as its owner set it (version 1).
                wrong[t] += !(r == recordOf(i) || r == recordOf(i, 1));
                const size_t mine = (rng() % (n / 4)) * 4 + static_cast<size_t>(t);
                column.set(mine, recordOf(mine, 1));
            }
        });
    }
    for (std::thread& th : threads) th.join();
    for (int t = 0; t < 4; ++t) EXPECT_EQ(wrong[t], 0) << "thread " << t;
    size_t set = 0;
    for (size_t i = 0; i < n; ++i) {
        const Rec r = column.get(i);
        ASSERT_TRUE(r == recordOf(i) || r == recordOf(i, 1)) << i;
        set += r == recordOf(i, 1);
    }
    EXPECT_GT(set, n / 4) << "the sets were kept through the evictions";
}

TEST(PagedColumn, ACopyIsItsOwnAndAMoveCarriesTheFile) {
    PagedColumn<Rec> column({}, "test records", 0);
    const size_t n = 6 * kPage;
    for (size_t i = 0; i < n; ++i) column.push_back(recordOf(i));
    PagedColumn<Rec> copy = column;
    copy.set(5, recordOf(5, 9));
    copy.set(n - 5, recordOf(n - 5, 9));
    copy.push_back(recordOf(n, 9));
    EXPECT_EQ(column.get(5), recordOf(5));
    EXPECT_EQ(column.get(n - 5), recordOf(n - 5));
    EXPECT_EQ(column.size(), n);
    EXPECT_EQ(copy.get(n - 5), recordOf(n - 5, 9));
    EXPECT_EQ(copy.get(n), recordOf(n, 9));
    PagedColumn<Rec> moved = std::move(column);
    for (size_t i = 0; i < n; i += 7) ASSERT_EQ(moved.get(i), recordOf(i)) << i;
}

TEST(PagedColumn, AFolderThatCannotTakeThePagesKeepsThemInMemory) {
    PagedColumn<Rec> column("/nonexistent/folder", "test records", 0);
    const size_t n = 10 * kPage;
    for (size_t i = 0; i < n; ++i) column.push_back(recordOf(i));
    EXPECT_FALSE(column.status().ok());
    EXPECT_NE(column.status().error.find("/nonexistent/folder"), std::string::npos) << column.status().error;
    EXPECT_NE(column.status().error.find("test records"), std::string::npos) << column.status().error;
    EXPECT_EQ(column.bytesOnDisk(), 0u);
    EXPECT_GE(column.bytes(), n * sizeof(Rec)) << "held in memory, as a vector would";
    for (size_t i = 0; i < n; ++i) ASSERT_EQ(column.get(i), recordOf(i)) << i;
    column.set(n - 1, recordOf(n - 1, 3));
    EXPECT_EQ(column.get(n - 1), recordOf(n - 1, 3));
}

}  // namespace
}  // namespace cityatlas
