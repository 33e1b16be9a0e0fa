// SPDX-License-Identifier: GPL-3.0-or-later
// core/record_file.h against a vector given the same writes: appended and
// written at any index (runs, holes, rewrites), read back through get() in
// order and at random (chunk borders, the unflushed appends) and through
// read(); and an error naming what the records were for.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

#include "core/record_file.h"

namespace cityatlas {
namespace {

struct Rec {
    uint64_t a = 0;
    int32_t b = 0, c = 0;
    friend bool operator==(const Rec&, const Rec&) = default;
};

TEST(RecordFile, ReadsBackWhatWasWrittenInAnyOrder) {
    for (const size_t chunk : {size_t{1}, size_t{7}, size_t{4096}}) {
        RecordFile<Rec> file({}, "test records", chunk);
        std::vector<Rec> truth;
        std::mt19937 rng(5);
        // Appends, then runs written past the end (holes between), then rewrites inside.
        for (uint64_t i = 0; i < 10'000; ++i) {
            truth.push_back({i * 3, static_cast<int32_t>(i), 1});
            ASSERT_TRUE(file.append(truth.back()).ok());
        }
        for (int run = 0; run < 20; ++run) {
            const size_t first = truth.size() + rng() % 50, n = 1 + rng() % 300;
            std::vector<Rec> recs(n);
            for (size_t k = 0; k < n; ++k) recs[k] = {rng(), static_cast<int32_t>(first + k), 2};
            ASSERT_TRUE(file.write(first, recs.data(), n).ok());
            truth.resize(first + n);
            std::copy(recs.begin(), recs.end(), truth.begin() + static_cast<std::ptrdiff_t>(first));
        }
        for (int run = 0; run < 20; ++run) {
            const size_t first = rng() % (truth.size() - 10);
            const Rec r{rng(), -1, 3};
            ASSERT_TRUE(file.write(first, &r, 1).ok());
            truth[first] = r;
        }
        for (uint64_t i = 0; i < 5; ++i) {  // appended after it all, still in the buffer
            truth.push_back({i, -2, 4});
            ASSERT_TRUE(file.append(truth.back()).ok());
        }
        ASSERT_EQ(file.size(), truth.size());
        for (size_t i = 0; i < truth.size(); ++i) ASSERT_EQ(file.get(i), truth[i]) << "in order, chunk " << chunk << ", " << i;
        std::vector<size_t> order(truth.size());
        for (size_t i = 0; i < order.size(); ++i) order[i] = i;
        std::shuffle(order.begin(), order.end(), rng);
        for (const size_t i : order) ASSERT_EQ(file.get(i), truth[i]) << "at random, chunk " << chunk << ", " << i;
        for (size_t k = 0; k < 2'000; ++k) ASSERT_EQ(file.read(order[k]), truth[order[k]]) << order[k];
        EXPECT_EQ(file.get(truth.size()), Rec{});  // beyond the end
        EXPECT_TRUE(file.status().ok()) << file.status().error;
    }
}

TEST(RecordFile, AWriteAfterAReadIsSeen) {
    RecordFile<Rec> file({}, "test records", 64);
    std::vector<Rec> recs(1000);
    for (size_t i = 0; i < recs.size(); ++i) recs[i] = {i, 0, 0};
    ASSERT_TRUE(file.write(0, recs.data(), recs.size()).ok());
    EXPECT_EQ(file.get(10).a, 10u);  // its chunk now read
    const Rec changed{77, 7, 7};
    ASSERT_TRUE(file.write(10, &changed, 1).ok());
    EXPECT_EQ(file.get(10), changed);
    EXPECT_EQ(file.get(11).a, 11u);
}

TEST(RecordFile, AFolderThatCannotTakeTheFileIsAnErrorNamingThem) {
    RecordFile<Rec> file("/nonexistent/folder", "the test's records");
    const Rec r{1, 2, 3};
    const Status s = file.write(3, &r, 1);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.error.find("/nonexistent/folder"), std::string::npos) << s.error;
    EXPECT_NE(s.error.find("the test's records"), std::string::npos) << s.error;
    EXPECT_EQ(file.get(3), Rec{});
    EXPECT_FALSE(file.status().ok());
}

}  // namespace
}  // namespace cityatlas
