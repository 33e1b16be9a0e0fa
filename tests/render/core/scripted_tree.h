// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Hand-made atlas trees for the render core's tests: boxes, min distances and
// block sizes chosen so the expected usage of every block follows from the
// papers' definitions by hand (each test says how).

#include <functional>
#include <vector>

#include "render/core/tileset_index.h"
#include "render/core/view.h"

namespace cityatlas::render::test {

struct ScriptedNode {
    Box3d box;
    double min_distance_m = 0;
    std::vector<int> children;  ///< indices into the script (preorder is rebuilt)
    bool texture_block = false; ///< a leaf with its own block of original textures
};

/// A camera whose focal length and corner factor the scripted build shares,
/// so distanceScale() is exactly 1 at tau 1.
inline Camera unitCamera(const Vec3d& position, const Vec3d& direction) {
    Camera c;
    c.position = position;
    c.direction = direction;
    c.up = {0, 0, 1};
    c.vertical_fov_deg = 60;
    c.width_px = 800;
    c.height_px = 800;
    c.near_m = 0.5;
    c.far_m = 1e5;
    return c;
}

inline BuildInfo buildFor(const Camera& c) {
    BuildInfo b;
    b.d_min_m = 1;
    b.atlas_size_px = 256;
    b.screen_width_px = c.width_px;
    b.screen_height_px = c.height_px;
    b.vertical_fov_deg = c.vertical_fov_deg;
    b.focal_px = c.focalPx();
    b.corner_factor = c.cornerFactor();
    b.tau = 1;
    return b;
}

inline Box3d box(double x0, double y0, double z0, double x1, double y1, double z1) {
    Box3d b;
    b.min = {x0, y0, z0};
    b.max = {x1, y1, z1};
    return b;
}

/// Builds the index: every node one opaque layer (geometry `geometry_bytes`,
/// atlas `atlas_bytes`); leaves flagged with texture_block get one texture block
/// of `texture_bytes`. Nodes keep the script's preorder (script[0] is the root,
/// children listed in preorder).
inline TilesetIndex makeIndex(const std::vector<ScriptedNode>& script, const BuildInfo& build, uint64_t geometry_bytes = 100,
                              uint64_t atlas_bytes = 1000, uint64_t texture_bytes = 4000) {
    TilesetIndex ix;
    ix.build = build;
    ix.nodes.resize(script.size());
    for (size_t i = 0; i < script.size(); ++i) {
        TileNode& n = ix.nodes[i];
        n.id = static_cast<int32_t>(i);
        n.bounds = script[i].box;
        n.centre = 0.5 * (script[i].box.min + script[i].box.max);
        n.min_distance_m = script[i].min_distance_m;
        for (const int c : script[i].children) {
            n.children.push_back(c);
            ix.nodes[static_cast<size_t>(c)].parent = static_cast<int32_t>(i);
        }
    }
    std::function<void(int, int)> levels = [&](int id, int level) {
        ix.nodes[static_cast<size_t>(id)].level = level;
        ix.depth = std::max(ix.depth, level);
        for (const int c : ix.nodes[static_cast<size_t>(id)].children) levels(c, level + 1);
    };
    levels(0, 0);
    for (size_t i = 0; i < script.size(); ++i) {
        NodeLayer& l = ix.nodes[i].layers[0];
        l.present = true;
        l.triangles = 10;
        l.atlas_width_px = l.atlas_height_px = 256;
        ix.blocks.push_back({BlockKind::Geometry, static_cast<int32_t>(i), 0, -1, "g", geometry_bytes});
        l.geometry = static_cast<BlockId>(ix.blocks.size() - 1);
        ix.blocks.push_back({BlockKind::Atlas, static_cast<int32_t>(i), 0, -1, "a", atlas_bytes});
        l.atlas = static_cast<BlockId>(ix.blocks.size() - 1);
    }
    for (size_t i = 0; i < script.size(); ++i) {
        if (!script[i].texture_block) continue;
        const auto k = static_cast<int32_t>(ix.texture_block_ids.size());
        ix.blocks.push_back({BlockKind::Textures, -1, -1, k, "t", texture_bytes});
        ix.texture_block_ids.push_back(static_cast<BlockId>(ix.blocks.size() - 1));
        ix.nodes[i].texture_blocks.push_back(ix.texture_block_ids.back());
    }
    for (const BlockInfo& b : ix.blocks) ix.bytes_total += b.bytes;
    return ix;
}

/// A complete quadtree over [0, size]^2 x [0, height], `depth` levels below the
/// root, min distance halving per level from `root_min_distance`, every leaf
/// with a texture block.
inline std::vector<ScriptedNode> quadtree(int depth, double size, double height, double root_min_distance) {
    std::vector<ScriptedNode> script;
    std::function<int(double, double, double, int)> add = [&](double x, double y, double s, int level) -> int {
        const int id = static_cast<int>(script.size());
        script.push_back({box(x, y, 0, x + s, y + s, height), root_min_distance / (1 << level), {}, level == depth});
        if (level < depth) {
            const double h = s / 2;
            for (const auto& [dx, dy] : {std::pair{0.0, 0.0}, {h, 0.0}, {0.0, h}, {h, h}}) {
                const int c = add(x + dx, y + dy, h, level + 1);
                script[static_cast<size_t>(id)].children.push_back(c);
            }
        }
        return id;
    };
    add(0, 0, size, 0);
    return script;
}

/// test_selection's tree: root [0,400] x [0,100] x [0,20] (min distance
/// 1000), four children 100 m wide along x (100), each with four leaves 25 m
/// wide (25, a texture block each). Node ids in preorder: root 0; c0 1
/// (leaves 2-5), c1 6 (7-10), c2 11 (12-15), c3 16 (17-20).
inline std::vector<ScriptedNode> rowTree() {
    std::vector<ScriptedNode> s;
    s.push_back({box(0, 0, 0, 400, 100, 20), 1000, {}, false});
    for (int c = 0; c < 4; ++c) {
        const int child = static_cast<int>(s.size());
        s[0].children.push_back(child);
        s.push_back({box(100.0 * c, 0, 0, 100.0 * (c + 1), 100, 20), 100, {}, false});
        for (int l = 0; l < 4; ++l) {
            s[static_cast<size_t>(child)].children.push_back(static_cast<int>(s.size()));
            const double x0 = 100.0 * c + 25.0 * l;
            s.push_back({box(x0, 0, 0, x0 + 25, 100, 20), 25, {}, true});
        }
    }
    return s;
}

}  // namespace cityatlas::render::test
