// SPDX-License-Identifier: GPL-3.0-or-later
// innerGeometry's cap (tiles/node_geometry.h): a merge whose children hold
// more than mergeMaxTriangles(budget) triangles leaves whole buildings out,
// smallest first, before it is built, so what one merge holds is bounded
// whatever the city's density.
//
// The children here are boxes of known sizes far apart, with a texel far
// below them: the texel rule leaves none out and no collapse fits the bound,
// so what the merge keeps is decided by the cap alone and is known exactly.
#include "tiles/node_geometry.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <memory>
#include <set>
#include <vector>

namespace cityatlas::tiles {
namespace {

// A closed axis-aligned box of side `side` at x = `x`: 8 vertices, 12 triangles.
void addBox(TileMesh& m, uint32_t feature, double x, double side) {
    const auto base = static_cast<uint32_t>(m.positions.size());
    for (int k = 0; k < 8; ++k) {
        m.positions.push_back({x + ((k & 1) ? side : 0.0), (k & 2) ? side : 0.0, (k & 4) ? side : 0.0});
        m.uv_atlas.push_back({});
        m.feature_id.push_back(feature);
        m.texture_id.push_back(-1);
        m.material_id.push_back(0);
    }
    static constexpr uint32_t kFaces[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                                               {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
    for (const auto& f : kFaces)
        for (uint32_t v : f) m.indices.push_back(base + v);
}

// A root and four children, each layer a 1 x 1 atlas (the atlas coordinates
// are not what is tested).
atlas::AtlasTree fourChildren() {
    atlas::AtlasTree tree;
    tree.nodes.resize(5);
    for (int32_t q = 0; q < 4; ++q) {
        tree.nodes[0].children[static_cast<size_t>(q)] = q + 1;
        tree.nodes[static_cast<size_t>(q + 1)].parent = 0;
        tree.nodes[static_cast<size_t>(q + 1)].level = 1;
    }
    for (atlas::AtlasNode& n : tree.nodes)
        for (atlas::NodeLayer& l : n.layers) l.width = l.height = 1;
    return tree;
}

using Children = std::array<std::unique_ptr<NodeGeometry>, 4>;

// Buildings 0..n-1 of side 1 + id metres, dealt to the children in turn.
Children boxes(uint32_t n) {
    Children c;
    for (auto& g : c) g = std::make_unique<NodeGeometry>();
    for (uint32_t f = 0; f < n; ++f) addBox(c[f % 4]->mesh, f, 100.0 * f, 1.0 + f);
    return c;
}

std::set<uint32_t> drawn(const NodeGeometry& g) {
    const std::vector<uint32_t> f = distinctFeatures(g.mesh);
    return {f.begin(), f.end()};
}

constexpr double kTexel = 1e-3;  // far below every box: no texel rule, no collapse

TEST(NodeGeometry, TheCapIsSixtyFourBudgetsWithinTwoMillionTriangles) {
    EXPECT_EQ(mergeMaxTriangles(32768), size_t{2097152});  // the default budget
    EXPECT_EQ(mergeMaxTriangles(4), size_t{256});
    EXPECT_EQ(mergeMaxTriangles(100000), size_t{2097152});       // a larger budget keeps the bound
    EXPECT_EQ(mergeMaxTriangles(size_t{1} << 22), size_t{1} << 22);  // never below the budget itself
}

// 40 boxes (480 triangles) into a merge that takes 256: the 19 smallest go
// (480 - 19 * 12 = 252), whatever their size against the texel; the error is
// the largest left out's diagonal.
TEST(NodeGeometry, AMergeAboveTheCapLeavesOutWholeBuildingsSmallestFirst) {
    const atlas::AtlasTree tree = fourChildren();
    const NodeGeometry g = innerGeometry(tree, 0, atlas::Layer::Opaque, boxes(40), 4, kTexel);
    EXPECT_EQ(g.left_out_over_cap, 19u);
    EXPECT_EQ(g.mesh.indices.size() / 3, 21u * 12u);
    std::set<uint32_t> largest;
    for (uint32_t f = 19; f < 40; ++f) largest.insert(f);
    EXPECT_EQ(drawn(g), largest);
    EXPECT_NEAR(g.geometric_error_m, 19.0 * std::sqrt(3.0), 1e-9);  // building 18: side 19 m
    EXPECT_FALSE(g.simplified);  // no collapse fits a millimetre
}

// At the cap exactly nothing goes, and the estimate the gate waits on stops
// at the cap: a merge of 480 triangles waits for as much as one of 256.
TEST(NodeGeometry, AtTheCapNothingIsLeftOutAndTheEstimateStopsThere) {
    const atlas::AtlasTree tree = fourChildren();
    Children at_cap = boxes(21);  // 252 triangles
    addBox(at_cap[0]->mesh, 99, -1000.0, 50.0);  // 264 > 256: over by one box
    Children below = boxes(21);
    const size_t below_estimate = mergeEstimateBytes(below, 4);
    EXPECT_GT(below_estimate, 0u);
    EXPECT_EQ(mergeEstimateBytes(boxes(40), 4), below_estimate / 252 * 256);
    EXPECT_EQ(mergeEstimateBytes(at_cap, 4), below_estimate / 252 * 256);
    const NodeGeometry g = innerGeometry(tree, 0, atlas::Layer::Opaque, std::move(below), 4, kTexel);
    EXPECT_EQ(g.left_out_over_cap, 0u);
    EXPECT_EQ(drawn(g).size(), 21u);
    EXPECT_NEAR(g.geometric_error_m, 0.0, 1e-12);
    const NodeGeometry over = innerGeometry(tree, 0, atlas::Layer::Opaque, std::move(at_cap), 4, kTexel);
    EXPECT_EQ(over.left_out_over_cap, 1u);  // building 0, the smallest: 252 left
    EXPECT_FALSE(drawn(over).count(0));
    EXPECT_TRUE(drawn(over).count(99));
}

// One building larger than the cap stays (a node must show something): the
// others go, it does not.
TEST(NodeGeometry, TheLastBuildingStaysEvenAboveTheCap) {
    const atlas::AtlasTree tree = fourChildren();
    Children c;
    c[0] = std::make_unique<NodeGeometry>();
    c[2] = std::make_unique<NodeGeometry>();
    for (int k = 0; k < 6; ++k) addBox(c[0]->mesh, 7, 20.0 * k, 10.0);  // one building, 72 triangles
    addBox(c[2]->mesh, 3, 500.0, 1.0);
    const NodeGeometry g = innerGeometry(tree, 0, atlas::Layer::Opaque, std::move(c), 1, kTexel);  // cap 64
    EXPECT_EQ(g.left_out_over_cap, 1u);
    EXPECT_EQ(drawn(g), std::set<uint32_t>{7});
    EXPECT_EQ(g.mesh.indices.size() / 3, 72u);
    EXPECT_NEAR(g.geometric_error_m, std::sqrt(3.0), 1e-9);
}

}  // namespace
}  // namespace cityatlas::tiles
