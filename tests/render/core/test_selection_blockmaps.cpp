// SPDX-License-Identifier: GPL-3.0-or-later
// The selection with BlockMaps (issue 20; render/core/selection.h), on the
// scripted tree of test_selection.cpp with a BlockMap on the root and on each
// of its four children (their own min distances), so the expected outcome
// follows by hand:
//
//   Camera at (140, 50, 5) looking along +x, 60 degree fov, square viewport.
//   root: d = 0 < 1000      -> refined; its BlockMap Needed (the fallback), not its geometry
//   c0: behind the camera    -> Culled (its BlockMap: what would stand for it)
//   c1: d = 0 < 100          -> refined; BlockMap Needed, leaves as without BlockMaps
//   c2: d = 60 < 100         -> refined; BlockMap Needed, leaves drawn with their atlases
//   c3: d = 160 >= 100       -> drawn by its BlockMap: Needed, its geometry and atlas
//                               Unused; its leaves (no BlockMaps) Parent needed
//   The root's BlockMap leads the candidates with the root's other blocks (pinned).
#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "render/core/block_manager.h"
#include "render/core/selection.h"
#include "tests/render/core/scripted_tree.h"

namespace cityatlas::render {
namespace {
using test::box;

using test::rowTree;  // root 0; c0 1 (leaves 2-5), c1 6 (7-10), c2 11 (12-15), c3 16 (17-20)

constexpr int kWithBlockMaps[] = {0, 1, 6, 11, 16};

struct Fixture {
    Camera camera = test::unitCamera({140, 50, 5}, {1, 0, 0});
    TilesetIndex index = [this] {
        TilesetIndex ix = test::makeIndex(rowTree(), test::buildFor(camera));
        for (const int n : kWithBlockMaps) {
            TileNode& node = ix.nodes[static_cast<size_t>(n)];
            ix.blocks.push_back({BlockKind::BlockMap, n, -1, -1, "b", 500});
            node.blockmap = static_cast<BlockId>(ix.blocks.size() - 1);
            node.blockmap_min_distance_m = node.min_distance_m;
            // Its buildings in full reach a little past the node.
            node.blockmap_bounds = box(node.bounds.min.x - 2, node.bounds.min.y, 0, node.bounds.max.x + 2, 100, 30);
        }
        return ix;
    }();
    BlockId geometry(int n) const { return index.nodes[static_cast<size_t>(n)].layers[0].geometry; }
    BlockId atlas(int n) const { return index.nodes[static_cast<size_t>(n)].layers[0].atlas; }
    BlockId blockmap(int n) const { return index.nodes[static_cast<size_t>(n)].blockmap; }
};

std::vector<std::pair<int, DrawMode>> drawsOf(const Selection& s) {
    std::vector<std::pair<int, DrawMode>> v;
    for (const DrawItem& d : s.draws) v.emplace_back(d.node, d.mode);
    return v;
}

std::function<bool(BlockId)> allBut(const std::set<BlockId>& missing) {
    return [missing](BlockId b) { return !missing.count(b); };
}

TEST(SelectionBlockMaps, UsageAsTheFileCommentDerives) {
    Fixture f;
    const Classification c = classifyBlocks(f.index, f.camera, {});
    auto usage = [&](BlockId b) { return c.priority[b].usage; };
    EXPECT_EQ(usage(f.blockmap(0)), Usage::Needed);
    EXPECT_EQ(usage(f.geometry(0)), Usage::Unused);
    EXPECT_EQ(usage(f.blockmap(1)), Usage::Culled);
    EXPECT_EQ(usage(f.blockmap(6)), Usage::Needed);
    EXPECT_EQ(usage(f.geometry(6)), Usage::Unused);
    EXPECT_EQ(usage(f.blockmap(11)), Usage::Needed);
    EXPECT_EQ(usage(f.blockmap(16)), Usage::Needed);
    EXPECT_EQ(usage(f.geometry(16)), Usage::Unused);
    EXPECT_EQ(usage(f.atlas(16)), Usage::Unused);
    for (int leaf = 17; leaf <= 20; ++leaf) {
        EXPECT_EQ(usage(f.geometry(leaf)), Usage::ParentNeeded) << "leaf " << leaf;
        EXPECT_EQ(usage(f.atlas(leaf)), Usage::ParentNeeded) << "leaf " << leaf;
    }
    // c2's and c1's leaves as without BlockMaps: drawn, so their geometry Needed.
    for (const int leaf : {8, 9, 10, 12, 13, 14, 15}) EXPECT_EQ(usage(f.geometry(leaf)), Usage::Needed) << "leaf " << leaf;
    // Pinned: the root's blocks first, its BlockMap among them.
    ASSERT_GE(c.candidates.size(), 3u);
    const std::set<BlockId> first(c.candidates.begin(), c.candidates.begin() + 3);
    EXPECT_EQ(first, (std::set<BlockId>{f.geometry(0), f.atlas(0), f.blockmap(0)}));
    // Off: no BlockMap is ever wanted.
    SelectionParams off;
    off.blockmaps = false;
    const Classification o = classifyBlocks(f.index, f.camera, off);
    for (const int n : {1, 6, 11, 16}) EXPECT_EQ(o.priority[f.blockmap(n)].usage, Usage::Unused) << "node " << n;
    EXPECT_EQ(o.priority[f.geometry(16)].usage, Usage::Needed);
}

TEST(SelectionBlockMaps, DrawsTheBlockMapFromItsDistanceOn) {
    Fixture f;
    const Selection s = selectDraws(f.index, f.camera, {}, [](BlockId) { return true; });
    const std::vector<std::pair<int, DrawMode>> want = {
        {8, DrawMode::Originals}, {9, DrawMode::Originals}, {10, DrawMode::Atlas}, {12, DrawMode::Atlas},
        {13, DrawMode::Atlas},    {14, DrawMode::Atlas},    {15, DrawMode::Atlas}, {16, DrawMode::BlockMap}};
    EXPECT_EQ(drawsOf(s), want);
    for (const DrawItem& d : s.draws) EXPECT_FALSE(d.coarse) << "node " << d.node;
    // The far plane covers the BlockMap's own box (it reaches 2 m past c3 and 10 m higher).
    const Vec3d far_corner{402, 0, 30};
    EXPECT_GE(s.farthest_m + 1e-9, length(far_corner - f.camera.position));
    // Off: today's selection.
    SelectionParams off;
    off.blockmaps = false;
    EXPECT_EQ(drawsOf(selectDraws(f.index, f.camera, off, [](BlockId) { return true; })).back(),
              (std::pair<int, DrawMode>{16, DrawMode::Atlas}));
}

TEST(SelectionBlockMaps, FallsBackWhereABlockIsMissing) {
    Fixture f;
    // c3's BlockMap not loaded yet: its geometry and atlas stand in.
    Selection s = selectDraws(f.index, f.camera, {}, allBut({f.blockmap(16)}));
    EXPECT_EQ(s.draws.back().node, 16);
    EXPECT_EQ(s.draws.back().mode, DrawMode::Atlas);
    EXPECT_FALSE(s.draws.back().coarse);
    // Neither: the root cannot refine (c3 is visible) and draws its own
    // atlas, coarse; without its geometry, its BlockMap, coarse.
    s = selectDraws(f.index, f.camera, {}, allBut({f.blockmap(16), f.geometry(16)}));
    EXPECT_EQ(drawsOf(s), (std::vector<std::pair<int, DrawMode>>{{0, DrawMode::Atlas}}));
    EXPECT_TRUE(s.draws[0].coarse);
    s = selectDraws(f.index, f.camera, {}, allBut({f.blockmap(16), f.geometry(16), f.geometry(0)}));
    EXPECT_FALSE(s.root_missing);
    EXPECT_EQ(drawsOf(s), (std::vector<std::pair<int, DrawMode>>{{0, DrawMode::BlockMap}}));
    EXPECT_TRUE(s.draws[0].coarse);
    // The root with neither: nothing can be drawn.
    s = selectDraws(f.index, f.camera, {}, allBut({f.blockmap(0), f.geometry(0)}));
    EXPECT_TRUE(s.root_missing);
    // c2's geometry missing but its BlockMap loaded: c2's children are what
    // is drawn there, so nothing changes; the BlockMap makes c2 drawable,
    // which the root's refinement counts on.
    s = selectDraws(f.index, f.camera, {}, allBut({f.geometry(11), f.atlas(11)}));
    EXPECT_EQ(s.draws.size(), 8u);
    EXPECT_EQ(s.coarse_draws, 0u);
    // A leaf of c2 missing: c2 cannot refine; its geometry is missing too, so
    // its BlockMap stands in, coarse (closer than its distance).
    s = selectDraws(f.index, f.camera, {}, allBut({f.geometry(11), f.geometry(13)}));
    const auto c2 = std::find_if(s.draws.begin(), s.draws.end(), [](const DrawItem& d) { return d.node == 11; });
    ASSERT_NE(c2, s.draws.end());
    EXPECT_EQ(c2->mode, DrawMode::BlockMap);
    EXPECT_TRUE(c2->coarse);
    for (const DrawItem& d : s.draws) EXPECT_FALSE(d.node >= 12 && d.node <= 15) << "a child of c2 drawn: " << d.node;
    // Every drawn node has what it is drawn with.
    const auto resident = allBut({f.geometry(11), f.geometry(13)});
    for (const DrawItem& d : s.draws) {
        if (d.mode == DrawMode::BlockMap)
            EXPECT_TRUE(resident(f.blockmap(d.node))) << "node " << d.node;
        else
            EXPECT_TRUE(nodeDrawable(f.index, d.node, resident)) << "node " << d.node;
    }
}

// Walking away along -x from inside the town: every node switches to its
// BlockMap exactly at its min distance, and drawn nodes never overlap (a
// node and one of its ancestors are never both drawn).
TEST(SelectionBlockMaps, SwitchesAtTheMinDistanceAndNeverDrawsANodeTwice) {
    Fixture f;
    for (double x = 420; x <= 1600; x += 7) {
        const Camera cam = test::unitCamera({x, 50, 5}, {-1, 0, 0});
        const Selection s = selectDraws(f.index, cam, {}, [](BlockId) { return true; });
        std::set<int> drawn;
        for (const DrawItem& d : s.draws) {
            drawn.insert(d.node);
            const TileNode& n = f.index.nodes[static_cast<size_t>(d.node)];
            const double dist = distanceToBox(cam.position, n.bounds);
            if (n.blockmap != kNoBlock) {
                EXPECT_EQ(d.mode == DrawMode::BlockMap, dist >= n.min_distance_m) << "node " << d.node << " at x " << x;
            }
        }
        for (const int n : drawn)
            for (int p = f.index.nodes[static_cast<size_t>(n)].parent; p >= 0; p = f.index.nodes[static_cast<size_t>(p)].parent)
                EXPECT_FALSE(drawn.count(p)) << "node " << n << " and its ancestor " << p << " at x " << x;
    }
}

// Leaves with BlockMaps (a shallow tree: every level within
// --blockmap-levels): a leaf closer than its distance is drawn with its own
// geometry, so that is what it needs, not its BlockMap; with its geometry
// missing and its BlockMap loaded, the BlockMap stands in, coarse.
TEST(SelectionBlockMaps, LeavesCloserThanTheirDistanceNeedTheirGeometry) {
    Fixture f;
    for (int leaf = 7; leaf <= 10; ++leaf) {
        TileNode& n = f.index.nodes[static_cast<size_t>(leaf)];
        f.index.blocks.push_back({BlockKind::BlockMap, leaf, -1, -1, "b", 500});
        n.blockmap = static_cast<BlockId>(f.index.blocks.size() - 1);
        n.blockmap_min_distance_m = n.min_distance_m;
        n.blockmap_bounds = n.bounds;
    }
    const Classification c = classifyBlocks(f.index, f.camera, {});
    // Leaf [150,175] (node 9): d = 10 < 25, drawn with its originals.
    EXPECT_EQ(c.priority[f.geometry(9)].usage, Usage::Needed);
    EXPECT_EQ(c.priority[f.blockmap(9)].usage, Usage::Unused);
    // Leaf [175,200] (node 10): d = 35 >= 25, drawn by its BlockMap.
    EXPECT_EQ(c.priority[f.blockmap(10)].usage, Usage::Needed);
    EXPECT_EQ(c.priority[f.geometry(10)].usage, Usage::Unused);
    Selection s = selectDraws(f.index, f.camera, {}, [](BlockId) { return true; });
    EXPECT_EQ(drawsOf(s)[1], (std::pair<int, DrawMode>{9, DrawMode::Originals}));
    EXPECT_EQ(drawsOf(s)[2], (std::pair<int, DrawMode>{10, DrawMode::BlockMap}));
    // Node 9's geometry missing, its BlockMap loaded: c1 refines (node 9 is
    // drawable by it) and node 9 is its BlockMap, coarse.
    s = selectDraws(f.index, f.camera, {}, allBut({f.geometry(9)}));
    const auto it = std::find_if(s.draws.begin(), s.draws.end(), [](const DrawItem& d) { return d.node == 9; });
    ASSERT_NE(it, s.draws.end());
    EXPECT_EQ(it->mode, DrawMode::BlockMap);
    EXPECT_TRUE(it->coarse);
}

// `--blockmaps replace`: the root and its children have their BlockMaps
// alone (no layer). c3's BlockMap switches at 200 m (a measured error above
// its texel, as LOD2 roofs give), farther than its own 100 m. By hand, the
// camera as above:
//   root: d = 0 < 1000      -> refined; its BlockMap Needed and pinned
//   c3: d = 160 < 200       -> refined (no atlas to be sharp with): its
//                              BlockMap Needed (the fallback), its leaves
//                              drawn with their atlases (d >= 160 >= 25)
//   c2, c1, c0: as above.
TEST(SelectionBlockMaps, ReplacedNodesAreDrawnByTheirBlockMapOrTheirChildren) {
    Fixture f;
    for (const int n : kWithBlockMaps) {
        TileNode& node = f.index.nodes[static_cast<size_t>(n)];
        node.layers = {};
        node.blockmap_only = true;
    }
    f.index.nodes[16].blockmap_min_distance_m = 200;
    const Classification c = classifyBlocks(f.index, f.camera, {});
    EXPECT_EQ(c.priority[f.blockmap(0)].usage, Usage::Needed);
    EXPECT_EQ(c.priority[f.blockmap(16)].usage, Usage::Needed);
    for (int leaf = 17; leaf <= 20; ++leaf) EXPECT_EQ(c.priority[f.geometry(leaf)].usage, Usage::Needed) << "leaf " << leaf;
    ASSERT_FALSE(c.candidates.empty());
    EXPECT_EQ(c.candidates.front(), f.blockmap(0)) << "the root's BlockMap is all the root has: pinned first";
    // Looking away from the town, the root's BlockMap stays pinned.
    const Classification away = classifyBlocks(f.index, test::unitCamera({-50, 50, 5}, {-1, 0, 0}), {});
    ASSERT_FALSE(away.candidates.empty());
    EXPECT_EQ(away.candidates.front(), f.blockmap(0));

    const auto all = [](BlockId) { return true; };
    Selection s = selectDraws(f.index, f.camera, {}, all);
    const std::vector<std::pair<int, DrawMode>> want = {
        {8, DrawMode::Originals}, {9, DrawMode::Originals}, {10, DrawMode::Atlas}, {12, DrawMode::Atlas},
        {13, DrawMode::Atlas},    {14, DrawMode::Atlas},    {15, DrawMode::Atlas}, {17, DrawMode::Atlas},
        {18, DrawMode::Atlas},    {19, DrawMode::Atlas},    {20, DrawMode::Atlas}};
    EXPECT_EQ(drawsOf(s), want);
    // BlockMaps "off" cannot turn off what a node has alone.
    SelectionParams off;
    off.blockmaps = false;
    EXPECT_EQ(drawsOf(selectDraws(f.index, f.camera, off, all)), want);
    // c3's BlockMap missing: the root cannot count on c3 and stands in by its BlockMap, coarse.
    s = selectDraws(f.index, f.camera, {}, allBut({f.blockmap(16)}));
    EXPECT_EQ(drawsOf(s), (std::vector<std::pair<int, DrawMode>>{{0, DrawMode::BlockMap}}));
    EXPECT_TRUE(s.draws[0].coarse);
    // The root's BlockMap missing: nothing can be drawn, whatever else is there.
    EXPECT_TRUE(selectDraws(f.index, f.camera, {}, allBut({f.blockmap(0)})).root_missing);
    // The budget must hold the root's BlockMap (500 bytes), its only block.
    EXPECT_FALSE(BlockManager::checkBudget(f.index, 499).ok());
    EXPECT_TRUE(BlockManager::checkBudget(f.index, 500).ok());

    // Walking away: a replaced node is drawn only by its BlockMap, never with
    // an atlas, from its BlockMap's distance on; never with an ancestor.
    for (double x = 420; x <= 1600; x += 7) {
        const Camera cam = test::unitCamera({x, 50, 5}, {-1, 0, 0});
        const Selection w = selectDraws(f.index, cam, {}, all);
        ASSERT_FALSE(w.draws.empty()) << "x " << x;
        std::set<int> drawn;
        for (const DrawItem& d : w.draws) {
            drawn.insert(d.node);
            const TileNode& n = f.index.nodes[static_cast<size_t>(d.node)];
            if (!n.blockmap_only) continue;
            EXPECT_EQ(d.mode, DrawMode::BlockMap) << "node " << d.node << " at x " << x;
            EXPECT_GE(distanceToBox(cam.position, n.bounds), n.blockmap_min_distance_m) << "node " << d.node << " at x " << x;
        }
        for (const int n : drawn)
            for (int p = f.index.nodes[static_cast<size_t>(n)].parent; p >= 0; p = f.index.nodes[static_cast<size_t>(p)].parent)
                EXPECT_FALSE(drawn.count(p)) << "node " << n << " and its ancestor " << p << " at x " << x;
    }
}

}  // namespace
}  // namespace cityatlas::render
