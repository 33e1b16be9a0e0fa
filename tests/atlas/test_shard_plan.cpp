// SPDX-License-Identifier: GPL-3.0-or-later
// atlas/shard_plan.h's cut on disk against the same cut made in memory with
// atlas/subdivide.h's splitIntoFourAt (the quartering the tree itself uses):
// the same nodes, shards and feature assignments, bit for bit, whatever the
// memory the cut is given.
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <random>
#include <vector>

#include "atlas/shard_plan.h"
#include "atlas/subdivide.h"

namespace cityatlas::atlas {
namespace {

namespace fs = std::filesystem;

// The oracle: the cut as it was made in memory before it moved to disk.
ShardPlan cutInMemory(const std::vector<FeatureSummary>& s, uint64_t max_triangles) {
    ShardPlan plan;
    const size_t nf = s.size();
    std::vector<Vec3d> point(nf, Vec3d{0, 0, 0});
    std::vector<double> weight(nf, 0);
    std::vector<uint32_t> all;
    for (uint32_t f = 0; f < nf; ++f) {
        weight[f] = s[f].weight;
        if (s[f].count == 0) continue;
        point[f] = (1.0 / s[f].area) * s[f].point;
        all.push_back(f);
    }
    plan.shard_of_feature.assign(nf, -1);
    std::function<int32_t(std::vector<uint32_t>, int32_t, int)> cut = [&](std::vector<uint32_t> ids, int32_t parent,
                                                                          int level) {
        const auto id = static_cast<int32_t>(plan.nodes.size());
        plan.nodes.push_back({parent, {-1, -1, -1, -1}, level, -1});
        uint64_t triangles = 0;
        for (uint32_t f : ids) triangles += s[f].count;
        if (triangles <= max_triangles || ids.size() < 2) {
            const auto shard = static_cast<int32_t>(plan.shard_triangles.size());
            plan.nodes[static_cast<size_t>(id)].shard = shard;
            plan.shard_triangles.push_back(triangles);
            for (uint32_t f : ids) plan.shard_of_feature[f] = shard;
            return id;
        }
        auto groups = splitIntoFourAt(ids, point, weight);
        for (size_t q = 0; q < 4; ++q)
            if (!groups[q].empty()) plan.nodes[static_cast<size_t>(id)].children[q] = cut(groups[q], id, level + 1);
        return id;
    };
    cut(all, -1, 0);
    return plan;
}

// Features on a coarse grid in x (many equal coordinates: the ties by id),
// spread in y, some untextured (weight 0), some without triangles.
std::vector<FeatureSummary> city(size_t n, uint32_t seed, bool untextured) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<FeatureSummary> s(n);
    for (FeatureSummary& f : s) {
        if (rng() % 17 == 0) continue;  // no triangles: no shard
        f.count = 1 + rng() % 40;
        const double area = 10 + 200 * u(rng);
        const Vec3d at{std::floor(40 * u(rng)) * 25.0, 3000 * u(rng) * u(rng), 5 * u(rng)};
        f.area = area;
        f.point = area * at;
        f.weight = untextured || rng() % 5 == 0 ? 0.0 : area * u(rng);
    }
    return s;
}

ShardPlan cutOnDisk(const std::vector<FeatureSummary>& s, uint64_t max_triangles, const fs::path& dir,
                    size_t memory_bytes) {
    FeatureSummaries summaries(dir, 64);  // a small window: the summaries go to disk too
    for (size_t f = 0; f < s.size(); ++f) summaries.records.at(f) = s[f];
    ShardPlan plan;
    const Status st = planShards(std::move(summaries), s.size(), max_triangles, dir, &plan, memory_bytes);
    EXPECT_TRUE(st.ok()) << st.error;
    return plan;
}

void expectSamePlan(const ShardPlan& want, const ShardPlan& got, const std::string& what) {
    ASSERT_EQ(want.nodes.size(), got.nodes.size()) << what;
    for (size_t i = 0; i < want.nodes.size(); ++i) {
        EXPECT_EQ(want.nodes[i].parent, got.nodes[i].parent) << what << ", node " << i;
        EXPECT_EQ(want.nodes[i].children, got.nodes[i].children) << what << ", node " << i;
        EXPECT_EQ(want.nodes[i].level, got.nodes[i].level) << what << ", node " << i;
        EXPECT_EQ(want.nodes[i].shard, got.nodes[i].shard) << what << ", node " << i;
    }
    EXPECT_EQ(want.shard_triangles, got.shard_triangles) << what;
    EXPECT_EQ(want.shard_of_feature, got.shard_of_feature) << what;
}

}  // namespace

TEST(ShardPlanOnDisk, CutsAsTheSubdivisionCutsInMemory) {
    const fs::path dir = fs::temp_directory_path() / "cityatlas-test-shard-plan";
    fs::remove_all(dir);
    fs::create_directories(dir);
    for (const bool untextured : {false, true}) {  // untextured: every cut counts features
        const std::vector<FeatureSummary> s = city(6000, untextured ? 7 : 3, untextured);
        uint64_t triangles = 0;
        for (const FeatureSummary& f : s) triangles += f.count;
        const uint64_t max = triangles / 40;
        const ShardPlan want = cutInMemory(s, max);
        ASSERT_GE(want.shards(), 16u) << "deep enough to exercise several levels";
        // 4 kB: every sort writes runs and every group larger than 1,024
        // features goes to its file; 32 MB: nothing touches the disk.
        for (const size_t memory : {size_t{4} << 10, size_t{32} << 20}) {
            const std::string what = std::string(untextured ? "untextured" : "textured") + ", " +
                                     std::to_string(memory) + " bytes";
            expectSamePlan(want, cutOnDisk(s, max, dir, memory), what);
            EXPECT_TRUE(fs::is_empty(dir)) << "scratch files are anonymous: " << what;
        }
    }
    fs::remove_all(dir);
}

TEST(ShardPlanOnDisk, AFeatureLargerThanAShardIsAShardOfItsOwn) {
    std::vector<FeatureSummary> s(5);
    for (size_t f = 0; f < s.size(); ++f) {
        s[f].count = f == 2 ? 1000 : 10;
        s[f].area = 1;
        s[f].weight = 1;
        s[f].point = Vec3d{static_cast<double>(f) * 100, 0, 0};
    }
    const ShardPlan want = cutInMemory(s, 100);
    const ShardPlan got = cutOnDisk(s, 100, fs::temp_directory_path(), size_t{4} << 10);
    expectSamePlan(want, got, "one large feature");
    const int32_t big = got.shard_of_feature[2];
    ASSERT_GE(big, 0);
    EXPECT_EQ(got.shard_triangles[static_cast<size_t>(big)], 1000u);
    for (size_t f = 0; f < s.size(); ++f)
        if (f != 2) {
            EXPECT_NE(got.shard_of_feature[f], big) << "feature " << f;
        }
}

TEST(ShardPlanOnDisk, AScratchFolderThatCannotTakeAFileIsAnErrorNamingIt) {
    const std::vector<FeatureSummary> s = city(3000, 5, false);
    FeatureSummaries summaries("/nonexistent/cityatlas-plan", 1 << 20);
    for (size_t f = 0; f < s.size(); ++f) summaries.records.at(f) = s[f];
    ShardPlan plan;
    const Status st = planShards(std::move(summaries), s.size(), 500, "/nonexistent/cityatlas-plan", &plan, 4096);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error.find("/nonexistent/cityatlas-plan"), std::string::npos) << st.error;
}

}  // namespace cityatlas::atlas
