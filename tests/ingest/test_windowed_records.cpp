// SPDX-License-Identifier: GPL-3.0-or-later
// core/windowed_records.h (a feature's summary while a city is read)
// against a vector given the same updates in the same order, for windows
// from two records to all of them, with readers that come back to old ids.
#include <gtest/gtest.h>

#include <filesystem>
#include <random>
#include <vector>

#include "core/windowed_records.h"

using namespace cityatlas;
namespace fs = std::filesystem;

namespace {

// An update that depends on the order updates come in (a running hash), so
// a record that missed, repeated or reordered one differs.
struct Record {
    uint64_t hash = 17;
    uint32_t updates = 0;
    uint32_t last = 0;
};
void update(Record& r, uint32_t v) {
    r.hash = r.hash * 1000003u ^ v;
    ++r.updates;
    r.last = v;
}

// Ids mostly the newest few (a reader's buildings), now and then an old one,
// and jumps over ids never named (features without triangles).
std::vector<uint32_t> accesses(size_t n, uint32_t seed) {
    std::mt19937 rng(seed);
    std::vector<uint32_t> ids;
    uint32_t newest = 0;
    for (size_t k = 0; k < n; ++k) {
        const uint32_t r = rng() % 100;
        if (r < 3) newest += 1 + rng() % 50;
        else if (r < 40) ++newest;
        ids.push_back(r == 99 && newest > 0 ? rng() % newest : newest - std::min<uint32_t>(newest, rng() % 3));
    }
    return ids;
}

}  // namespace

TEST(WindowedRecords, AnyWindowGivesTheRecordsOfOneInMemory) {
    const fs::path dir = fs::temp_directory_path() / "cityatlas-test-windowed-records";
    fs::remove_all(dir);
    fs::create_directories(dir);
    const std::vector<uint32_t> ids = accesses(50000, 11);
    std::vector<Record> want;
    for (size_t k = 0; k < ids.size(); ++k) {
        if (ids[k] >= want.size()) want.resize(ids[k] + 1);
        update(want[ids[k]], static_cast<uint32_t>(k));
    }
    for (const size_t window : {size_t{2}, size_t{7}, size_t{1000}, want.size() + 1}) {
        WindowedRecords<Record> got(dir, window);
        for (size_t k = 0; k < ids.size(); ++k) update(got.at(ids[k]), static_cast<uint32_t>(k));
        ASSERT_TRUE(got.status().ok()) << got.status().error;
        ASSERT_EQ(got.size(), want.size()) << "window " << window;
        if (window > want.size()) {
            EXPECT_EQ(got.strays(), 0u) << "everything in the window";
        }
        if (window == 7) {
            EXPECT_GT(got.strays(), 0u) << "old ids come back: read from the file and written back";
        }
        EXPECT_TRUE(fs::is_empty(dir)) << "the file is anonymous";
        for (size_t f = 0; f < want.size(); ++f) {  // in order: a block of the file at a time
            const Record r = got.get(f);
            ASSERT_EQ(r.hash, want[f].hash) << "window " << window << ", id " << f;
            ASSERT_EQ(r.updates, want[f].updates) << "window " << window << ", id " << f;
        }
        std::mt19937 rng(window);  // and out of order
        for (int k = 0; k < 2000; ++k) {
            const size_t f = rng() % want.size();
            ASSERT_EQ(got.get(f).hash, want[f].hash) << "window " << window << ", id " << f;
        }
        EXPECT_EQ(got.get(want.size() + 5).updates, 0u) << "beyond the records: fresh";
        // A change after a read: the next read sees it (a second pass of
        // updates, as procedural facades give the bounds).
        ASSERT_EQ(got.get(0).hash, want[0].hash);
        Record first = want[0];
        update(got.at(0), 7), update(first, 7);
        EXPECT_EQ(got.get(1).hash, want[1].hash);
        EXPECT_EQ(got.get(0).hash, first.hash) << "window " << window;
        got.clear();
        EXPECT_EQ(got.size(), 0u);
    }
    fs::remove_all(dir);
}

TEST(WindowedRecords, AFolderThatCannotTakeTheFileIsAnErrorNamingIt) {
    WindowedRecords<Record> r("/nonexistent/cityatlas-records", 4);
    for (uint32_t id = 0; id < 4; ++id) update(r.at(id), id);
    EXPECT_TRUE(r.status().ok()) << "within the window: no file yet";
    update(r.at(4), 4);
    ASSERT_FALSE(r.status().ok());
    EXPECT_NE(r.status().error.find("/nonexistent/cityatlas-records"), std::string::npos) << r.status().error;
}
