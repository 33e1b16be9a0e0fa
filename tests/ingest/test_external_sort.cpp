// SPDX-License-Identifier: GPL-3.0-or-later
// core/external_sort.h (the readers' sorter for a city's worth of keys)
// against std::sort of the same records.
#include <gtest/gtest.h>

#include <filesystem>
#include <random>

#include "core/external_sort.h"

using namespace cityatlas;
namespace fs = std::filesystem;

namespace {

struct Key {
    uint64_t hash;
    uint32_t member;
    bool operator<(const Key& o) const { return hash < o.hash || (hash == o.hash && member < o.member); }
    bool operator==(const Key& o) const { return hash == o.hash && member == o.member; }
};

std::vector<Key> keys(size_t n, uint32_t seed) {
    std::mt19937_64 rng(seed);
    std::vector<Key> v(n);
    // Few distinct hashes: many equal keys and equal hashes across runs.
    for (Key& k : v) k = {rng() % (n / 3 + 1), static_cast<uint32_t>(rng() % 5)};
    return v;
}

std::vector<Key> sorted(ExternalSorter<Key>& s, Status* st) {
    std::vector<Key> out;
    *st = s.forEachSorted([&](const Key& k) { out.push_back(k); });
    return out;
}

}  // namespace

TEST(ExternalSort, RunsOnDiskMergeToTheSortedWhole) {
    const fs::path dir = fs::temp_directory_path() / "cityatlas-test-external-sort";
    fs::remove_all(dir);
    fs::create_directories(dir);
    for (const size_t budget_records : {size_t{1}, size_t{7}, size_t{1000}, size_t{1} << 20}) {
        std::vector<Key> in = keys(20011, static_cast<uint32_t>(budget_records));
        ExternalSorter<Key> s(dir, budget_records * sizeof(Key));
        for (const Key& k : in) ASSERT_TRUE(s.push(k).ok());
        EXPECT_EQ(s.runs(), budget_records == (size_t{1} << 20) ? 0u : in.size() / budget_records)
            << "a run per full buffer; an input within the budget stays in memory";
        EXPECT_TRUE(fs::is_empty(dir)) << "the runs' file is anonymous";
        Status st;
        const std::vector<Key> out = sorted(s, &st);
        ASSERT_TRUE(st.ok()) << st.error;
        std::sort(in.begin(), in.end());
        EXPECT_EQ(out, in) << "budget " << budget_records;
        EXPECT_EQ(s.size(), 0u);
        // The sorter is reusable once emptied.
        ASSERT_TRUE(s.push({5, 1}).ok());
        EXPECT_EQ(sorted(s, &st), (std::vector<Key>{{5, 1}}));
    }
    fs::remove_all(dir);
}

TEST(ExternalSort, NothingPushedGivesNothing) {
    ExternalSorter<Key> s({}, 64);
    Status st;
    EXPECT_TRUE(sorted(s, &st).empty());
    EXPECT_TRUE(st.ok());
}

TEST(ExternalSort, AFolderThatCannotTakeARunIsAnErrorNamingIt) {
    ExternalSorter<Key> s("/nonexistent/cityatlas-sort", 2 * sizeof(Key));
    Status st = s.push({1, 0});
    EXPECT_TRUE(st.ok()) << "within the budget: no file yet";
    st = s.push({2, 0});
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error.find("/nonexistent/cityatlas-sort"), std::string::npos) << st.error;
    std::vector<Key> out;
    EXPECT_FALSE(s.forEachSorted([&](const Key& k) { out.push_back(k); }).ok()) << "the failure stays";
    EXPECT_TRUE(out.empty());
}
