// SPDX-License-Identifier: GPL-3.0-or-later
// The memory budget over blocks: the ideal set is the longest prefix of the
// priority order that fits; requests are bounded; resident + requested bytes
// never exceed the budget; eviction takes the lowest priority first; the root
// stays resident; at rest every resident node's ancestors are resident. Checked
// by simulating flights over a scripted quadtree with loads finishing in random
// order (and some failing), the invariants recomputed from block states.
#include <gtest/gtest.h>

#include <random>
#include <set>

#include "render/core/block_manager.h"
#include "tests/render/core/scripted_tree.h"

namespace cityatlas::render {
namespace {

struct World {
    Camera camera = test::unitCamera({-50, 800, 40}, {1, 0, -0.1});
    // 341 nodes over 1.6 km, leaves 100 m; geometry 100 B, atlas 1000 B, textures 4000 B per leaf.
    TilesetIndex index = test::makeIndex(test::quadtree(4, 1600, 30, 6400), test::buildFor(camera));
};

uint64_t bytesIn(const TilesetIndex& ix, const BlockManager& m, BlockState s) {
    uint64_t sum = 0;
    for (BlockId b = 0; b < ix.blocks.size(); ++b) sum += m.state(b) == s ? ix.blocks[b].bytes : 0;
    return sum;
}

uint32_t countIn(const TilesetIndex& ix, const BlockManager& m, BlockState s) {
    uint32_t n = 0;
    for (BlockId b = 0; b < ix.blocks.size(); ++b) n += m.state(b) == s ? 1 : 0;
    return n;
}

TEST(BlockManager, BudgetSmallerThanTheRootIsAClearError) {
    World w;
    const Status st = BlockManager::checkBudget(w.index, 1000);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error.find("1100"), std::string::npos) << st.error;  // root geometry 100 + atlas 1000
    EXPECT_TRUE(BlockManager::checkBudget(w.index, 1100).ok());
}

TEST(BlockManager, IdealSetIsTheLongestPrefixThatFits) {
    World w;
    const Classification c = classifyBlocks(w.index, w.camera, {});
    for (const uint64_t budget : {1100ull, 5000ull, 20000ull, 100000ull, 10000000ull}) {
        BlockManager m(w.index, {budget, 8});
        m.update(c);
        const std::vector<BlockId>& ideal = m.idealSet();
        ASSERT_LE(ideal.size(), c.candidates.size());
        uint64_t sum = 0;
        for (size_t i = 0; i < ideal.size(); ++i) {
            EXPECT_EQ(ideal[i], c.candidates[i]) << "not a prefix at " << i;
            sum += w.index.blocks[ideal[i]].bytes;
        }
        EXPECT_LE(sum, budget);
        if (ideal.size() < c.candidates.size()) {
            EXPECT_GT(sum + w.index.blocks[c.candidates[ideal.size()]].bytes, budget) << "the next one would have fit";
            EXPECT_TRUE(m.stats().ideal_cut);
        }
        EXPECT_EQ(m.stats().ideal_bytes, sum);
    }
}

// Flies the camera along a path; each frame finishes a random subset of the
// requests (some failing when `fail_rate` > 0) and checks every invariant.
void fly(World& w, uint64_t budget, uint32_t max_requests, double fail_rate, unsigned seed, SelectionParams params = {}) {
    std::mt19937 rng(seed);
    BlockManager m(w.index, {budget, max_requests});
    std::set<BlockId> requested;
    const BlockId root_geometry = w.index.nodes[0].layers[0].geometry, root_atlas = w.index.nodes[0].layers[0].atlas;
    bool root_loaded = false;
    for (int frame = 0; frame < 400; ++frame) {
        const double t = frame / 400.0;
        // Overview -> low oblique flight along the diagonal -> street level, turning.
        w.camera.position = {-200 + 1900 * t, 100 + 1300 * t, 600 * (1 - t) * (1 - t) + 2};
        w.camera.direction = normalized({std::cos(3 * t), std::sin(3 * t), -0.6 * (1 - t) - 0.05});
        const Classification c = classifyBlocks(w.index, w.camera, params);
        std::set<BlockId> resident_before;
        for (BlockId b = 0; b < w.index.blocks.size(); ++b)
            if (m.resident(b)) resident_before.insert(b);
        const BlockActions a = m.update(c);
        const std::set<BlockId> ideal(m.idealSet().begin(), m.idealSet().end());

        // Budget and queue bounds, from the states themselves.
        const uint64_t resident = bytesIn(w.index, m, BlockState::Resident);
        const uint64_t in_flight = bytesIn(w.index, m, BlockState::Requested);
        ASSERT_LE(resident + in_flight, budget) << "frame " << frame;
        ASSERT_LE(countIn(w.index, m, BlockState::Requested), max_requests) << "frame " << frame;
        EXPECT_EQ(m.stats().resident_bytes, resident);
        // Cancelled requests left the ideal set; new requests are in it and were absent.
        for (const BlockId b : a.cancel) {
            EXPECT_FALSE(ideal.count(b)) << "frame " << frame << " cancelled an ideal block";
            EXPECT_EQ(m.state(b), BlockState::Absent);
            requested.erase(b);
        }
        for (const BlockId b : a.request) {
            EXPECT_TRUE(ideal.count(b));
            EXPECT_EQ(m.state(b), BlockState::Requested);
            requested.insert(b);
        }
        // Evictions: outside the ideal set, and never while a lower-priority one stays.
        std::set<BlockId> evicted(a.evict.begin(), a.evict.end());
        for (const BlockId v : a.evict) {
            EXPECT_TRUE(resident_before.count(v));
            EXPECT_FALSE(ideal.count(v)) << "frame " << frame << " evicted an ideal block";
            for (const BlockId r : resident_before) {
                if (evicted.count(r) || ideal.count(r)) continue;
                EXPECT_TRUE(before(c.priority[r], r, c.priority[v], v))
                    << "frame " << frame << ": evicted " << v << " while lower-priority " << r << " stays";
            }
        }
        // The root never leaves once loaded.
        if (root_loaded) {
            EXPECT_TRUE(m.resident(root_geometry) && m.resident(root_atlas)) << "frame " << frame;
        }
        // Loads finish in random order; a few fail (never the root's).
        std::vector<BlockId> pending(requested.begin(), requested.end());
        std::shuffle(pending.begin(), pending.end(), rng);
        const size_t finish = pending.empty() ? 0 : rng() % (pending.size() + 1);
        for (size_t i = 0; i < finish; ++i) {
            const BlockId b = pending[i];
            const bool root = b == root_geometry || b == root_atlas;
            const bool ok = root || std::uniform_real_distribution<double>(0, 1)(rng) >= fail_rate;
            EXPECT_TRUE(m.finished(b, ok));
            requested.erase(b);
            ASSERT_LE(bytesIn(w.index, m, BlockState::Resident), budget);
        }
        root_loaded = m.resident(root_geometry) && m.resident(root_atlas);
        // A cancelled block's late result is refused.
        for (const BlockId b : a.cancel) EXPECT_FALSE(m.finished(b, true));
    }
    // Failed blocks are never requested again.
    const Classification c = classifyBlocks(w.index, w.camera, params);
    const BlockActions a = m.update(c);
    for (const BlockId b : a.request) EXPECT_NE(m.state(b), BlockState::Failed);
}

TEST(BlockManager, FlightKeepsEveryInvariant) {
    World w;
    const uint64_t total = w.index.bytes_total;
    for (const unsigned seed : {1u, 2u, 3u}) {
        fly(w, total / 10, 6, 0.0, seed);
        fly(w, total / 10, 6, 0.03, seed + 10);
        fly(w, total / 40, 2, 0.0, seed + 20);
        SelectionParams view;
        view.priority = PriorityMode::ViewWeighted;
        fly(w, total / 10, 6, 0.0, seed + 30, view);
    }
}

// Runs frames with every request finishing at once until nothing more is asked for.
void settle(World& w, BlockManager& m, const SelectionParams& params = {}) {
    for (int i = 0; i < 1000; ++i) {
        const BlockActions a = m.update(classifyBlocks(w.index, w.camera, params));
        if (a.request.empty()) break;
        for (const BlockId b : a.request) m.finished(b, true);
    }
}

TEST(BlockManager, AtRestTheIdealSetIsCompleteAndAncestorsAreResident) {
    World w;
    for (const uint64_t budget : {w.index.bytes_total / 30, w.index.bytes_total / 10, w.index.bytes_total}) {
        BlockManager m(w.index, {budget, 4});
        for (int k = 0; k < 12; ++k) {
            w.camera.position = {130.0 * k, 1600 - 120.0 * k, 5.0 + 40.0 * (k % 4)};
            w.camera.direction = normalized({std::cos(k * 1.1), std::sin(k * 1.1), -0.3});
            settle(w, m);
            EXPECT_TRUE(m.idealComplete()) << "budget " << budget << " camera " << k;
            EXPECT_EQ(m.stats().needed_missing, 0u);
            // Node blocks only: a texture block is shared by several leaves.
            for (const TileNode& n : w.index.nodes) {
                if (!m.resident(n.layers[0].atlas) && !m.resident(n.layers[0].geometry)) continue;
                for (int32_t p = n.parent; p >= 0; p = w.index.nodes[static_cast<size_t>(p)].parent) {
                    const NodeLayer& pl = w.index.nodes[static_cast<size_t>(p)].layers[0];
                    EXPECT_TRUE(m.resident(pl.atlas) && m.resident(pl.geometry))
                        << "budget " << budget << " camera " << k << ": node " << n.id << " resident without ancestor " << p;
                }
            }
            // And with everything of the ideal set resident, the selection draws no coarse node
            // when the whole candidate list fit.
            const Selection s = selectDraws(w.index, w.camera, {}, [&](BlockId b) { return m.resident(b); });
            if (!m.stats().ideal_cut) {
                EXPECT_EQ(s.coarse_draws, 0u) << "camera " << k;
            }
            EXPECT_FALSE(s.root_missing);
        }
    }
}

TEST(BlockManager, RequestsLeavingTheIdealSetAreCancelled) {
    World w;
    BlockManager m(w.index, {w.index.bytes_total / 20, 8});
    w.camera.position = {50, 50, 3};
    w.camera.direction = {1, 1, 0};
    BlockActions a = m.update(classifyBlocks(w.index, w.camera, {}));
    for (const BlockId b : a.request) {
        if (w.index.nodes[0].layers[0].atlas == b || w.index.nodes[0].layers[0].geometry == b) m.finished(b, true);
    }
    a = m.update(classifyBlocks(w.index, w.camera, {}));
    ASSERT_FALSE(a.request.empty());
    const std::vector<BlockId> first = a.request;
    // Teleport to the far corner, looking away: the first requests are no longer wanted.
    w.camera.position = {1590, 1590, 3};
    w.camera.direction = {1, 1, 0};
    a = m.update(classifyBlocks(w.index, w.camera, {}));
    const std::set<BlockId> ideal(m.idealSet().begin(), m.idealSet().end());
    size_t cancelled = 0;
    for (const BlockId b : first) {
        if (ideal.count(b)) continue;
        EXPECT_NE(std::find(a.cancel.begin(), a.cancel.end(), b), a.cancel.end()) << b;
        EXPECT_FALSE(m.finished(b, true)) << "a cancelled block became resident";
        EXPECT_FALSE(m.resident(b));
        ++cancelled;
    }
    EXPECT_GT(cancelled, 0u);
    EXPECT_GT(m.stats().cancellations, 0u);
}

TEST(BlockManager, LoweringTheBudgetEvictsAtOnceLowestPriorityFirst) {
    World w;
    BlockManager m(w.index, {w.index.bytes_total, 64});
    settle(w, m);
    ASSERT_GT(bytesIn(w.index, m, BlockState::Resident), w.index.bytes_total / 20);
    const Classification c = classifyBlocks(w.index, w.camera, {});
    m.setBudget(w.index.bytes_total / 20);
    const BlockActions a = m.update(c);
    EXPECT_LE(bytesIn(w.index, m, BlockState::Resident) + bytesIn(w.index, m, BlockState::Requested), w.index.bytes_total / 20);
    ASSERT_FALSE(a.evict.empty());
    // Lowest priority first: each victim ranks above the one evicted before it.
    for (size_t i = 1; i < a.evict.size(); ++i)
        EXPECT_TRUE(before(c.priority[a.evict[i]], a.evict[i], c.priority[a.evict[i - 1]], a.evict[i - 1])) << i;
    EXPECT_TRUE(m.resident(w.index.nodes[0].layers[0].atlas));
}

TEST(BlockManager, FailedBlocksLeaveTheIdealSetAndAreNotRetried) {
    World w;
    BlockManager m(w.index, {w.index.bytes_total, 64});
    BlockActions a = m.update(classifyBlocks(w.index, w.camera, {}));
    ASSERT_GE(a.request.size(), 3u);
    const BlockId bad = a.request[2];
    for (const BlockId b : a.request) m.finished(b, b != bad);
    EXPECT_EQ(m.state(bad), BlockState::Failed);
    EXPECT_TRUE(m.failedForGood(bad));
    for (int i = 0; i < 5; ++i) {
        a = m.update(classifyBlocks(w.index, w.camera, {}));
        EXPECT_EQ(std::find(a.request.begin(), a.request.end(), bad), a.request.end());
        EXPECT_EQ(std::find(m.idealSet().begin(), m.idealSet().end(), bad), m.idealSet().end());
        for (const BlockId b : a.request) m.finished(b, true);
    }
    EXPECT_EQ(m.stats().failed_blocks, 1u);
}

TEST(BlockManager, TransientFailuresAreTriedAgainAfterACooldownThatDoubles) {
    World w;
    BlockManager m(w.index, {w.index.bytes_total, 64});
    BlockActions a = m.update(classifyBlocks(w.index, w.camera, {}));
    ASSERT_GE(a.request.size(), 3u);
    const BlockId flaky = a.request[1];
    // Fails transiently twice, then the server is back.
    for (int failure = 0; failure < 2; ++failure) {
        for (const BlockId b : a.request) m.finished(b, b != flaky, /*transient=*/true);
        ASSERT_EQ(m.state(flaky), BlockState::Failed);
        EXPECT_FALSE(m.failedForGood(flaky)) << "a transient failure is tried again";
        const uint32_t cooldown = BlockManager::kFailureCooldownUpdates << failure;  // 8, then 16
        uint32_t updates = 0;
        do {
            a = m.update(classifyBlocks(w.index, w.camera, {}));
            ++updates;
            ASSERT_LE(updates, cooldown) << "not tried again within its cool-down";
            if (std::find(a.request.begin(), a.request.end(), flaky) != a.request.end()) break;
            for (const BlockId b : a.request) m.finished(b, true);  // everything else loads
        } while (true);
        EXPECT_EQ(updates, cooldown) << "tried again before its cool-down was over";
    }
    for (const BlockId b : a.request) m.finished(b, true);
    a = m.update(classifyBlocks(w.index, w.camera, {}));
    EXPECT_EQ(m.state(flaky), BlockState::Resident);
    EXPECT_TRUE(m.idealComplete());
}

}  // namespace
}  // namespace cityatlas::render
