// SPDX-License-Identifier: GPL-3.0-or-later
#include "atlas/placement.h"

#include <algorithm>
#include <cmath>
#include <tuple>

namespace cityatlas::atlas {
namespace {

int halfInBlocks(int texels) { return (texels / 2 + 3) / 4; }  // half the side, whole 4x4 blocks

// Widths (or heights) a bin of up to four items can usefully have: the sums of
// subsets of the items' sides, no larger than `max`.
std::vector<int> subsetSums(const std::vector<int>& sides, int max) {
    std::vector<int> sums;
    const size_t n = sides.size();
    for (uint32_t mask = 1; mask < (1u << n); ++mask) {
        int s = 0;
        for (size_t k = 0; k < n; ++k)
            if (mask & (1u << k)) s += sides[k];
        if (s <= max) sums.push_back(s);
    }
    sums.push_back(max);
    std::sort(sums.begin(), sums.end());
    sums.erase(std::unique(sums.begin(), sums.end()), sums.end());
    return sums;
}

}  // namespace

Vec2d NodeLayer::texelFromRoot(const Vec2d& root, int level, int atlas_size) const {
    const double scale = std::ldexp(static_cast<double>(atlas_size), level);
    return {root.x * scale - static_cast<double>(offset[0]), root.y * scale - static_cast<double>(offset[1])};
}

Vec2d NodeLayer::localFromRoot(const Vec2d& root, int level, int atlas_size) const {
    const Vec2d t = texelFromRoot(root, level, atlas_size);
    return {width > 0 ? t.x / width : 0.0, height > 0 ? t.y / height : 0.0};
}

BinSize shrinkLeafAtlas(PackingMethod method, int atlas_size, std::vector<PackedRegion>& regions) {
    const int blocks = atlas_size / 4;
    if (regions.empty()) return {atlas_size, atlas_size};
    std::vector<PackItem> items;
    items.reserve(regions.size());
    for (const PackedRegion& r : regions) {
        const int w = r.rotated ? r.h : r.w, h = r.rotated ? r.w : r.h;  // as planned, before any turn
        items.push_back({w / 4, h / 4});
    }
    const std::vector<BinSize> bins = binsByArea(std::max(1, blocks / 16), blocks, blocks, 2.0);
    std::vector<Placement> placed;
    const std::optional<BinSize> bin = packSmallest(method, items, bins, true, &placed);
    if (!bin) return {atlas_size, atlas_size};  // keeps the A x A layout it was given
    for (size_t k = 0; k < regions.size(); ++k) {
        PackedRegion& r = regions[k];
        const int w = items[k].w * 4, h = items[k].h * 4;
        r.x = placed[k].x * 4, r.y = placed[k].y * 4, r.rotated = placed[k].rotated;
        r.w = r.rotated ? h : w, r.h = r.rotated ? w : h;
    }
    return {bin->w * 4, bin->h * 4};
}

void placeAtlases(AtlasTree& tree) {
    const int a = tree.params.atlas_size_px, blocks = a / 4;
    // Bottom-up: children are numbered after their parent.
    std::vector<std::array<std::vector<ChildPlacement>, kLayerCount>> placed(tree.nodes.size());
    for (size_t id = tree.nodes.size(); id-- > 0;) {
        AtlasNode& n = tree.nodes[id];
        if (n.leaf()) continue;
        for (int l = 0; l < kLayerCount; ++l) {
            NodeLayer& nl = n.layers[l];
            nl.width = nl.height = 0;
            if (!nl.present()) continue;
            std::vector<PackItem> items;
            std::vector<int32_t> who;
            for (int32_t c : n.children) {
                if (c < 0) continue;
                const NodeLayer& cl = tree.nodes[c].layers[l];
                if (cl.width <= 0 || cl.height <= 0) continue;
                items.push_back({halfInBlocks(cl.width), halfInBlocks(cl.height)});
                who.push_back(c);
            }
            std::vector<int> ws, hs;
            int64_t area = 0;
            int max_w = 0, max_h = 0;
            for (const PackItem& it : items) {
                ws.push_back(it.w), hs.push_back(it.h);
                area += int64_t{it.w} * it.h;
                max_w = std::max(max_w, it.w), max_h = std::max(max_h, it.h);
            }
            std::vector<BinSize> bins;
            for (int w : subsetSums(ws, blocks))
                for (int h : subsetSums(hs, blocks))
                    if (w >= max_w && h >= max_h && int64_t{w} * h >= area) bins.push_back({w, h});
            std::sort(bins.begin(), bins.end(), [](const BinSize& x, const BinSize& y) {
                return std::make_tuple(int64_t{x.w} * x.h, std::max(x.w, x.h), -x.w) <
                       std::make_tuple(int64_t{y.w} * y.h, std::max(y.w, y.h), -y.w);
            });
            std::vector<Placement> where;
            std::optional<BinSize> bin = packSmallest(PackingMethod::MaxRects, items, bins, false, &where);
            if (!bin) {
                // Four halves of at most A/2 x A/2 always fit as quadrants.
                bin = BinSize{blocks, blocks};
                where.clear();
                for (int32_t c : who) {
                    int q = 0;
                    while (n.children[q] != c) ++q;
                    where.push_back({(q & 1) * blocks / 2, (q >> 1) * blocks / 2, false});
                }
            }
            nl.width = bin->w * 4, nl.height = bin->h * 4;
            for (size_t k = 0; k < who.size(); ++k) placed[id][l].push_back({who[k], where[k].x * 4, where[k].y * 4});
        }
    }
    // Top-down offsets.
    for (size_t id = 0; id < tree.nodes.size(); ++id) {
        AtlasNode& n = tree.nodes[id];
        if (id == 0)
            for (NodeLayer& nl : n.layers) nl.offset = {0, 0};
        for (int l = 0; l < kLayerCount; ++l) {
            for (int32_t c : n.children)
                if (c >= 0) tree.nodes[c].layers[l].offset = {2 * n.layers[l].offset[0], 2 * n.layers[l].offset[1]};
            for (const ChildPlacement& p : placed[id][l])
                tree.nodes[p.child].layers[l].offset = {2 * (n.layers[l].offset[0] + p.x),
                                                        2 * (n.layers[l].offset[1] + p.y)};
        }
    }
}

std::vector<ChildPlacement> childPlacements(const AtlasTree& tree, int32_t node, int layer) {
    std::vector<ChildPlacement> out;
    const AtlasNode& n = tree.nodes[static_cast<size_t>(node)];
    const NodeLayer& nl = n.layers[static_cast<size_t>(layer)];
    for (int32_t c : n.children) {
        if (c < 0) continue;
        const NodeLayer& cl = tree.nodes[static_cast<size_t>(c)].layers[static_cast<size_t>(layer)];
        if (cl.width <= 0 || cl.height <= 0) continue;
        out.push_back({c, static_cast<int>(cl.offset[0] / 2 - nl.offset[0]), static_cast<int>(cl.offset[1] / 2 - nl.offset[1])});
    }
    return out;
}

}  // namespace cityatlas::atlas
