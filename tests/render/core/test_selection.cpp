// SPDX-License-Identifier: GPL-3.0-or-later
// Usage categories, priorities and the draw selection on a scripted tree whose
// expected outcome follows by hand from papers/000 §4.4 / §4.6:
//
//   root [0,400] x [0,100] x [0,20], min distance 1000, children along x:
//     c0 [0,100]  c1 [100,200]  c2 [200,300]  c3 [300,400]   (min distance 100)
//   each with four leaves 25 m wide along x (min distance 25, one texture block each).
//   Camera at (140, 50, 5) looking along +x, 60 degree fov, square viewport.
//
//   root: d = 0 < 1000            -> refined, Needed
//   c0: behind the camera         -> outside the frustum; a sibling is Needed -> Culled
//   c1: contains the camera, d = 0 -> refined, Needed
//     leaf [100,125]: behind       -> Culled
//     leaf [125,150]: d = 0 < 25   -> originals: Needed, its textures Needed
//     leaf [150,175]: d = 10 < 25  -> originals: Needed, textures Needed
//     leaf [175,200]: d = 35 >= 25 -> atlas: Needed; d < 2 x 25: textures Parent needed
//   c2: d = 60 < 100               -> refined, Needed; its leaves d >= 60 >= 25 -> atlas, Needed;
//                                     d >= 2 x 25: textures Unused (originals are prefetched
//                                     within one octave of a leaf's min distance only)
//   c3: d = 160 >= 100             -> atlas, Needed; its leaves Parent needed, their textures Unused
//   c0's leaves and textures, leaf [100,125]'s textures: Unused
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>

#include "render/core/selection.h"
#include "tests/render/core/scripted_tree.h"

namespace cityatlas::render {
namespace {
using test::box;

using test::rowTree;  // root 0; c0 1 (leaves 2-5), c1 6 (7-10), c2 11 (12-15), c3 16 (17-20)

struct Fixture {
    Camera camera = test::unitCamera({140, 50, 5}, {1, 0, 0});
    TilesetIndex index = test::makeIndex(rowTree(), test::buildFor(camera));
    Usage nodeUsage(const Classification& c, int node) const {
        const NodeLayer& l = index.nodes[static_cast<size_t>(node)].layers[0];
        EXPECT_EQ(c.priority[l.geometry].usage, c.priority[l.atlas].usage) << "node " << node;
        return c.priority[l.atlas].usage;
    }
    Usage textureUsage(const Classification& c, int leaf) const {
        return c.priority[index.nodes[static_cast<size_t>(leaf)].texture_blocks.at(0)].usage;
    }
};

TEST(Selection, DistanceScaleFollowsViewportFovAndTau) {
    Fixture f;
    SelectionParams p;
    EXPECT_DOUBLE_EQ(distanceScale(f.index.build, f.camera, p), 1.0);
    Camera twice = f.camera;
    twice.width_px *= 2;
    twice.height_px *= 2;  // same fov and aspect: focal doubles, the corner factor stays
    EXPECT_NEAR(distanceScale(f.index.build, twice, p), 2.0, 1e-12);
    p.tau = 2;
    EXPECT_NEAR(distanceScale(f.index.build, f.camera, p), 0.5, 1e-12);
    Camera wide = f.camera;
    wide.vertical_fov_deg = 90;  // a wider fov: fewer pixels per radian, but larger corner factor
    const double fw = 400.0 / std::tan(M_PI / 4), cw = 1.0 + (2 * 400.0 * 400.0) / (fw * fw);
    p.tau = 1;
    EXPECT_NEAR(distanceScale(f.index.build, wide, p), fw * cw / (f.camera.focalPx() * f.camera.cornerFactor()), 1e-12);
}

TEST(Selection, UsageCategoriesAsPapersDefineThem) {
    Fixture f;
    const Classification c = classifyBlocks(f.index, f.camera, {});
    const std::map<int, Usage> nodes = {
        {0, Usage::Needed},   {1, Usage::Culled},  {2, Usage::Unused},  {3, Usage::Unused},  {4, Usage::Unused},
        {5, Usage::Unused},   {6, Usage::Needed},  {7, Usage::Culled},  {8, Usage::Needed},  {9, Usage::Needed},
        {10, Usage::Needed},  {11, Usage::Needed}, {12, Usage::Needed}, {13, Usage::Needed}, {14, Usage::Needed},
        {15, Usage::Needed},  {16, Usage::Needed}, {17, Usage::ParentNeeded}, {18, Usage::ParentNeeded},
        {19, Usage::ParentNeeded}, {20, Usage::ParentNeeded}};
    for (const auto& [node, usage] : nodes)
        EXPECT_EQ(usageName(f.nodeUsage(c, node)), std::string(usageName(usage))) << "node " << node;
    const std::map<int, Usage> textures = {
        {2, Usage::Unused},        {3, Usage::Unused},        {4, Usage::Unused},        {5, Usage::Unused},
        {7, Usage::Unused},        {8, Usage::Needed},        {9, Usage::Needed},        {10, Usage::ParentNeeded},
        {12, Usage::Unused},       {13, Usage::Unused},       {14, Usage::Unused},       {15, Usage::Unused},
        {17, Usage::Unused},       {18, Usage::Unused},       {19, Usage::Unused},       {20, Usage::Unused}};
    for (const auto& [leaf, usage] : textures)
        EXPECT_EQ(usageName(f.textureUsage(c, leaf)), std::string(usageName(usage))) << "textures of leaf " << leaf;
    EXPECT_EQ(c.nodes_needed, 11u);

    // Without original textures, leaves never need their blocks.
    SelectionParams no_originals;
    no_originals.originals = false;
    const Classification c2 = classifyBlocks(f.index, f.camera, no_originals);
    for (const auto& [leaf, usage] : textures) EXPECT_EQ(f.textureUsage(c2, leaf), Usage::Unused) << "leaf " << leaf;
}

TEST(Selection, EveryNeededNodesAncestorsAreNeeded) {
    // §4.6: "for each node N in the Needed category each node on the path from
    // the root to N is in the Needed category as well" — on a bigger tree and
    // many cameras.
    const Camera base = test::unitCamera({0, 0, 0}, {1, 0, 0});
    const TilesetIndex ix = test::makeIndex(test::quadtree(4, 1600, 30, 3200), test::buildFor(base));
    for (int k = 0; k < 40; ++k) {
        Camera cam = base;
        cam.position = {40.0 * k, std::fmod(37.0 * k, 1600.0), 2.0 + k % 7 * 30.0};
        cam.direction = normalized({std::cos(k * 0.7), std::sin(k * 0.7), -0.2 * (k % 3)});
        const Classification c = classifyBlocks(ix, cam, {});
        for (const TileNode& n : ix.nodes) {
            if (c.priority[n.layers[0].atlas].usage != Usage::Needed) continue;
            for (int32_t p = n.parent; p >= 0; p = ix.nodes[static_cast<size_t>(p)].parent)
                EXPECT_EQ(c.priority[ix.nodes[static_cast<size_t>(p)].layers[0].atlas].usage, Usage::Needed)
                    << "camera " << k << " node " << n.id << " ancestor " << p;
            // Culled and parent-needed nodes hang below a Needed parent.
        }
        for (const TileNode& n : ix.nodes) {
            const Usage u = c.priority[n.layers[0].atlas].usage;
            if ((u == Usage::Culled || u == Usage::ParentNeeded) && n.parent >= 0) {
                EXPECT_EQ(c.priority[ix.nodes[static_cast<size_t>(n.parent)].layers[0].atlas].usage, Usage::Needed)
                    << "camera " << k << " node " << n.id;
            }
        }
    }
}

TEST(Selection, CandidatesInPriorityOrderRootPinnedParentsFirst) {
    Fixture f;
    const Classification c = classifyBlocks(f.index, f.camera, {});
    // Root pinned in front.
    ASSERT_GE(c.candidates.size(), 2u);
    const std::set<BlockId> root = {f.index.nodes[0].layers[0].geometry, f.index.nodes[0].layers[0].atlas};
    EXPECT_TRUE(root.count(c.candidates[0]) && root.count(c.candidates[1]));
    // Then usage ascending; within a usage, distance ascending; then level.
    for (size_t i = 3; i < c.candidates.size(); ++i) {
        const BlockPriority& a = c.priority[c.candidates[i - 1]];
        const BlockPriority& b = c.priority[c.candidates[i]];
        ASSERT_LE(static_cast<int>(a.usage), static_cast<int>(b.usage)) << i;
        if (a.usage == b.usage) {
            ASSERT_LE(a.key, b.key) << i;
            if (a.key == b.key) {
                ASSERT_LE(a.level, b.level) << i;
            }
        }
    }
    // No unused block is a candidate; every used one is.
    std::set<BlockId> listed(c.candidates.begin(), c.candidates.end());
    for (BlockId b = 0; b < f.index.blocks.size(); ++b)
        EXPECT_EQ(listed.count(b) == 1, c.priority[b].usage != Usage::Unused || root.count(b)) << b;
    // A parent precedes its children wherever both are listed.
    std::map<BlockId, size_t> pos;
    for (size_t i = 0; i < c.candidates.size(); ++i) pos[c.candidates[i]] = i;
    for (const TileNode& n : f.index.nodes) {
        if (n.parent < 0 || !pos.count(n.layers[0].atlas)) continue;
        const BlockId pa = f.index.nodes[static_cast<size_t>(n.parent)].layers[0].atlas;
        ASSERT_TRUE(pos.count(pa)) << "node " << n.id << " listed without its parent";
        EXPECT_LT(pos[pa], pos[n.layers[0].atlas]) << "node " << n.id;
        for (const BlockId t : n.texture_blocks)
            if (pos.count(t)) {
                EXPECT_LT(pos[n.layers[0].atlas], pos[t]) << "textures of " << n.id;
            }
    }
    // Needed leaves' textures: the nearer leaf [125,150] (d 0) before [150,175] (d 10).
    EXPECT_LT(pos[f.index.nodes[8].texture_blocks[0]], pos[f.index.nodes[9].texture_blocks[0]]);
}

TEST(Selection, ViewWeightedPriorityPrefersWhatIsAhead) {
    // Two leaves at the same distance, one straight ahead and one off to the side:
    // by distance they tie (broken by id); view-weighted, the one ahead comes first.
    std::vector<test::ScriptedNode> s;
    s.push_back({box(-200, -200, 0, 200, 200, 10), 1e6, {1, 2}, false});
    s.push_back({box(-10, 100, 0, 10, 120, 10), 1, {}, true});    // off to the side (+y), d = 100
    s.push_back({box(100, -10, 0, 120, 10, 10), 1, {}, true});    // ahead (+x), d = 100
    const Camera cam = test::unitCamera({0, 0, 5}, {1, 0, 0});
    Camera wide = cam;
    wide.vertical_fov_deg = 120;  // both in view
    TilesetIndex ix = test::makeIndex(s, test::buildFor(wide));
    ix.nodes[0].min_distance_m = 0;  // the root is sharp: children are Parent needed, ordered by key
    SelectionParams by_distance, by_view;
    by_view.priority = PriorityMode::ViewWeighted;
    const Classification a = classifyBlocks(ix, wide, by_distance);
    const Classification b = classifyBlocks(ix, wide, by_view);
    const BlockId side = ix.nodes[1].layers[0].atlas, ahead = ix.nodes[2].layers[0].atlas;
    EXPECT_EQ(a.priority[side].usage, Usage::ParentNeeded);
    EXPECT_DOUBLE_EQ(a.priority[side].key, a.priority[ahead].key);
    EXPECT_TRUE(before(b.priority[ahead], ahead, b.priority[side], side));
    EXPECT_LT(b.priority[ahead].key, 1e-9);
}

TEST(Selection, DrawsWithEverythingResident) {
    Fixture f;
    const Selection s = selectDraws(f.index, f.camera, {}, [](BlockId) { return true; });
    ASSERT_FALSE(s.root_missing);
    std::vector<std::pair<int, DrawMode>> got;
    for (const DrawItem& d : s.draws) {
        got.emplace_back(d.node, d.mode);
        EXPECT_FALSE(d.coarse);
    }
    const std::vector<std::pair<int, DrawMode>> want = {
        {8, DrawMode::Originals}, {9, DrawMode::Originals}, {10, DrawMode::Atlas}, {12, DrawMode::Atlas},
        {13, DrawMode::Atlas},    {14, DrawMode::Atlas},    {15, DrawMode::Atlas}, {16, DrawMode::Atlas}};
    EXPECT_EQ(got, want);
    EXPECT_EQ(s.nodes_culled, 2u);  // c0 and leaf [100,125]
}

std::function<bool(BlockId)> allBut(const std::set<BlockId>& missing) {
    return [missing](BlockId b) { return !missing.count(b); };
}

TEST(Selection, RefinementOnlyWhenPossible) {
    Fixture f;
    auto nodesOf = [](const Selection& s) {
        std::vector<std::pair<int, bool>> v;
        for (const DrawItem& d : s.draws) v.emplace_back(d.node, d.coarse);
        return v;
    };
    // Leaf [150,175]'s originals missing: it draws its atlas, flagged coarse.
    Selection s = selectDraws(f.index, f.camera, {}, allBut({f.index.nodes[9].texture_blocks[0]}));
    ASSERT_EQ(s.draws.size(), 8u);
    EXPECT_EQ(s.draws[1].node, 9);
    EXPECT_EQ(s.draws[1].mode, DrawMode::Atlas);
    EXPECT_TRUE(s.draws[1].coarse);
    EXPECT_EQ(s.coarse_draws, 1u);
    // A visible child of c2 missing its geometry: c2 cannot refine and draws its own atlas.
    s = selectDraws(f.index, f.camera, {}, allBut({f.index.nodes[14].layers[0].geometry}));
    EXPECT_EQ(nodesOf(s), (std::vector<std::pair<int, bool>>{{8, false}, {9, false}, {10, false}, {11, true}, {16, false}}));
    // Culled children missing do not block refinement (Fig. 30: "in memory or invisible").
    std::set<BlockId> culled;
    for (const int n : {1, 2, 3, 4, 5, 7})
        for (const BlockId b : {f.index.nodes[static_cast<size_t>(n)].layers[0].geometry, f.index.nodes[static_cast<size_t>(n)].layers[0].atlas})
            culled.insert(b);
    s = selectDraws(f.index, f.camera, {}, allBut(culled));
    EXPECT_EQ(s.draws.size(), 8u);
    EXPECT_EQ(s.coarse_draws, 0u);
    // c1's visible leaf missing: c1 draws coarse, the rest unchanged.
    s = selectDraws(f.index, f.camera, {}, allBut({f.index.nodes[10].layers[0].atlas}));
    EXPECT_EQ(nodesOf(s), (std::vector<std::pair<int, bool>>{{6, true}, {12, false}, {13, false}, {14, false}, {15, false}, {16, false}}));
    // Nothing below the root: the root alone, coarse.
    std::set<BlockId> below_root;
    for (BlockId b = 2; b < f.index.blocks.size(); ++b) below_root.insert(b);
    s = selectDraws(f.index, f.camera, {}, allBut(below_root));
    EXPECT_EQ(nodesOf(s), (std::vector<std::pair<int, bool>>{{0, true}}));
    // The root missing: nothing can be drawn, and the selection says so.
    s = selectDraws(f.index, f.camera, {}, allBut({f.index.nodes[0].layers[0].atlas}));
    EXPECT_TRUE(s.root_missing);
    EXPECT_TRUE(s.draws.empty());
}

// Texture blocks by view (papers/004 §2: a street-level view loads only the
// tiles it sees). Leaf 9 [150,175] (d = 10 < 25: drawn with originals) gets
// four blocks, sampled over sub-boxes of it whose usage follows by hand from
// the camera at (140, 50, 5) looking along +x with a 60 degree fov:
//   A x [150,155] y [48,52]  : d = 10, in view              -> Needed
//   B x [170,175] y [48,52]  : d = 30 in [25, 50), in view  -> Parent needed
//   C x [150,152] y [95,100] : 77 degrees off axis          -> Culled
//   D none (the mesh samples no texture of it)              -> Unused
// Leaf 10 [175,200] (d = 35 >= 25: sharp, prefetch within 50) gets A' at
// x [175,180] (d 35: Parent needed) and B' at x [195,200] (d 55: Unused).
struct ByView {
    Fixture f;
    TextureUseMap use;
    BlockId a = 0, b = 0, c = 0, d = 0, a2 = 0, b2 = 0;
    BlockId addBlock(int leaf) {
        TilesetIndex& ix = f.index;
        const auto k = static_cast<int32_t>(ix.texture_block_ids.size());
        ix.blocks.push_back({BlockKind::Textures, -1, -1, k, "t", 1000});
        ix.texture_block_ids.push_back(static_cast<BlockId>(ix.blocks.size() - 1));
        ix.nodes[static_cast<size_t>(leaf)].texture_blocks.push_back(ix.texture_block_ids.back());
        return ix.texture_block_ids.back();
    }
    ByView() {
        a = f.index.nodes[9].texture_blocks[0];
        b = addBlock(9);
        c = addBlock(9);
        d = addBlock(9);
        a2 = f.index.nodes[10].texture_blocks[0];
        b2 = addBlock(10);
        use.assign(f.index.blocks.size(), TextureUse{});
        use[f.index.nodes[9].layers[0].geometry] = {true, {{a, box(150, 48, 0, 155, 52, 10)},
                                                           {b, box(170, 48, 0, 175, 52, 10)},
                                                           {c, box(150, 95, 0, 152, 100, 10)}}};
        use[f.index.nodes[10].layers[0].geometry] = {true, {{a2, box(175, 48, 0, 180, 52, 10)},
                                                            {b2, box(195, 48, 0, 200, 52, 10)}}};
    }
    SelectionParams params() const {
        SelectionParams p;
        p.texture_use = &use;
        return p;
    }
};

TEST(Selection, TextureBlocksByWhatTheCameraSees) {
    ByView v;
    const Classification c = classifyBlocks(v.f.index, v.f.camera, v.params());
    EXPECT_STREQ(usageName(c.priority[v.a].usage), "needed");
    EXPECT_STREQ(usageName(c.priority[v.b].usage), "parent_needed");
    EXPECT_STREQ(usageName(c.priority[v.c].usage), "culled");
    EXPECT_STREQ(usageName(c.priority[v.d].usage), "unused");
    EXPECT_STREQ(usageName(c.priority[v.a2].usage), "parent_needed");
    EXPECT_STREQ(usageName(c.priority[v.b2].usage), "unused");
    // Each block by its own box's distance.
    EXPECT_DOUBLE_EQ(c.priority[v.a].key, 10);
    EXPECT_DOUBLE_EQ(c.priority[v.b].key, 30);
    EXPECT_DOUBLE_EQ(c.priority[v.a2].key, 35);

    // Without the boxes (or before the geometry is decoded) every block counts as the leaf.
    TextureUseMap unknown = v.use;
    unknown[v.f.index.nodes[9].layers[0].geometry].known = false;
    SelectionParams not_yet = v.params();
    not_yet.texture_use = &unknown;
    for (const SelectionParams& p : {SelectionParams{}, not_yet}) {
        const Classification u = classifyBlocks(v.f.index, v.f.camera, p);
        for (const BlockId blk : {v.a, v.b, v.c, v.d}) EXPECT_EQ(u.priority[blk].usage, Usage::Needed) << blk;
    }

    // Refinement needs only the Needed block: the leaf draws originals with
    // B, C and D missing (their triangles fall back to the atlas), not with A.
    const auto modeOf9 = [&](const Selection& s) {
        for (const DrawItem& d : s.draws)
            if (d.node == 9) return std::make_pair(d.mode, d.coarse);
        return std::make_pair(DrawMode::Atlas, true);
    };
    EXPECT_EQ(modeOf9(selectDraws(v.f.index, v.f.camera, v.params(), allBut({v.b, v.c, v.d}))),
              std::make_pair(DrawMode::Originals, false));
    EXPECT_EQ(modeOf9(selectDraws(v.f.index, v.f.camera, v.params(), allBut({v.a}))),
              std::make_pair(DrawMode::Atlas, true));
    // Without the boxes every block must be resident.
    EXPECT_EQ(modeOf9(selectDraws(v.f.index, v.f.camera, {}, allBut({v.c}))), std::make_pair(DrawMode::Atlas, true));
}

TEST(Selection, RefinementPossibleSemantics) {
    Fixture f;
    const Frustum fr = frustumOf(f.camera);
    const auto all = [](BlockId) { return true; };
    EXPECT_TRUE(refinementPossible(f.index, 0, fr, all));
    // Leaf: only its original textures matter.
    EXPECT_FALSE(refinementPossible(f.index, 8, fr, allBut({f.index.nodes[8].texture_blocks[0]})));
    EXPECT_TRUE(refinementPossible(f.index, 8, fr, allBut({f.index.nodes[8].layers[0].atlas})));
    // Inner: a visible child's atlas or geometry missing blocks it; an invisible child's does not.
    EXPECT_FALSE(refinementPossible(f.index, 6, fr, allBut({f.index.nodes[8].layers[0].atlas})));
    EXPECT_FALSE(refinementPossible(f.index, 6, fr, allBut({f.index.nodes[8].layers[0].geometry})));
    EXPECT_TRUE(refinementPossible(f.index, 6, fr, allBut({f.index.nodes[7].layers[0].atlas})));
    // Grandchildren do not matter to the root.
    EXPECT_TRUE(refinementPossible(f.index, 0, fr, allBut({f.index.nodes[8].layers[0].atlas})));
}

TEST(Selection, TauAndViewportChangeWhereRefinementStops) {
    Fixture f;
    SelectionParams coarse;
    coarse.tau = 2;  // threshold 50: c2 (d 60) is sharp enough
    Selection s = selectDraws(f.index, f.camera, coarse, [](BlockId) { return true; });
    bool c2_atlas = false;
    for (const DrawItem& d : s.draws) c2_atlas |= d.node == 11;
    EXPECT_TRUE(c2_atlas);
    Camera big = f.camera;
    big.width_px *= 2;
    big.height_px *= 2;  // threshold 200: c3 (d 160) refines
    s = selectDraws(f.index, big, {}, [](BlockId) { return true; });
    int c3_leaves = 0;
    for (const DrawItem& d : s.draws) c3_leaves += d.node >= 17 ? 1 : 0;
    EXPECT_EQ(c3_leaves, 4);
}

}  // namespace
}  // namespace cityatlas::render

namespace cityatlas::render {
namespace {

// Computed textures (issue 19, papers/000 §5.1.3, M5): two per node layer.
// The shown one's blocks take their node's usage and priority; the other's,
// and all of them with none shown, are Unused, so never candidates; nodes
// stay drawable without them (the photo stands in).
TEST(Selection, OnlyTheShownComputedTextureIsUsedAndDrawingNeverWaitsForIt) {
    Fixture f;
    for (TileNode& n : f.index.nodes)
        for (int k = 0; k < 2; ++k) {
            f.index.blocks.push_back({BlockKind::Computed, n.id, 0, k, "c", 250});
            n.layers[0].computed.push_back(static_cast<BlockId>(f.index.blocks.size() - 1));
        }
    auto computedUse = [&](const Classification& c, int node, int k) {
        return c.priority[f.index.nodes[static_cast<size_t>(node)].layers[0].computed[static_cast<size_t>(k)]];
    };
    const Classification none = classifyBlocks(f.index, f.camera, {});
    for (const TileNode& n : f.index.nodes)
        for (int k = 0; k < 2; ++k) EXPECT_EQ(computedUse(none, n.id, k).usage, Usage::Unused) << "node " << n.id;
    for (const BlockId b : none.candidates) EXPECT_NE(f.index.blocks[b].kind, BlockKind::Computed);

    SelectionParams shown;
    shown.computed = 1;
    const Classification c = classifyBlocks(f.index, f.camera, shown);
    int used = 0;
    for (const TileNode& n : f.index.nodes) {
        const BlockPriority& atlas = c.priority[n.layers[0].atlas];
        const BlockPriority& mine = computedUse(c, n.id, 1);
        EXPECT_EQ(mine.usage, atlas.usage) << "node " << n.id;
        EXPECT_EQ(mine.key, atlas.key) << "node " << n.id;
        EXPECT_EQ(mine.level, atlas.level) << "node " << n.id;
        EXPECT_EQ(computedUse(c, n.id, 0).usage, Usage::Unused) << "node " << n.id;
        used += mine.usage != Usage::Unused;
    }
    EXPECT_EQ(used, 17);  // the nodes whose atlas is used: 21 minus the 4 Unused leaves of c0
    // Same candidates as without, plus the shown computed texture's blocks.
    EXPECT_EQ(c.candidates.size(), none.candidates.size() + 17);

    // Drawable with geometry and atlas alone; the selection is the same.
    const auto photo_only = [&](BlockId b) { return f.index.blocks[b].kind != BlockKind::Computed; };
    const Selection with = selectDraws(f.index, f.camera, shown, photo_only);
    const Selection without = selectDraws(f.index, f.camera, {}, photo_only);
    EXPECT_FALSE(with.root_missing);
    ASSERT_EQ(with.draws.size(), without.draws.size());
    for (size_t i = 0; i < with.draws.size(); ++i) EXPECT_EQ(with.draws[i].node, without.draws[i].node);
}

}  // namespace
}  // namespace cityatlas::render
